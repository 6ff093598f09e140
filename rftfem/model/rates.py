"""The time scheme's velocity, the one relation every effect with rates uses (the
shell's UFL velocity, the Stokes flow's nodal velocities, a motion's corrections)."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import numpy as np
    import ufl


def scheme_velocity(
    du: ufl.core.expr.Expr | np.ndarray,
    v_n: ufl.core.expr.Expr | np.ndarray,
    a_n: ufl.core.expr.Expr | np.ndarray,
    cv: ufl.core.expr.Expr | float,
    cv_v: ufl.core.expr.Expr | float,
    cv_a: ufl.core.expr.Expr | float,
) -> ufl.core.expr.Expr | np.ndarray:
    """The velocity a step's scheme gives its end, ``v = c_v Δu + c_v^v v_n + c_v^a a_n``
    (docs/model.md §6), of UFL expressions or arrays alike; the coefficients are
    numbers or constants."""
    return cv * du + cv_v * v_n + cv_a * a_n
