#!/usr/bin/env bash
# How converged is the strip sweep (demos/strip_sweep.sh)?  For each field frequency,
# `rftfem study` runs the sweep's run at STEPS steps per period and at 2 and 4 times
# as many (--refine dt --levels 3), and reports the mean swimming speed along Z over
# the sweep's window with its change per level, observed order and Richardson error
# estimate.  Then one table of all frequencies: convergence.md and convergence.csv.
#
#   demos/strip_convergence.sh                          # into results/strip_convergence
#   JOBS=2 demos/strip_convergence.sh                   # two frequencies at a time
#   FREQS="4 16" LEVELS=4 demos/strip_convergence.sh results/conv
#
# The window is the sweep's: from SETTLE (0.1 s) after the ramp, PERIODS field periods
# (8) but at least WINDOW seconds (0.1).  With the defaults (2 to 128 Hz, 50/100/200
# steps per period) it costs about 2 hours of one core.  Levels that finished before
# are kept (rftfem study --reuse): a second call only redoes the tables.
set -euo pipefail
# rftfem from the repository's .venv when it is not on PATH
source "$(dirname "${BASH_SOURCE[0]}")/../scripts/use_repository_env.sh"

HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
SCENE="$HERE/bidirectional_strip.toml"
OUT="${1:-results/strip_convergence}"
[[ $# -gt 0 ]] && shift
FREQS="${FREQS:-2 4 8 16 32 64 128}"
PERIODS="${PERIODS:-8}"
SETTLE="${SETTLE:-0.1}"
WINDOW="${WINDOW:-0.1}"
STEPS="${STEPS:-50}"
LEVELS="${LEVELS:-3}"
JOBS="${JOBS:-1}"
PYTHON="${PYTHON:-python3}"
export SCENE OUT PERIODS SETTLE WINDOW STEPS LEVELS

ramp=$(grep -E '^ramp_time' "$SCENE" | head -1 | sed -E 's/^ramp_time *= *([0-9.eE+-]+).*/\1/')
export ramp
mkdir -p "$OUT"

one() {
    local f=$1
    local end dt start
    end=$(awk -v r="$ramp" -v s="$SETTLE" -v w="$WINDOW" -v f="$f" -v n="$PERIODS" \
        'BEGIN { m = n / f; if (m < w) m = w; printf "%.10g", r + s + m }')
    dt=$(awk -v f="$f" -v s="$STEPS" 'BEGIN { printf "%.10g", 1 / (f * s) }')
    start=$(awk -v r="$ramp" -v s="$SETTLE" 'BEGIN { printf "%.10g", r + s }')
    echo "f = $f Hz: t_end = $end s, dt = $dt s and finer -> $OUT/f$f"
    rftfem study "$SCENE" --out "$OUT/f$f" --refine dt --levels "$LEVELS" --reuse \
        --set "magnetic.field.frequency=$f" --set "time.end=$end" --set "time.dt=$dt" \
        --set "time.output_every=1" \
        --quantity "speed=rate(centroid_z, $start, $end)" > "$OUT/f$f.log" 2>&1 \
        || echo "f = $f Hz: study failed (see $OUT/f$f.log)"
}
export -f one
printf '%s\n' $FREQS | xargs -P "$JOBS" -I{} bash -c 'one {}'

# one table: a row per frequency and level
"$PYTHON" - "$OUT" $FREQS <<'EOF'
import csv, sys
from pathlib import Path

out, freqs = Path(sys.argv[1]), sys.argv[2:]
rows = []
for f in freqs:
    path = out / f"f{f}" / "study.csv"
    if not path.is_file():
        rows.append({"f_hz": f, "status": "no study"})
        continue
    for r in csv.DictReader(open(path)):
        rows.append({"f_hz": f, **r})
keys = list(dict.fromkeys(k for r in rows for k in r))
with open(out / "convergence.csv", "w", newline="") as fh:
    w = csv.DictWriter(fh, fieldnames=keys)
    w.writeheader()
    w.writerows(rows)

def num(r, k, spec):
    v = r.get(k, "")
    return format(float(v), spec) if v not in ("", None) else ""

lines = ["| f (Hz) | steps per period | steps | dt cuts | wall (s) | speed (mm/s) | change | "
         "observed order | error estimate |", "|" + " --- |" * 9]
for r in rows:
    if r.get("status") != "ok":
        lines.append(f"| {r['f_hz']} | | | | | {r.get('status')}: {r.get('failure', '')} | | | |")
        continue
    spp = round(1 / (float(r["f_hz"]) * float(r["dt"])))
    change = num(r, "change", "+.3g")
    rel = (f" ({100 * float(r['change']) / abs(float(r['value'])):+.1f} %)"
           if r.get("change") else "")
    lines.append(f"| {r['f_hz']} | {spp} | {r['steps']} | {r['dt_cuts']} | "
                 f"{num(r, 'wall_s', '.0f')} | {num(r, 'value', '.4f')} | {change}{rel} | "
                 f"{num(r, 'order', '.2f')} | {num(r, 'error_estimate', '.3g')} |")
(out / "convergence.md").write_text("\n".join(lines) + "\n")
print("\n".join(lines))
EOF
