"""One pair's terms of the direct Stokes sums (``rftfem.model.stokes_direct``), as
small numba functions inlined into the sums' loops so that the compiler vectorises
them: the singular Stokeslet's velocity and its derivative along a direction, and
Blake's images' (the wall's frame), each from the pair's separation.
"""

from __future__ import annotations

import numba as nb
import numpy as np

_JIT = dict(cache=True)

#: numba's floating-point freedoms for the sums: reassociation (vectorised loops),
#: fused multiply-adds and signless zeros; never approximate reciprocals or roots
#: (``inverse_root`` refines its own)
FAST = {"reassoc", "contract", "nsz"}


@nb.njit(fastmath=FAST, inline="always", **_JIT)
def inverse_root(d2: float) -> float:
    """``1/√d2`` for ``1e-36 ≤ d2 ≤ 1e37``: single precision's correctly rounded
    root refined by two Newton steps in double (within 2 ulp of ``1/sqrt(d2)``;
    single-precision roots and divisions go at twice the rate of double ones)."""
    a = np.float64(np.float32(1.0) / np.sqrt(np.float32(d2)))
    h = 0.5 * d2
    a = a * (1.5 - h * a * a)
    return a * (1.5 - h * a * a)


@nb.njit(fastmath=FAST, inline="always", **_JIT)
def singular(d2: float) -> float:
    """``1/r`` of the Stokeslet at ``r² = d2``, zero at ``d2 = 0`` (a node and itself)."""
    far = d2 > 0.0
    a = inverse_root(d2 if far else 1.0)
    return a if far else 0.0


@nb.njit(fastmath=FAST, inline="always", **_JIT)
def image_velocity(
    R0: float, R1: float, R2: float, h: float, f0: float, f1: float, f2: float
) -> tuple[float, float, float]:
    """Blake's images' velocity ``W f`` at ``R = ξ − Dη``, ``h = η₃`` (the wall's
    frame; ``stokes_kernels.image_block`` applied to ``f``):
    ``W f = R (a R·f + b R·Df) + c f + d Df + e (R·Df) e₃ + e f₃ R`` with
    ``a = −1/R³, b = 6h(R₃ − h)/R⁵, c = −1/R, d = 2h(h − R₃)/R³, e = 2h/R³``."""
    i1 = inverse_root(R0 * R0 + R1 * R1 + R2 * R2)
    i3 = i1 * i1 * i1
    i5 = i3 * i1 * i1
    a, b = -i3, 6.0 * h * (R2 - h) * i5
    c, d, e = -i1, 2.0 * h * (h - R2) * i3, 2.0 * h * i3
    s = R0 * f0 + R1 * f1 + R2 * f2
    q = R0 * f0 + R1 * f1 - R2 * f2
    m = a * s + b * q + e * f2
    return (
        m * R0 + (c + d) * f0,
        m * R1 + (c + d) * f1,
        m * R2 + (c - d) * f2 + e * q,
    )


@nb.njit(fastmath=FAST, inline="always", **_JIT)
def image_direction(
    R0: float,
    R1: float,
    R2: float,
    h: float,
    f0: float,
    f1: float,
    f2: float,
    P0: float,
    P1: float,
    P2: float,
    hp: float,
) -> tuple[float, float, float]:
    """The derivative of :func:`image_velocity` along ``R′ = P``, ``h′ = hp`` (at
    fixed ``f``), term by term of its coefficients."""
    i1 = inverse_root(R0 * R0 + R1 * R1 + R2 * R2)
    i2 = i1 * i1
    i3 = i1 * i2
    i5 = i3 * i2
    i7 = i5 * i2
    rho = R0 * P0 + R1 * P1 + R2 * P2
    a, b, e = -i3, 6.0 * h * (R2 - h) * i5, 2.0 * h * i3
    ap = 3.0 * i5 * rho
    bp = 6.0 * (hp * (R2 - h) + h * (P2 - hp)) * i5 - 30.0 * h * (R2 - h) * i7 * rho
    cp = i3 * rho
    dp = 2.0 * (hp * (h - R2) + h * (hp - P2)) * i3 - 6.0 * h * (h - R2) * i5 * rho
    ep = 2.0 * hp * i3 - 6.0 * h * i5 * rho
    s = R0 * f0 + R1 * f1 + R2 * f2
    q = R0 * f0 + R1 * f1 - R2 * f2
    sp = P0 * f0 + P1 * f1 + P2 * f2
    qp = P0 * f0 + P1 * f1 - P2 * f2
    m = a * s + b * q + e * f2
    mp = ap * s + a * sp + bp * q + b * qp + ep * f2
    return (
        mp * R0 + m * P0 + (cp + dp) * f0,
        mp * R1 + m * P1 + (cp + dp) * f1,
        mp * R2 + m * P2 + (cp - dp) * f2 + ep * q + e * qp,
    )


@nb.njit(fastmath=FAST, inline="always", **_JIT)
def stokeslet(
    r0: float, r1: float, r2: float, f0: float, f1: float, f2: float
) -> tuple[float, float, float]:
    """The singular Stokeslet's velocity ``(f/r + (r·f) r/r³)`` at ``r`` (zero at 0)."""
    a = singular(r0 * r0 + r1 * r1 + r2 * r2)
    rF = a * a * a * (r0 * f0 + r1 * f1 + r2 * f2)
    return a * f0 + rF * r0, a * f1 + rF * r1, a * f2 + rF * r2


@nb.njit(fastmath=FAST, inline="always", **_JIT)
def stokeslet_direction(
    r0: float,
    r1: float,
    r2: float,
    f0: float,
    f1: float,
    f2: float,
    w0: float,
    w1: float,
    w2: float,
) -> tuple[float, float, float]:
    """The singular Stokeslet's ``T w = ∂(S(r) f)/∂r · w``: with ``b = 1/r³``,
    ``T w = −b (r·w) f − 3b/r² (r·f)(r·w) r + b (f·w) r + b (r·f) w``
    (``stokes_kernels.free_gradient`` contracted)."""
    inv = singular(r0 * r0 + r1 * r1 + r2 * r2)
    b = inv * inv * inv
    rF = r0 * f0 + r1 * f1 + r2 * f2
    rw = r0 * w0 + r1 * w1 + r2 * w2
    cr = -3.0 * b * inv * inv * rF * rw + b * (f0 * w0 + f1 * w1 + f2 * w2)
    return (
        -b * rw * f0 + cr * r0 + b * rF * w0,
        -b * rw * f1 + cr * r1 + b * rF * w1,
        -b * rw * f2 + cr * r2 + b * rF * w2,
    )
