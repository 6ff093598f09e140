#!/usr/bin/env bash
# Set up rftfem's Python environments on Debian 12.
#
#   scripts/setup.sh [reference|current|all]      (default: reference)
#
# reference  Debian's FEniCSx packages (dolfinx 0.5.2, Open MPI) run by
#            /usr/bin/python3, in .venv (made with --system-site-packages),
#            with rftfem installed in editable mode.
# current    Python >= 3.12 in .venv-current with the dolfinx-solver-real and
#            gmsh wheels (dolfinx 0.11, PETSc and MPICH inside the wheels), plus
#            the Debian libraries those wheels and the JIT compiler need.
# all        both.
#
# Idempotent. apt is skipped when dpkg says every package is installed; pip is
# skipped when the stamp in the venv matches pyproject.toml and this stack's
# package list. Runs of this script on the same checkout are serialized.
#
# Environment:
#   RFTFEM_CURRENT_PYTHON  interpreter for the current stack (default: first
#                          python3.12/3.13/3.14 that runs, on PATH or in pyenv)
#   RFTFEM_SETUP_FORCE=1   reinstall the pip part even when the stamp matches

set -Eeuo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"

# ---------------------------------------------------------------- settings --

REF_PYTHON=/usr/bin/python3
REF_VENV="$ROOT/.venv"
# EGL and Mesa's DRI drivers: off-screen rendering by the vtk wheel (pyvista)
# without a display. Without them VTK crashes at its first render.
RENDER_APT=(libegl1 libgl1-mesa-dri)
# libopenblas0-pthread: an optimised BLAS/LAPACK behind numpy and scipy (Debian's
# alternatives pick it over the reference BLAS): the Stokes flow's dense
# factorisations are 10x faster with it.
REF_APT=(
    python3-dolfinx-real python3-gmsh openmpi-bin
    python3-venv python3-pip python3-setuptools
    python3-matplotlib python3-scipy python3-pandas python3-numba python3-pytest python3-h5py-mpi python3-hypothesis
    libopenblas0-pthread
    "${RENDER_APT[@]}"
)

CUR_VENV="$ROOT/.venv-current"
CUR_PIP=(dolfinx-solver-real gmsh h5py hypothesis)
# The fast multipole library of the matrix-free Stokes operator (rftfem/model/stokes_fmm.py).
# Its wheels declare numpy >= 1.26 but run on Debian's numpy 1.24 (built against
# numpy 2's backward-compatible ABI; tests/test_stokes.py checks it against the dense
# operator), so the reference stack takes it without dependencies; the current
# stack takes it through the project's `fast` extra.
FMM_PIP="fmm3dpy==2.1.0"
# Shared libraries the gmsh wheel's libgmsh links against (readelf NEEDED),
# mapped to their Debian packages, plus a C compiler and libc headers for the
# FFCx just-in-time compilation of forms.
CUR_APT=(
    gcc libc6-dev
    libglu1-mesa libgl1 libx11-6 libxext6 libxrender1 libxcursor1 libxfixes3
    libxft2 libxinerama1 libfontconfig1 libgomp1 libstdc++6 zlib1g
    "${RENDER_APT[@]}"
)

STAMP_NAME=.rftfem-setup-stamp

# ----------------------------------------------------------------- helpers --

STEP="start"
T0=$SECONDS

say()  { printf 'setup: %s\n' "$*"; }
fail() { printf 'setup: ERROR: %s\n' "$*" >&2; exit 1; }
step() { STEP="$*"; say "$STEP"; }

on_err() {
    local rc=$1 line=$2
    printf '\nsetup: FAILED (exit %s) during step: %s  [scripts/setup.sh line %s]\n' \
        "$rc" "$STEP" "$line" >&2
}
trap 'on_err $? $LINENO' ERR

as_root() {
    if [[ $(id -u) -eq 0 ]]; then
        "$@"
    elif command -v sudo >/dev/null 2>&1; then
        sudo "$@"
    else
        fail "need root (or sudo) to run: $*"
    fi
}

# Packages among "$@" that dpkg does not report as installed.
missing_debs() {
    local p status
    for p in "$@"; do
        status="$(dpkg-query -W -f='${db:Status-Abbrev}' "$p" 2>/dev/null || true)"
        [[ $status == ii* ]] || printf '%s\n' "$p"
    done
}

