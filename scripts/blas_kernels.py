"""Print the kernels and threads of every OpenBLAS a stack loads, and check them.

    python scripts/blas_kernels.py [CORETYPE | threads1]

OpenBLAS chooses its compute kernels by CPU at load time (``OPENBLAS_CORETYPE``
overrides the choice), and the round-off of every dense product and factorisation
follows them.  A stack may load several copies (numpy's, scipy's, the one inside the
PETSc wheel); each is asked for its core name and thread count.  Given the variant
``./dev.sh test-kernels`` asked for, exits 1 with one line if any copy runs other
kernels (an OpenBLAS built for one CPU only ignores ``OPENBLAS_CORETYPE``) or more
than one thread.
"""

from __future__ import annotations

import ctypes
import sys

import numpy  # noqa: F401  (loads numpy's BLAS)
import scipy.linalg  # noqa: F401  (and scipy's)

try:
    import dolfinx_solver  # noqa: F401  (the current stack's PETSc, before petsc4py)
except ImportError:
    pass
from petsc4py import PETSc  # noqa: F401,E402  (and PETSc's)

#: the names of the query functions: Debian's OpenBLAS, then the scipy-openblas wheels
_PREFIXES = (("openblas_", ""), ("scipy_openblas_", "64_"), ("scipy_openblas_", ""))


def loaded() -> list[tuple[str, str, int]]:
    """(path, core name, threads) of each OpenBLAS mapped into this process."""
    with open("/proc/self/maps", encoding="utf-8") as maps:
        paths = sorted(
            {line.split()[-1] for line in maps if "openblas" in line.split()[-1].lower()}
        )
    found = []
    for path in paths:
        lib = ctypes.CDLL(path)
        for prefix, suffix in _PREFIXES:
            core = getattr(lib, f"{prefix}get_corename{suffix}", None)
            threads = getattr(lib, f"{prefix}get_num_threads{suffix}", None)
            if core is not None and threads is not None:
                core.restype = ctypes.c_char_p
                found.append((path, core().decode(), int(threads())))
                break
    return found


def main(variant: str | None) -> int:
    libraries = loaded()
    for path, core, threads in libraries:
        print(f"OpenBLAS {core}, {threads} thread(s): {path}")
    if not libraries:
        print("blas_kernels: no OpenBLAS is loaded; the variants test nothing", file=sys.stderr)
        return 1
    for path, core, threads in libraries:
        if variant == "threads1" and threads != 1:
            print(f"blas_kernels: {path} runs {threads} threads, not 1", file=sys.stderr)
            return 1
        if variant not in (None, "threads1") and core.lower() != variant.lower():
            print(f"blas_kernels: {path} runs {core} kernels, not {variant}", file=sys.stderr)
            return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1] if len(sys.argv) > 1 else None))
