"""Magnetic body couples on hard-magnetic parts (docs/model.md §5.5; the paper's eq. 16).

A hard-magnetic material fibre carries a remanent magnetization of magnitude
``m`` (per volume) along a material direction ``q₀``.  It is convected by the
shell's deformation gradient ``F = F_s + d ⊗ N``:

    q = F q₀ / |F q₀|

and an external field ``b`` does the virtual work

    δW_mag = ∫_Ωm t m b·δq J dA₀,

with ``t`` the thickness and ``J`` the area ratio.  Since ``|q| = 1``,
``δq = δφ × q`` and ``b·δq = (q × b)·δφ``: the couple ``t m q × b`` per area on the
virtual rotation of the fibre.  ``δq`` is ``ufl.derivative`` of ``q``; the
Jacobian is ``ufl.derivative`` of the whole term (not symmetric).
"""

from __future__ import annotations

import ufl

from .kinematics import unit


def magnetization_direction(F: ufl.core.expr.Expr, q0: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
    """Current direction of the magnetized fibre, ``q = F q₀ / |F q₀|``."""
    return unit(F * q0)


def magnetization(F: ufl.core.expr.Expr, M: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
    """Current magnetization ``m q = |M| F M / |F M|`` from the remanent ``M = m q₀``;
    zero where ``M`` is (off the magnetic parts), so it can be written everywhere."""
    FM = F * M
    return ufl.sqrt(ufl.dot(M, M)) * FM / ufl.sqrt(ufl.dot(FM, FM) + 1e-300)


def magnetic_work(
    t: ufl.core.expr.Expr | float,
    m: ufl.core.expr.Expr | float,
    b: ufl.core.expr.Expr,
    dq: ufl.core.expr.Expr,
    J: ufl.core.expr.Expr | float,
    dx: ufl.Measure,
) -> ufl.Form:
    """Virtual work of the field on the magnetized parts, ``∫ t m b·δq J dA₀``.

    ``dx`` must be restricted to the magnetic subdomains.
    """
    return t * m * ufl.dot(b, dq) * J * dx


def magnetic_moment(
    t: ufl.core.expr.Expr | float,
    m: ufl.core.expr.Expr | float,
    q: ufl.core.expr.Expr,
    J: ufl.core.expr.Expr | float,
    dx: ufl.Measure,
) -> list[ufl.Form]:
    """Components of the body's total moment ``∫ t m q J dA₀`` (three scalar forms)."""
    return [t * m * q[i] * J * dx for i in range(3)]


def safe_direction(v: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
    """``v / |v|``, and 0 where ``v`` is 0 (a magnetization formula may vanish at a
    quadrature point): used where the magnetization varies over a part."""
    return v / ufl.sqrt(ufl.dot(v, v) + 1e-300)


def magnetic_energy(
    t: ufl.core.expr.Expr | float,
    F: ufl.core.expr.Expr,
    M: ufl.core.expr.Expr,
    B: ufl.core.expr.Expr,
    dx: ufl.Measure,
) -> ufl.Form:
    """Potential energy of the magnetized parts in a field ``B(x)`` that varies in
    space, ``Π = −∫ t (F M)·B(x) dA₀`` (``M = m q₀`` the remanent magnetization per
    volume, ``x = X + u`` inside ``B``).  Its first variation holds the couple
    (through ``δF``) and the gradient force ``t (∇B)ᵀ(F M)·δu``; its second, their
    exact tangent.  ``dx`` must be restricted to the magnetic subdomains."""
    return -t * ufl.dot(F * M, B) * dx
