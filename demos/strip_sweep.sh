#!/usr/bin/env bash
# Frequency sweep of the bidirectional magnetic strip (demos/bidirectional_strip.toml):
# one `rftfem run --set magnetic.field.frequency=F` per frequency, then the plot of
# the steady swimming speed against F with the speed peak and any stepped-out run (the
# moment slips behind the field) and any failed run marked (sweep.png, sweep.csv).
# The default frequencies reach past step-out: the moment followed the field at
# 64 Hz and slipped at 128 Hz (the rigid-rotor estimate, 287 Hz, is higher).
# Each run costs 100 steps per period, the ramp included (demos/strip_convergence.sh:
# 100 are within 0.3 % of 200 at every frequency, where 50 were 1-12 % off and, for the
# step halvings the magnetized ends' flips forced, slower).
# Outputs in the sweep folder: runs.csv (`rftfem collect`: one row per run with its
# status and failure reason, frequency, counts, wall time, steady and window speeds
# along Z),
# sweep.csv and sweep.png (demos/bidirectional_strip.py --sweep: speed and slip).
#
#   demos/strip_sweep.sh                       # serial, into results/strip_sweep
#   NP=2 demos/strip_sweep.sh                  # each run under mpirun -n 2
#   FIELDS=true demos/strip_sweep.sh           # fields for ParaView too (23 MB a frequency)
#   FREQS="2 4 8" PERIODS=6 demos/strip_sweep.sh results/my_sweep --set mesh.divisions=[30,4]
#
# Each run goes on until its swim is steady (time.until = "periodic": the period
# means of its outputs are watched and their limit extrapolated, docs/model.md
# §6.13), and its speed is the steady centroid speed along the axis: the strip
# keeps curling for periods after the ramp (at 4 Hz it moves at -7.9 mm/s over
# the first two periods and settles to -1.57), so a mean over a fixed window
# measures the transient.  A run may go on for at most PERIODS field periods
# (default 24) but at least WINDOW seconds (default 0.2) after the ramp; one that
# is not steady by then is measured over its window from SETTLE seconds (default
# 0.1) after the ramp, and marked.  The slip is measured over that window too.
# STEPS steps per period (default 100), the ramp included. The runs write their
# rows (probes, body, steps) but no fields for ParaView unless FIELDS=true: fields
# at every step were a quarter of a run's time and 23 MB a frequency.  Runs that already
# finished (summary.json says "ok") are not repeated.
set -euo pipefail
# rftfem from the repository's .venv when it is not on PATH
source "$(dirname "${BASH_SOURCE[0]}")/../scripts/use_repository_env.sh"

HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
SCENE="$HERE/bidirectional_strip.toml"
OUT="${1:-results/strip_sweep}"
[[ $# -gt 0 ]] && shift
FREQS="${FREQS:-2 4 8 16 32 64 128}"
PERIODS="${PERIODS:-24}"
SETTLE="${SETTLE:-0.1}"
WINDOW="${WINDOW:-0.2}"
STEPS="${STEPS:-100}"
NP="${NP:-1}"
FIELDS="${FIELDS:-false}"
PYTHON="${PYTHON:-python3}"

launcher=()
if [[ "$NP" -gt 1 ]]; then
    launcher=(mpirun -n "$NP")
fi
ramp=$(grep -E '^ramp_time' "$SCENE" | head -1 | sed -E 's/^ramp_time *= *([0-9.eE+-]+).*/\1/')

mkdir -p "$OUT"
for f in $FREQS; do
    dir="$OUT/f$f"
    if [[ -f "$dir/summary.json" ]] && grep -q '"status": "ok"' "$dir/summary.json"; then
        echo "f = $f Hz: done before, kept ($dir)"
        continue
    fi
    end=$(awk -v r="$ramp" -v w="$WINDOW" -v f="$f" -v n="$PERIODS" \
        'BEGIN { m = n / f; if (m < w) m = w; printf "%.10g", r + m }')
    dt=$(awk -v f="$f" -v s="$STEPS" 'BEGIN { printf "%.10g", 1 / (f * s) }')
    echo "f = $f Hz: until steady, at most t = $end s, dt = $dt s -> $dir"
    # a failed run (exit 3) keeps its outputs; the sweep goes on and the plot uses
    # what each run wrote
    "${launcher[@]}" rftfem run "$SCENE" --out "$dir" --quiet \
        --set "magnetic.field.frequency=$f" --set "time.end=$end" --set "time.dt=$dt" \
        --set "time.output_every=1" --set "time.until=periodic" \
        --set "output.fields=$FIELDS" "$@" \
        || echo "f = $f Hz: run failed (see $dir/summary.json)"
done

# The table of the runs (rftfem collect): the steady speed of the centroid along Z,
# the scene's rotation axis (empty where a run was not steady by its end), and the
# mean rate from SETTLE seconds after the ramp to the end of the run (where a
# failed run stopped; empty if it stopped before the window).
start=$(awk -v r="$ramp" -v s="$SETTLE" 'BEGIN { printf "%.10g", r + s }')
runs=()
for f in $FREQS; do
    if [[ -f "$OUT/f$f/summary.json" || -f "$OUT/f$f/body.csv" ]]; then
        runs+=("$OUT/f$f")
    fi
done
if [[ ${#runs[@]} -gt 0 ]]; then
    rftfem collect "${runs[@]}" --out "$OUT/runs.csv" \
        --quantity "steady_speed_mm_s=steady(centroid_z_rate)" \
        --quantity "window_speed_mm_s=rate(centroid_z, $start)"
fi
# The plot, and the slip of the moment behind the field (unwrapped angles of
# body.csv's field and moment about the axis), by the demo's own code
"$PYTHON" "$HERE/bidirectional_strip.py" --sweep "$OUT" --settle "$SETTLE"
