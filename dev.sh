#!/usr/bin/env bash
# Developer entry point for rftfem. Every target first runs the set-up it
# needs (scripts/setup.sh), which is quick when everything is in place.
# Run ./dev.sh help for the list of targets.

set -euo pipefail

# What test-current runs when given no arguments: the suite without the `slow`
# reproductions (pyproject's addopts) and without the `long` ones, which the
# reference leg runs, except those marked `both_stacks` (the derivatives of the
# compiled forms, the sheet to steady, arc-length restart under mpirun, motion
# reactions); together the two legs stay within CI's time.
CURRENT_TEST_ARGS=(tests -m "not slow and (not long or both_stacks)")

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
cd "$ROOT"

# Open MPI refuses to run as root without these (containers, CI machines).
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1

REF_VENV="$ROOT/.venv"
CUR_VENV="$ROOT/.venv-current"
# PyElastica, for the peer race only: its own venv, so that rftfem's never imports it;
# made from ELASTICA_PYTHON, else from the interpreter of the current stack's venv.
ELASTICA_VENV="$ROOT/.venv-elastica"

usage() {
    cat <<'EOF'
usage: ./dev.sh TARGET [ARGS...]

  demo                  run the default demo scene (demos/rollup.toml -> results/rollup),
                        then draw its picture and film (rollup.png, rollup.mp4)
  test [PYTEST ARGS]    test suite on the reference stack (.venv), without `slow` tests
  test-full [ARGS]      whole suite on the reference stack, `slow` tests included
  test-current [ARGS]   test suite on the current stack (.venv-current), without `slow`
                        and `long` but for the `both_stacks` ones (./dev.sh test-current
                        -m long runs every long one)
  bench                 run benchmarks/*.py on the reference stack
  race [ARGS]           the peer race against PyElastica (benchmarks/peer_race.py; about
                        20 minutes, --quick for a few); creates .venv-elastica if missing
  setup [STACK]         only set up: reference (default), current or all
  help                  this text

Set-up is automatic: each target installs what it needs on first use
(Debian packages, virtual environments, editable install of rftfem).
EOF
}

setup() { bash "$ROOT/scripts/setup.sh" "$@"; }

# Run pytest with the interpreter of venv $1; exit status 5 (nothing
# collected) is reported and turned into a failure.
run_pytest() {
    local venv=$1; shift
    local rc=0
    # The venv's bin first on PATH, so `rftfem` and `mpirun` called by tests
    # belong to the stack under test.
    PATH="$venv/bin:$PATH" "$venv/bin/python" -m pytest "$@" || rc=$?
    if [[ $rc -eq 5 ]]; then
        echo "dev.sh: FAILED: pytest collected no tests (exit 5); a run that tests nothing does not pass" >&2
        return 1
    fi
    return "$rc"
}

target="${1:-help}"
if [[ $# -gt 0 ]]; then shift; fi

case $target in
    demo)
        setup reference
        if [[ ! -f demos/rollup.toml ]]; then
            echo "dev.sh: demos/rollup.toml not found" >&2
            exit 1
        fi
        PATH="$REF_VENV/bin:$PATH" "$REF_VENV/bin/rftfem" run demos/rollup.toml --out results/rollup "$@"
        # its picture and film, drawn off-screen from the results folder
        "$REF_VENV/bin/rftfem" render results/rollup --out results/rollup/rollup.png --color director_z
        "$REF_VENV/bin/rftfem" render results/rollup --out results/rollup/rollup.mp4 --color director_z
        ;;
    test)
        setup reference
        run_pytest "$REF_VENV" "$@"
        ;;
    test-full)
        setup reference
        # Replaces pyproject's addopts (which deselect `slow`).
        run_pytest "$REF_VENV" -o addopts='-ra' "$@"
        ;;
    test-current)
        setup current
        # the default selection only when no test paths or options are given
        if [[ $# -eq 0 ]]; then set -- "${CURRENT_TEST_ARGS[@]}"; fi
        run_pytest "$CUR_VENV" "$@"
        ;;
    bench)
        setup reference
        shopt -s nullglob
        # the peer race is ./dev.sh race (its own venv, 20 minutes)
        benches=()
        for b in benchmarks/*.py; do
            [[ $b == benchmarks/peer_race.py ]] || benches+=("$b")
        done
        if [[ ${#benches[@]} -eq 0 ]]; then
            echo "dev.sh: no benchmarks (benchmarks/*.py does not exist yet); nothing to run"
            exit 0
        fi
        for b in "${benches[@]}"; do
            echo "== $b"
            PATH="$REF_VENV/bin:$PATH" "$REF_VENV/bin/python" "$b" "$@"
        done
        ;;
    race)
        setup reference
        if [[ ! -x "$ELASTICA_VENV/bin/python" ]] \
            || ! "$ELASTICA_VENV/bin/python" -c 'import elastica' 2>/dev/null; then
            if [[ -z "${ELASTICA_PYTHON:-}" ]]; then
                setup current     # finds a Python >= 3.12 (scripts/setup.sh)
                ELASTICA_PYTHON="$(readlink -f "$CUR_VENV/bin/python")"
            fi
            echo "dev.sh: creating $ELASTICA_VENV (pyelastica 1.0.0, numba) from $ELASTICA_PYTHON"
            "$ELASTICA_PYTHON" -m venv "$ELASTICA_VENV"
            "$ELASTICA_VENV/bin/pip" install --quiet "pyelastica==1.0.0"
        fi
        PATH="$REF_VENV/bin:$PATH" "$REF_VENV/bin/python" benchmarks/peer_race.py "$@"
        ;;
    setup)
        setup "${1:-reference}"
        ;;
    help|-h|--help)
        usage
        ;;
    *)
        echo "dev.sh: unknown target '$target' (try ./dev.sh help)" >&2
        exit 2
        ;;
esac
