"""The stack's versions and what its PETSc offers or calls by another name."""

from __future__ import annotations

import dolfinx
import ufl
from petsc4py import PETSc

#: SNES's converged reason for a residual that is NaN or infinite: PETSc 3.18 calls it
#: DIVERGED_FNORM_NAN, PETSc >= 3.22 DIVERGED_FUNCTION_NANORINF (compared by name)
SNES_NOT_FINITE = ("DIVERGED_FNORM_NAN", "DIVERGED_FUNCTION_NANORINF")


def versions() -> dict:
    import petsc4py

    v = PETSc.Sys.getVersion()
    return {
        "dolfinx": dolfinx.__version__,
        "ufl": getattr(ufl, "__version__", "unknown"),
        "petsc": ".".join(str(i) for i in v),
        "petsc4py": petsc4py.__version__,
    }


def petsc_unlimited() -> int:
    """The value that switches a PETSc tolerance off.

    PETSc ≥ 3.22 has ``PETSC_UNLIMITED`` (−3) and reads −1 as "the default"
    (a divergence tolerance of 1e4); older versions switch off with −1.
    """
    return int(getattr(PETSc, "UNLIMITED", -1))


def has_mumps() -> bool:
    return bool(PETSc.Sys.hasExternalPackage("mumps"))


def has_scalapack() -> bool:
    """Whether PETSc can factorise distributed dense matrices (``MATSCALAPACK``)."""
    return bool(PETSc.Sys.hasExternalPackage("scalapack"))
