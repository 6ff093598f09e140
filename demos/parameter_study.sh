#!/usr/bin/env bash
# A parameter study in a few lines: Taylor's swimming sheet (demos/swimming_sheet.toml)
# on a 2 × 2 grid of wave amplitude b and wavenumber k, each run in its own folder,
# several at a time (xargs -P), then one table of all of them by `rftfem collect`.
#
#   demos/parameter_study.sh                      # 2 runs at a time, into results/parameter_study
#   demos/parameter_study.sh -j 4 results/study   # 4 at a time, into results/study
#   demos/parameter_study.sh -j 1 results/fine --set mesh.divisions=[20,4]
#
# Arguments after the folder are passed to every `rftfem run` (here: more --set).
# The runs are short and coarse (10 × 2 mesh, 16 steps per wave period, each a few
# seconds on one core): they show the workflow, not converged numbers.  Each run
# stops once its speed is steady (the scene's time.until = "periodic", at most 20
# periods): `speed` is the steady swimming speed, `power` the steady mean drag
# power, both extrapolated from the last periods (summary.json's steady values).
#
# Writes OUT/b<b>_k<k>/ (a run folder with the run's log.txt) and OUT/table.csv,
# and prints the table.  Runs that finished before (summary.json says "ok") are not
# repeated: remove OUT to start over.  Exit status 1 if a run failed (it still
# has its row in the table, marked failed, with the reason).
set -euo pipefail
# rftfem from the repository's .venv when it is not on PATH
source "$(dirname "${BASH_SOURCE[0]}")/../scripts/use_repository_env.sh"

usage() { sed -n '2,20p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//'; }
JOBS=2
while getopts "j:h" opt; do
    case $opt in
        j) JOBS=$OPTARG ;;
        h) usage; exit 0 ;;
        *) echo "usage: $0 [-j JOBS] [OUT [rftfem run options...]]" >&2; exit 2 ;;
    esac
done
shift $((OPTIND - 1))
if ! [[ "$JOBS" =~ ^[1-9][0-9]*$ ]]; then
    echo "$0: -j needs a positive number of jobs, got '$JOBS'" >&2
    exit 2
fi

HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
SCENE="$HERE/swimming_sheet.toml"
OUT="${1:-results/parameter_study}"
[[ $# -gt 0 ]] && shift
AMPLITUDES="0.1 0.2"            # motion.0.amplitude (mm)
WAVENUMBERS="0.5 1.0"           # motion.0.wavenumber (1/mm); ω = 100 rad/s for all
PERIOD=$(awk 'BEGIN { printf "%.17g", 8 * atan2(1, 1) / 100 }')   # 2π/ω
END=$(awk -v p="$PERIOD" 'BEGIN { printf "%.17g", 20 * p }')
DT=$(awk -v p="$PERIOD" 'BEGIN { printf "%.17g", p / 16 }')

# One run: its settings as --set, its output and log in its own folder.
run_one() {  # run_one B K
    local dir="$OUT/b$1_k$2" extra=()
    [[ -n "$EXTRA" ]] && mapfile -t extra <<<"$EXTRA"
    if [[ -f "$dir/summary.json" ]] && grep -q '"status": "ok"' "$dir/summary.json"; then
        echo "b = $1, k = $2: done before, kept ($dir)"
        return 0
    fi
    mkdir -p "$dir"
    if rftfem run "$SCENE" --out "$dir" --quiet \
        --set "motion.0.amplitude=$1" --set "motion.0.wavenumber=$2" \
        --set "mesh.divisions=[10,2]" --set "time.end=$END" --set "time.dt=$DT" \
        --set "time.output_every=2" --set "output.fields=false" \
        "${extra[@]}" >"$dir/log.txt" 2>&1; then
        echo "b = $1, k = $2: done ($dir)"
    else
        echo "b = $1, k = $2: FAILED with exit status $? (see $dir/log.txt)"
    fi
}
export -f run_one
export SCENE OUT END DT EXTRA="$(printf '%s\n' "$@")"
export OMP_NUM_THREADS="${OMP_NUM_THREADS:-1}"   # one thread per run: the runs share the cores

mkdir -p "$OUT"
for b in $AMPLITUDES; do
    for k in $WAVENUMBERS; do
        echo "$b $k"
    done
done | xargs -P "$JOBS" -L 1 bash -c 'run_one "$@"' run_one

dirs=()
for b in $AMPLITUDES; do
    for k in $WAVENUMBERS; do
        dirs+=("$OUT/b${b}_k${k}")
    done
done
rftfem collect "${dirs[@]}" --out "$OUT/table.csv" \
    --quantity "speed=steady(centroid_x_rate)" --quantity "power=steady(drag_power)"
echo
cat "$OUT/table.csv"
! grep -q '^[^,]*,failed,' "$OUT/table.csv"
