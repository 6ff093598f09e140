"""Translational inertia (docs/model.md §5.3): ``∫ ρ t a·δu dA₀``.

Rotary inertia of the director is neglected: it is of order t²/L² of the
translational inertia for the thin shells this code is for.
"""

from __future__ import annotations

import ufl


def inertia_work(
    rho: ufl.core.expr.Expr | float,
    t: ufl.core.expr.Expr | float,
    acceleration: ufl.core.expr.Expr,
    du: ufl.core.expr.Expr,
    dx: ufl.Measure,
) -> ufl.Form:
    """Virtual work of the inertia forces, ``∫ ρ t a·δu dA₀``."""
    return rho * t * ufl.dot(acceleration, du) * dx


def kinetic_energy(
    rho: ufl.core.expr.Expr | float,
    t: ufl.core.expr.Expr | float,
    velocity: ufl.core.expr.Expr,
    dx: ufl.Measure,
) -> ufl.Form:
    """``½ ∫ ρ t v·v dA₀``."""
    return 0.5 * rho * t * ufl.dot(velocity, velocity) * dx
