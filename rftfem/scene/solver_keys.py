"""rftfem's own keys of ``[solver]``, not given to PETSc: the Newton tangent, when
its factorisation is made, and how it is stored."""

from __future__ import annotations

from typing import Any

from rftfem.errors import SceneError

#: rftfem's own key of ``[solver]`` (not given to PETSc): the Newton tangent
#: (docs/model.md §7.4), the default first
TANGENTS = ("mixed-point", "exact")


def check_tangent(value: Any, where: str = "solver.tangent") -> str:
    """``value`` if it names a tangent of ``TANGENTS``, else a one-line SceneError."""
    return _check_choice(value, TANGENTS, where)


#: rftfem's other key of ``[solver]``: when the tangent's LU factorisation is made
#: (docs/model.md §7.7), the default first
FACTORIZATIONS = ("auto", "every-iteration", "every-step", "reused")


def check_factorization(value: Any, where: str = "solver.factorization") -> str:
    """``value`` if it names a policy of ``FACTORIZATIONS``, else a one-line SceneError."""
    return _check_choice(value, FACTORIZATIONS, where)


#: the tangent's PETSc matrix types (``[solver] mat_type``): node blocks (the default)
#: or single entries, for a preconditioner that takes no block matrix (hypre)
MATRIX_TYPES = ("baij", "aij")


def check_matrix_type(value: Any, where: str = "solver.mat_type") -> str:
    """``value`` if it names one of ``MATRIX_TYPES``, else a one-line SceneError."""
    return _check_choice(value, MATRIX_TYPES, where)


def _check_choice(value, choices, where: str) -> str:
    if value not in choices:
        raise SceneError(
            f"{where}: expected one of {', '.join(map(repr, choices))}, found {value!r}"
        )
    return value
