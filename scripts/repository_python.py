"""Run a shipped Python script with the repository's own environment when the
interpreter that started it lacks rftfem.

`python3 demos/three_link.py` from a plain shell starts the system's python3, which
has neither dolfinx nor rftfem: `./dev.sh setup` installed them into the
repository's .venv (the reference stack) or .venv-current.  :func:`ensure` then runs
the same script with the same arguments under that environment's python (one
re-execution; an interpreter that has rftfem is used as it is).  The demos and
benchmarks call it before they import anything of the FEniCSx stack.
"""

from __future__ import annotations

import importlib.util
import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
_MARK = "RFTFEM_REPOSITORY_PYTHON"


def ensure() -> None:
    """Re-execute the running script under the repository's environment if this
    interpreter cannot import rftfem; exit 2 with one line if there is none."""
    if importlib.util.find_spec("rftfem") is not None:
        return
    script = Path(sys.argv[0]).name
    if os.environ.get(_MARK):
        _fail(
            f"{script}: the repository's environment does not import rftfem: run "
            "./dev.sh setup again"
        )
    for venv in (ROOT / ".venv", ROOT / ".venv-current"):
        python = venv / "bin" / "python"
        if python.exists():
            os.environ[_MARK] = "1"
            os.environ["PATH"] = f"{venv / 'bin'}{os.pathsep}{os.environ.get('PATH', '')}"
            os.execv(str(python), [str(python), *sys.argv])
    _fail(
        f"{script}: rftfem is not installed: run ./dev.sh setup (or the README's quick start) first"
    )


def _fail(message: str) -> None:
    print(message, file=sys.stderr)
    sys.exit(2)
