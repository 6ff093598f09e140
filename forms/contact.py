"""Contact of the shell's lower face with a plane (docs/contact.md), in UFL.

The lower face is the mid-surface offset by half the thickness against the
director, ``x⁻ = x − (t/2) d``; its gap to the plane through ``p`` with unit
normal ``n`` (towards the body's side) is ``g = (x⁻ − p)·n``.  The normal law is
the barrier of Incremental Potential Contact (Li et al. 2020) laid across the
plane: with the reach ``δ``, ``s = g + δ`` and ``ŝ = 2δ``,

    b(s) = −(s − ŝ)² ln(s / ŝ)        for 0 < s < ŝ (that is −δ < g < δ),

zero farther than ``δ`` above the plane, C² where it starts, unbounded as the
face nears ``δ`` below it.  Its pressure at ``g = 0`` is the reference pressure
the stiffness is made from, so a face pressed that hard rests on the plane.
Below ``s_c = CLAMP ŝ`` it is continued by its second-order Taylor polynomial
at ``s_c``, so an overshooting Newton iterate meets a finite, convex energy.
Friction is Coulomb's law on the slip velocity of the lower face, smoothed near
zero slip and stepping from the static to the kinetic coefficient over a
velocity scale ``ε_v`` (docs/contact.md §2).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import ufl

if TYPE_CHECKING:
    from collections.abc import Sequence

#: where the logarithmic barrier is continued by its Taylor polynomial, as a share of
#: ŝ = 2δ: there the contact pressure is ≈ 850 times that on the plane
CLAMP = 1.0e-3
#: ``−b′(δ)/δ = 2 ln 2 + 1``: the barrier's slope on the plane, per unit reach
SLOPE_ON_PLANE = 2 * math.log(2.0) + 1


def lower_face(
    x: ufl.core.expr.Expr, d: ufl.core.expr.Expr, t: ufl.core.expr.Expr | float
) -> ufl.core.expr.Expr:
    """``x⁻ = x − (t/2) d``: the point of the lower face under the mid-surface point ``x``."""
    return x - 0.5 * t * d


def gap(
    x_face: ufl.core.expr.Expr, point: ufl.core.expr.Expr, normal: ufl.core.expr.Expr
) -> ufl.core.expr.Expr:
    """``g = (x⁻ − p)·n``: the height of the lower face over the plane (negative below)."""
    return ufl.dot(x_face - point, normal)


def _log_barrier(s, s_hat):
    return -((s - s_hat) ** 2) * ufl.ln(s / s_hat)


def barrier(g: ufl.core.expr.Expr, reach: ufl.core.expr.Expr | float) -> ufl.core.expr.Expr:
    """``b(g + δ)`` of the module docstring, per unit stiffness (units length²): 0 for
    ``g ≥ δ``, the IPC barrier for ``−δ + s_c < g < δ``, its Taylor polynomial below."""
    s, s_hat = g + reach, 2 * reach
    sc = CLAMP * s_hat
    b_c = _log_barrier(sc, s_hat)
    db_c = -2 * (sc - s_hat) * ufl.ln(sc / s_hat) - (sc - s_hat) ** 2 / sc
    d2b_c = -2 * ufl.ln(sc / s_hat) - 4 * (sc - s_hat) / sc + (sc - s_hat) ** 2 / sc**2
    taylor = b_c + db_c * (s - sc) + 0.5 * d2b_c * (s - sc) ** 2
    s_log = ufl.max_value(s, sc)  # keeps ln's argument positive on the branch not taken
    inside = ufl.conditional(ufl.gt(s, sc), _log_barrier(s_log, s_hat), taylor)
    return ufl.conditional(ufl.lt(g, reach), inside, 0 * g)


def barrier_energy(
    stiffness: ufl.core.expr.Expr | float,
    g: ufl.core.expr.Expr,
    reach: ufl.core.expr.Expr | float,
    dx: ufl.Measure,
) -> ufl.Form:
    """``∫ κ b(g + δ) dA₀``: the stored energy of the normal contact (its derivative is
    the pressure ``κ |b′|`` along ``n`` on the lower face)."""
    return stiffness * barrier(g, reach) * dx


def barrier_slope(g: ufl.core.expr.Expr, reach: ufl.core.expr.Expr | float) -> ufl.core.expr.Expr:
    """``b′(g + δ)`` (≤ 0), by UFL's differentiation of :func:`barrier`."""
    gv = ufl.variable(g)
    return ufl.diff(barrier(gv, reach), gv)