ensure_apt() {
    local label=$1; shift
    local missing
    mapfile -t missing < <(missing_debs "$@")
    if [[ ${#missing[@]} -eq 0 ]]; then
        say "apt ($label): all ${#} packages installed"
        return 0
    fi
    step "apt ($label): installing ${missing[*]}"
    command -v apt-get >/dev/null 2>&1 || fail "apt-get not found: this script targets Debian 12"
    export DEBIAN_FRONTEND=noninteractive
    as_root apt-get update </dev/null
    as_root apt-get install -y "${missing[@]}" </dev/null
    mapfile -t missing < <(missing_debs "$@")
    [[ ${#missing[@]} -eq 0 ]] || fail "apt ($label): still not installed: ${missing[*]}"
}

# Hash of everything the pip step of a stack depends on.
stamp_of() {
    { cat "$ROOT/pyproject.toml"; printf '%s\n' "$@"; } | sha256sum | cut -d' ' -f1
}

# True when venv $1 has a working interpreter that lives at $1 (not a copied
# or moved venv) and its base interpreter satisfies the check in $2.
venv_ok() {
    local venv=$1 check=$2
    [[ -x $venv/bin/python ]] || return 1
    "$venv/bin/python" - "$venv" <<EOF >/dev/null 2>&1
import os, sys
if os.path.realpath(sys.prefix) != os.path.realpath(sys.argv[1]):
    sys.exit(1)
$check
EOF
}

pip_flags=(--disable-pip-version-check)
if [[ -n ${CI:-} ]]; then pip_flags+=(--progress-bar off); fi

# --------------------------------------------------------------- reference --

setup_reference() {
    local t=$SECONDS
    step "reference: checking Debian packages"
    ensure_apt reference "${REF_APT[@]}"
    [[ -x $REF_PYTHON ]] || fail "$REF_PYTHON not found after installing the Debian packages"

    local want
    want="$(stamp_of reference "$REF_PYTHON" "$ROOT" "$FMM_PIP")"
    local check="sys.exit(os.path.realpath(sys.base_prefix) != '/usr')"
    if venv_ok "$REF_VENV" "$check" && [[ -z ${RFTFEM_SETUP_FORCE:-} ]] \
        && [[ "$(cat "$REF_VENV/$STAMP_NAME" 2>/dev/null)" == "$want" ]]; then
        say "reference: .venv up to date ($((SECONDS - t)) s)"
        return 0
    fi

    if ! venv_ok "$REF_VENV" "$check"; then
        if [[ -e $REF_VENV ]]; then
            say "reference: .venv is not a working $REF_PYTHON venv at this path; recreating it"
            rm -rf "$REF_VENV"
        fi
        step "reference: creating .venv ($REF_PYTHON -m venv --system-site-packages)"
        "$REF_PYTHON" -m venv --system-site-packages "$REF_VENV"
    fi
    rm -f "$REF_VENV/$STAMP_NAME"

    # Debian's numpy (and scipy, matplotlib, pillow, pandas, numba) must stay: dolfinx and petsc4py are
    # built against them. pip gets them as constraints, so the pure-Python
    # extras (pyvista, imageio) are chosen to fit instead of replacing them.
    local constraints="$REF_VENV/debian-constraints.txt"
    "$REF_PYTHON" - >"$constraints" <<'PY'
import importlib.metadata as md
for name in ("numpy", "scipy", "matplotlib", "pillow", "pandas", "numba", "llvmlite"):
    try:
        print(f"{name}=={md.version(name)}")
    except md.PackageNotFoundError:
        pass
PY
    # (the test extra brings magpylib, the tests' reference for permanent magnets; the
    # constraints pick a release that runs on Debian's numpy)
    step "reference: pip install -e '.[test,cluster]' into .venv (constraints: $(tr '\n' ' ' <"$constraints"))"
    "$REF_VENV/bin/python" -m pip install "${pip_flags[@]}" --no-build-isolation \
        -c "$constraints" -e '.[test,cluster]'
    step "reference: pip install --no-deps $FMM_PIP into .venv"
    "$REF_VENV/bin/python" -m pip install "${pip_flags[@]}" --no-deps "$FMM_PIP"

    step "reference: checking that dolfinx, gmsh, pyvista and rftfem import"
    "$REF_VENV/bin/python" -c 'import rftfem.outputs.render, dolfinx, gmsh, petsc4py, mpi4py, fmm3dpy, distributed, dask_jobqueue, magpylib; print("setup: reference: dolfinx", dolfinx.__version__, "gmsh", gmsh.__version__, "pyvista", rftfem.outputs.render.pv.__version__)'

    printf '%s\n' "$want" >"$REF_VENV/$STAMP_NAME"
    say "reference: ready ($((SECONDS - t)) s)"
}

# ----------------------------------------------------------------- current --

version_check='import sys; sys.exit(0 if sys.version_info >= (3, 12) else 1)'

find_current_python() {
    local c cands=()
    if [[ -n ${RFTFEM_CURRENT_PYTHON:-} ]]; then
        if "$RFTFEM_CURRENT_PYTHON" -c "$version_check" >/dev/null 2>&1; then
            command -v "$RFTFEM_CURRENT_PYTHON"
            return 0
        fi
        printf 'setup: ERROR: RFTFEM_CURRENT_PYTHON=%s does not run or is older than 3.12\n' \
            "$RFTFEM_CURRENT_PYTHON" >&2
        return 1
    fi
    for c in python3.12 python3.13 python3.14; do
        if command -v "$c" >/dev/null 2>&1; then
            cands+=("$(command -v "$c")")
        fi
    done
    local pyenv_root="${PYENV_ROOT:-$HOME/.pyenv}"
    if [[ -d $pyenv_root/versions ]]; then
        while IFS= read -r c; do cands+=("$c"); done < <(
            { compgen -G "$pyenv_root/versions/3.1[2-9]*/bin/python3" || true; } | sort -V)
    fi
    for c in "${cands[@]}"; do
        # pyenv shims exist for versions that are not selected and then fail,
        # so try each candidate instead of trusting its name.
        if "$c" -c "$version_check" >/dev/null 2>&1 \
            && "$c" -c 'import venv, ensurepip' >/dev/null 2>&1; then
            printf '%s\n' "$c"
            return 0
        fi
    done
    return 1
}

setup_current() {
    local t=$SECONDS
    step "current: checking Debian packages"
    ensure_apt current "${CUR_APT[@]}"

    local check="sys.exit(sys.version_info < (3, 12))"
    local py=""
    if ! venv_ok "$CUR_VENV" "$check"; then
        step "current: looking for Python >= 3.12"
        if ! py="$(find_current_python)"; then
            fail "current stack: no Python >= 3.12 found (looked for python3.12/3.13/3.14 on PATH and in ${PYENV_ROOT:-$HOME/.pyenv}/versions). Debian 12 ships 3.11 only: install one (e.g. with pyenv) or set RFTFEM_CURRENT_PYTHON=/path/to/python3.12"
        fi
        say "current: using $py ($("$py" -c 'import sys; print(sys.version.split()[0])'))"
    fi

    local pyver
    if [[ -n $py ]]; then pyver="$("$py" -V)"; else pyver="$("$CUR_VENV/bin/python" -V)"; fi
    local want
    want="$(stamp_of current "$pyver" "$ROOT" "${CUR_PIP[@]}")"
    if [[ -z $py && -z ${RFTFEM_SETUP_FORCE:-} ]] \
        && [[ "$(cat "$CUR_VENV/$STAMP_NAME" 2>/dev/null)" == "$want" ]]; then
        say "current: .venv-current up to date ($((SECONDS - t)) s)"
        return 0
    fi

    if [[ -n $py ]]; then
        if [[ -e $CUR_VENV ]]; then
            say "current: .venv-current is not a working Python >= 3.12 venv at this path; recreating it"
            rm -rf "$CUR_VENV"
        fi
        step "current: creating .venv-current ($py -m venv)"
        "$py" -m venv "$CUR_VENV"
    fi
    rm -f "$CUR_VENV/$STAMP_NAME"

    step "current: pip install -e '.[test,fast,cluster]' ${CUR_PIP[*]} into .venv-current"
    "$CUR_VENV/bin/python" -m pip install "${pip_flags[@]}" -e '.[test,fast,cluster]' "${CUR_PIP[@]}"

    step "current: checking that dolfinx_solver, dolfinx, gmsh, pyvista and rftfem import"
    "$CUR_VENV/bin/python" -c 'import rftfem.outputs.render, dolfinx_solver, dolfinx, gmsh, petsc4py, mpi4py, fmm3dpy, distributed, dask_jobqueue, magpylib; print("setup: current: dolfinx", dolfinx.__version__, "gmsh", gmsh.__version__, "pyvista", rftfem.outputs.render.pv.__version__)'

    printf '%s\n' "$want" >"$CUR_VENV/$STAMP_NAME"
    say "current: ready ($((SECONDS - t)) s)"
}

# -------------------------------------------------------------------- main --

usage() { echo "usage: scripts/setup.sh [reference|current|all]"; }

stack="${1:-reference}"
case $stack in
    reference|current|all) ;;
    -h|--help|help) usage; exit 0 ;;
    *) usage >&2; exit 2 ;;
esac

# Serialize concurrent runs on this checkout (several people or terminals
# running ./dev.sh at once would otherwise race on apt and pip).
if command -v flock >/dev/null 2>&1; then
    lock="${TMPDIR:-/tmp}/rftfem-setup-$(printf '%s' "$ROOT" | cksum | cut -d' ' -f1).lock"
    exec 9>"$lock"
    if ! flock -n 9; then
        say "waiting for another setup run on this checkout"
        flock 9
    fi
fi

case $stack in
    reference) setup_reference ;;
    current)   setup_current ;;
    all)       setup_reference; setup_current ;;
esac
STEP="done"
say "done: $stack ($((SECONDS - T0)) s)"
