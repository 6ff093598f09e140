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
  test-kernels [STACK] [ARGS]
                        the suite (as `test` or `test-current`) once under each other
                        OpenBLAS kernel type and once on one BLAS thread: STACK is
                        reference (default), current or all; RFTFEM_KERNELS lists the
                        variants (default: Haswell SkylakeX Sandybridge threads1; also
                        forms-O2: the forms compiled without the CPU's vector flags);
                        RFTFEM_KERNEL_JOBS=2 runs two variants side by side. Logs in
                        results/kernels/ (RFTFEM_KERNEL_LOGS). About 25 min a variant.
  lint [PATHS]          ruff: the linter's rules and the formatter's check (pyproject.toml
                        [tool.ruff]); ./dev.sh lint --fix applies both
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

# test-kernels: one pytest run of stack $1 under variant $2 (an OpenBLAS kernel type,
# or threads1: the machine's own kernels on one thread), the rest pytest's arguments;
# its output goes to $KERNEL_LOGS/STACK-VARIANT.log with the captured prints of the
# passing tests (-rP), so the figures each variant reached can be compared.
kernel_variant() {
    local stack=$1 variant=$2; shift 2
    local log="$KERNEL_LOGS/$stack-$variant.log" t=$SECONDS rc=0
    local venv=$REF_VENV
    if [[ $stack == current ]]; then
        venv=$CUR_VENV
        if [[ $# -eq 0 ]]; then set -- "${CURRENT_TEST_ARGS[@]}"; fi
    fi
    echo "dev.sh: test-kernels: $stack stack, $variant: $log"
    (
        local check=$variant
        if [[ $variant == threads1 ]]; then
            export OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1
        elif [[ $variant == forms-O2 ]]; then
            # the forms compiled without the CPU's vector instructions and reassociation
            # (their round-off moves with the CPU too, which no BLAS setting reaches);
            # every form is compiled again once for these flags
            export RFTFEM_COMPILE_FLAGS="-O2 -g0"
            check=""
        else
            export OPENBLAS_CORETYPE=$variant
        fi
        # which kernels every OpenBLAS of the stack runs, refused if not the variant's
        "$venv/bin/python" scripts/blas_kernels.py $check &&
            run_pytest "$venv" -rP -p no:cacheprovider "$@"
    ) >"$log" 2>&1 || rc=$?
    echo "dev.sh: test-kernels: $stack $variant: $(tail -n 1 "$log") ($((SECONDS - t)) s, exit $rc)"
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
    test-kernels)
        stacks=(reference)
        case ${1:-} in
            reference|current) stacks=("$1"); shift ;;
            all) stacks=(reference current); shift ;;
        esac
        for stack in "${stacks[@]}"; do setup "$stack"; done
        KERNEL_LOGS=${RFTFEM_KERNEL_LOGS:-$ROOT/results/kernels}
        mkdir -p "$KERNEL_LOGS"
        read -r -a variants <<<"${RFTFEM_KERNELS:-Haswell SkylakeX Sandybridge threads1}"
        jobs=${RFTFEM_KERNEL_JOBS:-1}
        failed=0
        pids=()
        for stack in "${stacks[@]}"; do
            for variant in "${variants[@]}"; do
                if [[ $jobs -le 1 ]]; then
                    kernel_variant "$stack" "$variant" "$@" || failed=1
                    continue
                fi
                kernel_variant "$stack" "$variant" "$@" &
                pids+=($!)
                if [[ ${#pids[@]} -ge $jobs ]]; then
                    wait "${pids[0]}" || failed=1
                    pids=("${pids[@]:1}")
                fi
            done
        done
        for pid in "${pids[@]}"; do wait "$pid" || failed=1; done
        if [[ $failed -ne 0 ]]; then
            echo "dev.sh: test-kernels: FAILED under some kernels (logs in $KERNEL_LOGS)" >&2
            exit 1
        fi
        echo "dev.sh: test-kernels: passed under every kernel"
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
    lint)
        setup reference
        if [[ ${1:-} == --fix ]]; then
            shift
            "$REF_VENV/bin/ruff" check --fix "${@:-.}"
            "$REF_VENV/bin/ruff" format "${@:-.}"
        else
            "$REF_VENV/bin/ruff" check "${@:-.}"
            "$REF_VENV/bin/ruff" format --check "${@:-.}"
        fi
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
