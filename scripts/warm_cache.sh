#!/usr/bin/env bash
# Compile the forms of every shipped demo scene into the JIT cache, by running
# one short step of each (serial and on two MPI ranks), and draw one picture
# to check off-screen rendering. Used by the Dockerfile; harmless anywhere.
#
#   scripts/warm_cache.sh [WORK_DIR]     (default: a temporary folder)
#
# A run that fails numerically in its one step (exit 3) has compiled its forms
# all the same and is accepted; a bad scene (exit 2) or a crash is an error.

set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
WORK="${1:-$(mktemp -d)}"
mkdir -p "$WORK"
RFTFEM="${RFTFEM:-rftfem}"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_rmaps_base_oversubscribe=1

one_step=(--quiet --set time.end=0.001 --set time.dt=0.001)
for scene in "$ROOT"/demos/*.toml; do
    name="$(basename "$scene" .toml)"
    for np in 1 2; do
        launch=()
        if [[ $np -gt 1 ]]; then launch=(mpirun -n "$np"); fi
        rc=0
        "${launch[@]}" "$RFTFEM" run "$scene" --out "$WORK/$name-$np" "${one_step[@]}" || rc=$?
        if [[ $rc -ne 0 && $rc -ne 3 ]]; then
            echo "warm_cache: $name on $np rank(s) exited with $rc" >&2
            exit 1
        fi
    done
done
"$RFTFEM" render "$WORK/rollup-1" --out "$WORK/rollup.png"
echo "warm_cache: forms of $(ls "$ROOT"/demos/*.toml | wc -l) demo scenes compiled"