def contact_pressure(
    stiffness: ufl.core.expr.Expr | float, g: ufl.core.expr.Expr, reach: ufl.core.expr.Expr | float
) -> ufl.core.expr.Expr:
    """``λ = −κ b′(g + δ)`` (force per reference area, ≥ 0): the normal pressure."""
    return -stiffness * barrier_slope(g, reach)


#: below this change of the gap over a step (a share of δ) the secant of the barrier
#: is its slope at the mean gap (then the two differ by ~1e-8 of the slope)
SECANT_FLOOR = 1.0e-4


def step_pressure(
    stiffness: ufl.core.expr.Expr | float,
    g: ufl.core.expr.Expr,
    g_start: ufl.core.expr.Expr,
    reach: ufl.core.expr.Expr | float,
    alpha_f: ufl.core.expr.Expr | float,
    weighted: ufl.core.expr.Expr | float,
) -> ufl.core.expr.Expr:
    """The barrier's pressure over a step from the gap ``g_start`` to ``g`` (docs/contact.md §1):

        λ = −κ [ (b(g) − b(g_start))/(g − g_start) + (½ − α_f)(b′(g) − b′(g_start)) ]

    where ``weighted`` is 1 (a second-order scheme in time), else ``−κ b′(g)``.  The
    secant makes the barrier's work over the step exactly its change of energy, and
    the second term, for the scheme's force weight α_f ≤ ½, only dissipates (b is
    convex): an impact cannot gain energy however badly the step resolves it.  For a
    smooth motion the bracket is b′ at the time n + 1 − α_f to second order, where the
    scheme takes the other forces, so a rolling body feels no lag."""
    dg = g - g_start
    small = ufl.lt(abs(dg), SECANT_FLOOR * reach)
    slope, slope_start = barrier_slope(g, reach), barrier_slope(g_start, reach)
    secant = ufl.conditional(
        small,
        barrier_slope(0.5 * (g + g_start), reach),
        (barrier(g, reach) - barrier(g_start, reach)) / ufl.conditional(small, 1.0, dg),
    )
    stepped = secant + (0.5 - alpha_f) * (slope - slope_start)
    return -stiffness * (weighted * stepped + (1 - weighted) * slope)


def slip_velocity(
    x_face: ufl.core.expr.Expr,
    x_face_start: ufl.core.expr.Expr,
    normal: ufl.core.expr.Expr,
    inv_dt: ufl.core.expr.Expr | float,
) -> ufl.core.expr.Expr:
    """``v_T = (I − n⊗n)(x⁻ − x⁻ₙ)/Δt``: the tangential velocity of the lower face over
    the step (its mean over the step, whatever the time scheme)."""
    dx_face = (x_face - x_face_start) * inv_dt
    return dx_face - ufl.dot(dx_face, normal) * normal


def _speed(v, v_scale):
    """``|v|``, kept differentiable at ``v = 0`` (offset 1e-9 ε_v)."""
    return ufl.sqrt(ufl.dot(v, v) + (1e-9 * v_scale) ** 2)


def friction_coefficient(
    mu_kinetic: ufl.core.expr.Expr | float,
    mu_static: ufl.core.expr.Expr | float,
    speed: ufl.core.expr.Expr,
    v_scale: ufl.core.expr.Expr | float,
) -> ufl.core.expr.Expr:
    """``μ(y)``: ``μ_s`` up to ``y = ε_v``, then ``μ_k + (μ_s − μ_k) exp(−((y − ε_v)/ε_v)²)``
    (C¹; below 1e-4 of the step by y = 4 ε_v)."""
    over = ufl.max_value(speed - v_scale, 0 * speed) / v_scale
    return mu_kinetic + (mu_static - mu_kinetic) * ufl.exp(-(over**2))


