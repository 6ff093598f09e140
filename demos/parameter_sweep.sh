#!/usr/bin/env bash
# demos/parameter_study.sh in one command: Taylor's swimming sheet on a 2 × 2 grid
# of wave amplitude b and wavenumber k, by `rftfem sweep`.
#
#   demos/parameter_sweep.sh                                # 2 runs at a time, local
#   demos/parameter_sweep.sh -j 4 results/sweep             # 4 at a time, into results/sweep
#   demos/parameter_sweep.sh -j 2 results/sweep --executor dask   # on a local Dask cluster
#   demos/parameter_sweep.sh -j 8 results/sweep --executor slurm --slurm queue=short
#
# Arguments after the folder go to `rftfem sweep` (an executor, --reuse, more --set).
# The same short, coarse runs as parameter_study.sh (10 × 2 mesh, 16 steps a wave
# period, each stops once its speed is steady): they show the workflow, not
# converged numbers. Writes OUT/sweep.csv (b, k, status, speed, power), OUT/sweep.png
# (heat maps of both) and a run folder per combination; prints the table. Exit
# status 1 if a run failed (its row says why).
set -euo pipefail
# rftfem from the repository's .venv when it is not on PATH
source "$(dirname "${BASH_SOURCE[0]}")/../scripts/use_repository_env.sh"

usage() { sed -n '2,16p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//'; }
JOBS=2
while getopts "j:h" opt; do
    case $opt in
        j) JOBS=$OPTARG ;;
        h) usage; exit 0 ;;
        *) echo "usage: $0 [-j JOBS] [OUT [rftfem sweep options...]]" >&2; exit 2 ;;
    esac
done
shift $((OPTIND - 1))
if ! [[ "$JOBS" =~ ^[1-9][0-9]*$ ]]; then
    echo "$0: -j needs a positive number of jobs, got '$JOBS'" >&2
    exit 2
fi

HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
OUT="${1:-results/parameter_sweep}"
[[ $# -gt 0 ]] && shift
PERIOD=$(awk 'BEGIN { printf "%.17g", 8 * atan2(1, 1) / 100 }')   # 2π/ω, ω = 100 rad/s
export OMP_NUM_THREADS="${OMP_NUM_THREADS:-1}"   # one thread per run: the runs share the cores

rftfem sweep "$HERE/swimming_sheet.toml" --out "$OUT" --jobs "$JOBS" \
    --vary "motion.0.amplitude=0.1,0.2" --vary "motion.0.wavenumber=0.5,1.0" \
    --set "mesh.divisions=[10,2]" \
    --set "time.end=$(awk -v p="$PERIOD" 'BEGIN { printf "%.17g", 20 * p }')" \
    --set "time.dt=$(awk -v p="$PERIOD" 'BEGIN { printf "%.17g", p / 16 }')" \
    --set "time.output_every=2" --set "output.fields=false" \
    --quantity "speed=steady(centroid_x_rate)" --quantity "power=steady(drag_power)" "$@"
echo
cat "$OUT/sweep.csv"
! grep -q ',failed,' "$OUT/sweep.csv"
