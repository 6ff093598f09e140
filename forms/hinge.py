"""Hinges: jointed panels and the rotational spring of a hinge line
(docs/hinges.md).

A hinge line splits the mid-surface into panels that share their displacement
(one continuous ``u``) but not their director: each side carries its own.  The
panels are coloured so that two panels meeting at a hinge differ, and a cell of
colour ``c`` takes its director from colour ``c``'s rotation field and triad:

    d = Σ_c χ_c d_c,      χ_c = 1 on the cells of colour c, 0 elsewhere (DG0)

A spring hinge of stiffness ``k`` (per unit length, on the fold angle) stores

    Π_h = ½ k ∫_hinge φ² ds,      φ = 2 atan(s / (1 + c)),   s = (d⁻ × d⁺)·τ,  c = d⁻·d⁺

with ``d±`` the two sides' directors at the line and ``τ`` its current unit
tangent, ``F_s T`` normalised, ``T`` the reference tangent.  ``φ`` is the signed
angle between the two directors about the line; the reference surface is
smooth across the hinge, so ``φ = 0`` there.  A free hinge (``k = 0``) adds
nothing: it carries force but no moment about its line.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import ufl

from .kinematics import unit

if TYPE_CHECKING:
    from collections.abc import Sequence


def panel_director(
    indicators: Sequence[ufl.core.expr.Expr], directors: Sequence[ufl.core.expr.Expr]
) -> ufl.core.expr.Expr:
    """``d = Σ_c χ_c d_c``: the director of the colour each cell belongs to (the
    indicators are 1 on their own cells and 0 elsewhere, so on every cell one term is
    left).  A sum, not a ``conditional``: FFCx 0.5 cannot factorise a conditional
    whose branches hold different components of the test function."""
    d = indicators[0] * directors[0]
    for chi, dc in zip(indicators[1:], directors[1:]):
        d = d + chi * dc
    return d


def hinge_tangent(
    F_s: ufl.core.expr.Expr, N: ufl.core.expr.Expr, n: ufl.core.expr.Expr
) -> ufl.core.expr.Expr:
    """Current unit tangent of a line of the mid-surface, ``F_s T / |F_s T|``, with
    the reference tangent ``T = N × n`` from the cell normal ``N`` and the in-surface
    facet normal ``n`` (restrict all three to one side)."""
    return unit(F_s * ufl.cross(N, n))


def fold_angle(
    d_minus: ufl.core.expr.Expr, d_plus: ufl.core.expr.Expr, tangent: ufl.core.expr.Expr
) -> ufl.core.expr.Expr:
    """Signed angle ``φ`` from ``d⁻`` to ``d⁺`` about ``tangent``.

    For unit directors turning about the line, ``s = (d⁻ × d⁺)·τ = sin φ`` and
    ``c = d⁻·d⁺ = cos φ``, and the half-angle formula ``φ = 2 atan(s / (1 + c))``
    gives the angle in (−π, π), smooth at 0 (only a fold of ±180° is singular).
    """
    s = ufl.dot(ufl.cross(d_minus, d_plus), tangent)
    c = ufl.dot(d_minus, d_plus)
    return 2 * ufl.atan(s / (1 + c))


def hinge_spring_energy(
    stiffness: ufl.core.expr.Expr | float, angle: ufl.core.expr.Expr, dS: ufl.Measure
) -> ufl.Form:
    """``½ k ∫ φ² ds`` over the hinge line(s) of ``dS`` (interior facets)."""
    return 0.5 * stiffness * angle**2 * dS
