"""The field outside a uniformly magnetized cuboid, cylinder or sphere, in numbers and UFL.

A uniformly magnetized body of polarization ``J`` (tesla, in the magnet's own frame)
is, outside itself, the field of the surface charges ``σ = J·n`` on its faces:
``B(x) = 1/(4π) ∫ σ (x − x')/|x − x'|³ dA'``.

- **cuboid** (sides ``2h``): each face is a rectangle, whose integral is closed form:
  with ``u, v, w`` the offsets of ``x`` from a corner along the face's two sides and
  its normal, ``R = |(u, v, w)|``, the normal part is ``atan(u v/(w R))`` and the two
  in-plane parts ``−ln(v + R)``, ``−ln(u + R)``, summed over the four corners with
  signs.  ``ln(v + R)`` is taken as ``ln(ρ²) − ln(R − v)`` (``ρ² = u² + w²``) where
  ``v < 0``, so that it keeps its digits in the face's shadow, and the normal part as
  ``sign(w) atan2(u v, |w| R)``, 0 in the face's plane (its limit outside the magnet).
- **sphere**: outside, exactly the point dipole of moment ``m = J V/μ₀``,
  ``V = π d³/6``.
- **cylinder** polarized along its axis (diameter ``2a``, height ``2b``): Derby and
  Olbert's closed form (Am. J. Phys. 78, 229 (2010)) with Bulirsch's complete
  elliptic integral ``cel(k_c, p, c, s)``, whose iteration (an arithmetic-geometric
  mean, quadratically convergent) is written out a fixed 8 times: converged to
  round-off down to 1e-10 of the radius from the rim.  Polarized across its axis it
  is refused for now (:func:`rftfem.model.magnets.check_sources`).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from collections.abc import Sequence

    from ufl.core.expr import Expr

    #: one component of a point, a polarization or a field: numbers (numpy) or UFL
    Component = float | np.ndarray | Expr

#: ln(0) guard, far below any ρ² of a body outside the magnet (it cancels exactly)
_TINY = 1e-300


class _Numpy:
    sqrt, ln, atan2, sign, abs = np.sqrt, np.log, np.arctan2, np.sign, np.abs


class _Ufl:
    def __init__(self):
        import ufl

        self.sqrt, self.ln, self.sign, self.abs = ufl.sqrt, ufl.ln, ufl.sign, abs
        self.atan2 = getattr(ufl, "atan2", None) or getattr(ufl, "atan_2")


def _ln_v_plus_r(v, R, rho2, ops):
    """``ln(v + R)``, without cancellation where ``v < 0`` (``R − |v| = ρ²/(R + |v|)``)."""
    s = ops.sign(v)
    return s * ops.ln(ops.abs(v) + R) + (1 - s) * 0.5 * ops.ln(rho2 + _TINY)


def cuboid_field(
    x: np.ndarray | Sequence[Component],
    half: np.ndarray,
    J: np.ndarray | Sequence[Component],
    ops: type[_Numpy] | _Ufl = _Numpy,
    axes: Sequence[int] = (0, 1, 2),
) -> list[Component]:
    """``B`` (3 components, in J's unit) at ``x`` (3 components, the magnet's frame, its
    centre at 0) of a cuboid of half-sides ``half`` and polarization ``J``; outside
    the cuboid.  ``axes``: the components of ``J`` to take (the others are 0: the forms
    then leave out their faces, a third of the terms each)."""
    B = [0.0, 0.0, 0.0]
    for k in axes:
        i, j = (k + 1) % 3, (k + 2) % 3
        part = [0.0, 0.0, 0.0]
        for r in (1, -1):  # the face at +h_k (σ = J_k), at −h_k (−J_k)
            w = x[k] - r * half[k]
            for p in (1, -1):
                u = x[i] - p * half[i]
                for q in (1, -1):
                    v = x[j] - q * half[j]
                    R = ops.sqrt(u * u + v * v + w * w)
                    s = r * p * q
                    part[k] = part[k] + s * ops.sign(w) * ops.atan2(u * v, ops.abs(w) * R)
                    part[i] = part[i] - s * _ln_v_plus_r(v, R, u * u + w * w, ops)
                    part[j] = part[j] - s * _ln_v_plus_r(u, R, v * v + w * w, ops)
        for c in range(3):
            B[c] = B[c] + J[k] / (4 * math.pi) * part[c]
    return B


#: iterations of Bulirsch's cel, written out (8: round-off at 1e-10 of a from the rim)
CEL_ITERATIONS = 8


def _cel(kc, pp, cc, ss, ops):
    """Bulirsch's ``cel(k_c, p, c, s)`` for ``p > 0``, given ``pp = √p`` and
    ``ss = s/√p``: ``∫₀^{π/2} (c cos² + s sin²)/((cos² + p sin²) √(cos² + k_c² sin²)) dφ``."""
    k, em = ops.abs(kc), 1.0
    f = cc
    cc = cc + ss / pp
    g = k / pp
    ss = 2 * (ss + f * g)
    pp = g + pp
    g, em, kk = em, k + em, k
    for _ in range(CEL_ITERATIONS):
        k = 2 * ops.sqrt(kk)
        kk = k * em
        f = cc
        cc = cc + ss / pp
        g = kk / pp
        ss = 2 * (ss + f * g)
        pp = g + pp
        g, em = em, k + em
    return (math.pi / 2) * (ss + cc * em) / (em * (em + pp))


def cylinder_field(
    x: np.ndarray | Sequence[Component],
    diameter: float,
    height: float,
    Jz: Component,
    ops: type[_Numpy] | _Ufl = _Numpy,
) -> list[Component]:
    """``B`` outside a cylinder (its axis along Z, centre at 0) polarized ``Jz`` along
    its axis: with ``z± = z ± b``, ``D = √(z±² + (ρ + a)²)``, ``γ = (a − ρ)/(a + ρ)``,
    ``k± = √(z±² + (a − ρ)²)/D``,
    ``B_ρ = (J/π) Σ± ±(a/D) cel(k±, 1, 1, −1)``,
    ``B_z = (J/π) a/(a + ρ) Σ± ±(z±/D) cel(k±, γ², 1, γ)``."""
    a, b = 0.5 * diameter, 0.5 * height
    rho = ops.sqrt(x[0] * x[0] + x[1] * x[1] + _TINY)
    gamma = (a - rho) / (a + rho)
    radial = axial = 0.0
    for sign in (1, -1):
        zs = x[2] + sign * b
        D = ops.sqrt(zs * zs + (rho + a) * (rho + a))
        k = ops.sqrt(zs * zs + (a - rho) * (a - rho)) / D
        radial = radial + sign * a / D * _cel(k, 1.0, 1.0, -1.0, ops)
        root = ops.sqrt(gamma * gamma + _TINY)  # √p, p = γ² (0 on the cylinder ρ = a)
        axial = axial + sign * zs / D * _cel(k, root, 1.0, gamma / root, ops)
    Br = Jz / math.pi * radial
    return [Br * x[0] / rho, Br * x[1] / rho, Jz / math.pi * a / (a + rho) * axial]


def sphere_field(
    x: np.ndarray | Sequence[Component],
    diameter: float,
    J: np.ndarray | Sequence[Component],
    ops: type[_Numpy] | _Ufl = _Numpy,
) -> list[Component]:
    """``B`` outside a sphere of polarization ``J``: the dipole ``m = J V/μ₀``,
    ``B = V/(4π) (3 r (J·r)/|r|⁵ − J/|r|³)``."""
    volume = math.pi * diameter**3 / 6
    r2 = x[0] * x[0] + x[1] * x[1] + x[2] * x[2]
    rr = ops.sqrt(r2)
    Jr = J[0] * x[0] + J[1] * x[1] + J[2] * x[2]
    return [
        volume / (4 * math.pi) * (3 * x[c] * Jr / (r2 * r2 * rr) - J[c] / (r2 * rr))
        for c in range(3)
    ]
