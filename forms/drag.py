"""Resistive-force-theory drag (docs/model.md §5.4; the paper's eq. 7-9 and 14).

The fluid acts on the mid-surface with a local, anisotropic traction
proportional to its velocity ``v``.  In the current configuration

    e₁ = F_s E₁* / |F_s E₁*|        (material axis, pushed forward)
    e₃ = g₁ × g₂ / |g₁ × g₂|        (current normal)
    e₂ = e₃ × e₁
    C̃  = C₁ e₁⊗e₁ + C₂ e₂⊗e₂ + C₃ e₃⊗e₃

and the drag does the virtual work ``∫ (C̃ v)·δu J dA₀`` with the area ratio
``J = |g₁ × g₂| / |G₁ × G₂|`` (current area per reference area).  ``e₁`` is a
unit tangent and ``e₃`` the unit normal, so the frame is orthonormal.  The
traction depends on the state through ``v``, the frame and ``J``; its Jacobian
(not symmetric) comes from ``ufl.derivative`` on the whole term.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import ufl

from .kinematics import area_ratio, convected_axis, unit, unit_normal

if TYPE_CHECKING:
    from collections.abc import Sequence


def drag_frame(
    convected: ufl.core.expr.Expr, g1: ufl.core.expr.Expr, g2: ufl.core.expr.Expr
) -> tuple[ufl.core.expr.Expr, ufl.core.expr.Expr, ufl.core.expr.Expr]:
    """Orthonormal current frame ``(e₁, e₂, e₃)`` of the paper's eq. 9, from the
    convected material axis ``F_s E₁*`` (``kinematics.convected_axis``)."""
    e1 = unit(convected)
    e3 = unit_normal(g1, g2)
    return e1, ufl.cross(e3, e1), e3


def drag_tensor(
    coefficients: Sequence[ufl.core.expr.Expr | float], frame: Sequence[ufl.core.expr.Expr]
) -> ufl.core.expr.Expr:
    """``C̃ = Σ Cᵢ eᵢ⊗eᵢ`` from ``(C₁, C₂, C₃)`` and the frame ``(e₁, e₂, e₃)``."""
    return sum(c * ufl.outer(e, e) for c, e in zip(coefficients, frame))


def transverse_drag_tensor(
    coefficients: Sequence[ufl.core.expr.Expr | float], normal: ufl.core.expr.Expr
) -> ufl.core.expr.Expr:
    """``C̃`` of a liquid that resists every tangent direction alike (``C₁ = C₂``):
    ``C₁ (I − e₃⊗e₃) + C₃ e₃⊗e₃``, the same tensor as ``drag_tensor`` with no
    material axis (a closed surface has none that is tangent everywhere)."""
    tangent, normal_c = coefficients[0], coefficients[2]
    return tangent * ufl.Identity(3) + (normal_c - tangent) * ufl.outer(normal, normal)


def drag_traction(
    coefficients: Sequence[ufl.core.expr.Expr | float],
    frame: Sequence[ufl.core.expr.Expr],
    velocity: ufl.core.expr.Expr,
) -> ufl.core.expr.Expr:
    """RFT traction per current area, ``C̃ v`` (resisting: it enters the residual with +)."""
    return ufl.dot(drag_tensor(coefficients, frame), velocity)


def _traction_per_reference_area(coefficients, F_s, axis, velocity, g1, g2, G1, G2):
    """``C̃ v J``: the traction in the current frame times the area ratio; with
    ``axis`` None the liquid resists every tangent direction alike
    (``transverse_drag_tensor``)."""
    if axis is None:
        traction = ufl.dot(transverse_drag_tensor(coefficients, unit_normal(g1, g2)), velocity)
    else:
        frame = drag_frame(convected_axis(F_s, axis, G1, G2), g1, g2)
        traction = drag_traction(coefficients, frame, velocity)
    return traction * area_ratio(g1, g2, G1, G2)


def drag_work(
    coefficients: Sequence[ufl.core.expr.Expr | float],
    F_s: ufl.core.expr.Expr,
    axis: ufl.core.expr.Expr | None,
    velocity: ufl.core.expr.Expr,
    du: ufl.core.expr.Expr,
    g1: ufl.core.expr.Expr,
    g2: ufl.core.expr.Expr,
    G1: ufl.core.expr.Expr,
    G2: ufl.core.expr.Expr,
    dx: ufl.Measure,
) -> ufl.Form:
    """Virtual work of the drag, ``∫ (C̃ v)·δu J dA₀`` (docs/model.md §5.4)."""
    traction = _traction_per_reference_area(coefficients, F_s, axis, velocity, g1, g2, G1, G2)
    return ufl.dot(traction, du) * dx


def drag_power(
    coefficients: Sequence[ufl.core.expr.Expr | float],
    F_s: ufl.core.expr.Expr,
    axis: ufl.core.expr.Expr | None,
    velocity: ufl.core.expr.Expr,
    g1: ufl.core.expr.Expr,
    g2: ufl.core.expr.Expr,
    G1: ufl.core.expr.Expr,
    G2: ufl.core.expr.Expr,
    dx: ufl.Measure,
) -> ufl.Form:
    """Dissipated power ``∫ (C̃ v)·v J dA₀`` (≥ 0 for Cᵢ ≥ 0)."""
    return drag_work(coefficients, F_s, axis, velocity, velocity, g1, g2, G1, G2, dx)


def drag_force(
    coefficients: Sequence[ufl.core.expr.Expr | float],
    F_s: ufl.core.expr.Expr,
    axis: ufl.core.expr.Expr | None,
    velocity: ufl.core.expr.Expr,
    g1: ufl.core.expr.Expr,
    g2: ufl.core.expr.Expr,
    G1: ufl.core.expr.Expr,
    G2: ufl.core.expr.Expr,
    dx: ufl.Measure,
) -> list[ufl.Form]:
    """The three components of the total drag force ``∫ C̃ v J dA₀`` (scalar forms)."""
    traction = _traction_per_reference_area(coefficients, F_s, axis, velocity, g1, g2, G1, G2)
    return [traction[i] * dx for i in range(3)]


def drag_moment(
    coefficients: Sequence[ufl.core.expr.Expr | float],
    F_s: ufl.core.expr.Expr,
    axis: ufl.core.expr.Expr | None,
    velocity: ufl.core.expr.Expr,
    position: ufl.core.expr.Expr,
    g1: ufl.core.expr.Expr,
    g2: ufl.core.expr.Expr,
    G1: ufl.core.expr.Expr,
    G2: ufl.core.expr.Expr,
    dx: ufl.Measure,
) -> list[ufl.Form]:
    """The three components of the drag's moment about the origin, ``∫ x × C̃ v J dA₀``
    with ``x`` the current position (scalar forms)."""
    traction = _traction_per_reference_area(coefficients, F_s, axis, velocity, g1, g2, G1, G2)
    moment = ufl.cross(position, traction)
    return [moment[i] * dx for i in range(3)]
