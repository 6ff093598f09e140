"""Follower pressure (docs/model.md §5.6): a load normal to the current surface."""

from __future__ import annotations

import ufl


def follower_pressure_work(
    p: ufl.core.expr.Expr | float,
    g1: ufl.core.expr.Expr,
    g2: ufl.core.expr.Expr,
    G1: ufl.core.expr.Expr,
    G2: ufl.core.expr.Expr,
    du: ufl.core.expr.Expr,
    dx: ufl.Measure,
) -> ufl.Form:
    """``∫ p (g₁ × g₂)·δu / |G₁ × G₂| dA₀``: the work of a pressure ``p`` along the
    current normal on the current area (positive along g₁ × g₂, the side the
    reference normal points to)."""
    return (
        p
        * ufl.dot(ufl.cross(g1, g2), du)
        / ufl.sqrt(ufl.dot(ufl.cross(G1, G2), ufl.cross(G1, G2)))
        * dx
    )