def mollifier(speed: ufl.core.expr.Expr, v_scale: ufl.core.expr.Expr | float) -> ufl.core.expr.Expr:
    """``f₁(y)/y``: ``(2 − y/ε_v)/ε_v`` below ``ε_v``, ``1/y`` above (IPC's C¹ smoothing
    of the direction ``v/|v|``; finite at zero slip)."""
    return ufl.conditional(
        ufl.lt(speed, v_scale), (2 - speed / v_scale) / v_scale, 1 / ufl.max_value(speed, v_scale)
    )


def friction_traction(
    pressure: ufl.core.expr.Expr,
    v_slip: ufl.core.expr.Expr,
    v_scale: ufl.core.expr.Expr | float,
    mu_kinetic: ufl.core.expr.Expr | float | Sequence[ufl.core.expr.Expr | float],
    mu_static: ufl.core.expr.Expr | float | Sequence[ufl.core.expr.Expr | float],
    frame: tuple[ufl.core.expr.Expr, ufl.core.expr.Expr] | None = None,
) -> ufl.core.expr.Expr:
    """The friction force per reference area on the body, ``−λ Σ μᵢ(y) (v·eᵢ) eᵢ f₁(y)/y``.

    Isotropic (``frame`` None): ``μ_k``, ``μ_s`` are numbers (UFL scalars) and the
    sum is ``μ(y) v``.  Anisotropic: ``frame = (e_a, e_c)``, the material axis
    projected on the plane and the direction across it there, and ``mu_kinetic``,
    ``mu_static`` are ``[forward, backward, sideways]``: slip along ``+e_a`` meets
    the forward coefficient, along ``−e_a`` the backward one, across it the
    sideways one.
    """
    y = _speed(v_slip, v_scale)
    smooth = mollifier(y, v_scale)
    if frame is None:
        mu = friction_coefficient(mu_kinetic, mu_static, y, v_scale)
        return -pressure * mu * smooth * v_slip
    e_a, e_c = frame
    va, vc = ufl.dot(v_slip, e_a), ufl.dot(v_slip, e_c)
    forward = ufl.ge(va, 0)
    mu_a = [ufl.conditional(forward, mu[0], mu[1]) for mu in (mu_kinetic, mu_static)]
    mu_along = friction_coefficient(mu_a[0], mu_a[1], y, v_scale)
    mu_across = friction_coefficient(mu_kinetic[2], mu_static[2], y, v_scale)
    return -pressure * smooth * (mu_along * va * e_a + mu_across * vc * e_c)


def friction_frame(
    axis: ufl.core.expr.Expr, normal: ufl.core.expr.Expr
) -> tuple[ufl.core.expr.Expr, ufl.core.expr.Expr]:
    """``(e_a, e_c)``: the unit projection of the (current) material axis on the plane
    and ``n × e_a``.  Where the axis is along ``n`` the frame is undefined; it is kept
    finite (a tiny offset), and the check of the scene refuses such starts."""
    a = axis - ufl.dot(axis, normal) * normal
    e_a = a / ufl.sqrt(ufl.dot(a, a) + 1e-30)
    return e_a, ufl.cross(normal, e_a)


def contact_work(
    pressure: ufl.core.expr.Expr,
    traction: ufl.core.expr.Expr,
    normal: ufl.core.expr.Expr,
    dx_virtual: ufl.core.expr.Expr,
    dx: ufl.Measure,
) -> ufl.Form:
    """``−∫ (λ n + τ)·δx⁻ dA₀``: the virtual work of the plane's force on the lower face
    (internal-minus-external sign, as the other loads)."""
    return -ufl.dot(pressure * normal + traction, dx_virtual) * dx
