#!/usr/bin/env bash
# Frequency sweep of the bidirectional magnetic strip (demos/bidirectional_strip.toml):
# one `rftfem run --set magnetic.field.frequency=F` per frequency, then the plot of
# mean swimming speed against F with the speed peak and any stepped-out run (the
# moment slips behind the field) and any failed run marked (sweep.png, sweep.csv).
# The default frequencies reach past step-out: the moment followed the field at
# 64 Hz and slipped at 128 Hz (the rigid-rotor estimate, 287 Hz, is higher).
# Each run costs 100 steps per period, the ramp included (demos/strip_convergence.sh:
# 100 are within 0.3 % of 200 at every frequency, where 50 were 1-12 % off and, for the
# step halvings the magnetized ends' flips forced, slower).
# Outputs in the sweep folder: runs.csv (`rftfem collect`: one row per run with its
# status and failure reason, frequency, counts, wall time and mean speed along Z),
# sweep.csv and sweep.png (demos/bidirectional_strip.py --sweep: speed and slip).
#
#   demos/strip_sweep.sh                       # serial, into results/strip_sweep
#   NP=2 demos/strip_sweep.sh                  # each run under mpirun -n 2
#   FREQS="2 4 8" PERIODS=6 demos/strip_sweep.sh results/my_sweep --set mesh.divisions=[30,4]
#
# Phase 2 of each run starts with SETTLE seconds (default 0.1) in which the strip
# finishes curling after the ramp (in a static field its centroid still moves
# 0.3 mm along the axis in the first 0.05 s after the ramp, and settles within
# 0.1 s).  The speed and the slip are measured over the window that follows:
# PERIODS field periods (default 8), but at least WINDOW seconds (default 0.1).
# STEPS steps per period (default 100), the ramp included.  Runs that already
# finished (summary.json says "ok") are not repeated.
set -euo pipefail
# rftfem from the repository's .venv when it is not on PATH
source "$(dirname "${BASH_SOURCE[0]}")/../scripts/use_repository_env.sh"

HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
SCENE="$HERE/bidirectional_strip.toml"
OUT="${1:-results/strip_sweep}"
[[ $# -gt 0 ]] && shift
FREQS="${FREQS:-2 4 8 16 32 64 128}"
PERIODS="${PERIODS:-8}"
SETTLE="${SETTLE:-0.1}"
WINDOW="${WINDOW:-0.1}"
STEPS="${STEPS:-100}"
NP="${NP:-1}"
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
    end=$(awk -v r="$ramp" -v s="$SETTLE" -v w="$WINDOW" -v f="$f" -v n="$PERIODS" \
        'BEGIN { m = n / f; if (m < w) m = w; printf "%.10g", r + s + m }')
    dt=$(awk -v f="$f" -v s="$STEPS" 'BEGIN { printf "%.10g", 1 / (f * s) }')
    echo "f = $f Hz: t_end = $end s, dt = $dt s -> $dir"
    # a failed run (exit 3) keeps its outputs; the sweep goes on and the plot uses
    # what each run wrote
    "${launcher[@]}" rftfem run "$SCENE" --out "$dir" --quiet \
        --set "magnetic.field.frequency=$f" --set "time.end=$end" --set "time.dt=$dt" \
        --set "time.output_every=1" "$@" || echo "f = $f Hz: run failed (see $dir/summary.json)"
done

# The table of the runs (rftfem collect): the speed is the mean rate of the centroid
# along Z, the scene's rotation axis, from SETTLE seconds after the ramp to the end
# of the run (where a failed run stopped; empty if it stopped before the window).
start=$(awk -v r="$ramp" -v s="$SETTLE" 'BEGIN { printf "%.10g", r + s }')
runs=()
for f in $FREQS; do
    if [[ -f "$OUT/f$f/summary.json" || -f "$OUT/f$f/body.csv" ]]; then
        runs+=("$OUT/f$f")
    fi
done
if [[ ${#runs[@]} -gt 0 ]]; then
    rftfem collect "${runs[@]}" --out "$OUT/runs.csv" \
        --quantity "mean_speed_mm_s=rate(centroid_z, $start)"
fi
# The plot, and the slip of the moment behind the field (unwrapped angles of
# body.csv's field and moment about the axis), by the demo's own code
"$PYTHON" "$HERE/bidirectional_strip.py" --sweep "$OUT" --settle "$SETTLE"
