"""Dead edge loads (docs/model.md §5.6): a force and a moment per unit reference length."""

from __future__ import annotations

import ufl


def edge_force_work(force: ufl.core.expr.Expr, du: ufl.core.expr.Expr, ds: ufl.Measure) -> ufl.Form:
    """``∫ f·δu ds`` for a force ``f`` per unit length."""
    return ufl.dot(force, du) * ds


def edge_moment_work(
    moment: ufl.core.expr.Expr, d: ufl.core.expr.Expr, dd: ufl.core.expr.Expr, ds: ufl.Measure
) -> ufl.Form:
    """``∫ M·(d × δd) ds`` for a moment ``M`` per unit length acting on the director.

    With ``δd = δφ × d`` this is the work of ``M`` on the virtual rotation ``δφ``
    less its drilling part (along ``d``), which the director cannot take.
    """
    return ufl.dot(moment, ufl.cross(d, dd)) * ds
