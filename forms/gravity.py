"""Gravity (docs/model.md §5.6): a body force per reference area."""

from __future__ import annotations

import ufl


def body_force_work(
    rho: ufl.core.expr.Expr | float,
    t: ufl.core.expr.Expr | float,
    g: ufl.core.expr.Expr,
    du: ufl.core.expr.Expr,
    dx: ufl.Measure,
) -> ufl.Form:
    """``∫ ρ t g·δu dA₀``: the work of the weight of a shell of density ``rho`` (net of
    buoyancy if the fluid's density is subtracted) and thickness ``t``."""
    return rho * t * ufl.dot(g, du) * dx
