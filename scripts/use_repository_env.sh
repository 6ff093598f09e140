# Sourced by the shipped shell scripts (demos/*.sh): when `rftfem` is not on PATH,
# put the repository's own environment first, the one `./dev.sh setup` (and so the
# README's quick start) made: .venv (the reference stack), else .venv-current.
# A script then works from a plain shell right after the quick start; an activated
# environment, or an rftfem installed elsewhere on PATH, is used as it is.
if ! command -v rftfem >/dev/null 2>&1; then
    _rftfem_root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
    for _rftfem_venv in "$_rftfem_root/.venv" "$_rftfem_root/.venv-current"; do
        if [[ -x "$_rftfem_venv/bin/rftfem" ]]; then
            PATH="$_rftfem_venv/bin:$PATH"
            export PATH
            break
        fi
    done
    if ! command -v rftfem >/dev/null 2>&1; then
        echo "$(basename "$0"): rftfem is not installed: run ./dev.sh setup (or the README's quick start) first" >&2
        exit 2
    fi
    unset _rftfem_root _rftfem_venv
fi
