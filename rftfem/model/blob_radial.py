"""The Gaussian blob's radial functions (``rftfem.model.stokeslets``): ``s₁/ρ``, ``s₂/ρ³``
and their derivatives, as series near the centre and the Stokeslet's far out.
"""

from __future__ import annotations

from math import factorial, pi, sqrt

import numpy as np
from numpy.polynomial import polynomial as P
from scipy.special import erf

_C = 2.0 / sqrt(pi)
#: below this ρ the radial functions are summed as series (no cancellation); beyond
#: the last, erfc ρ and the Gaussian terms (≤ 4e-19 of the Stokeslet's) are dropped
_SERIES_BELOW, _DEGREE, _STOKESLET_BEYOND = 0.3, 40, 7.0


def _series():
    """Taylor coefficients in ρ of s₁/ρ, s₂/ρ³, (ρ s₁′ − s₁)/ρ³ and (ρ s₂′ − 3 s₂)/ρ⁵."""
    n = _DEGREE
    E = np.zeros(n + 1)
    ERF = np.zeros(n + 1)
    for k in range(n // 2):
        E[2 * k] = (-1) ** k / factorial(k)
        if 2 * k + 1 <= n:
            ERF[2 * k + 1] = _C * (-1) ** k / (factorial(k) * (2 * k + 1))

    def mul(p, q):
        return P.polymul(p, q)[: n + 1]

    s1 = P.polyadd(ERF, _C * mul([0, 3, 0, -2], E))[: n + 1]
    s2 = P.polysub(ERF, _C * mul([0, 1, 0, -2], E))[: n + 1]
    ds1 = _C * mul([4, 0, -12, 0, 4], E)
    ds2 = _C * mul([0, 0, 8, 0, -4], E)
    rho = [0, 1]

    def shift(p, k):
        p = np.asarray(p)[: n + 1]
        assert np.allclose(p[:k], 0.0, atol=1e-14)
        return p[k:]

    return (
        shift(s1, 1),
        shift(s2, 3),
        shift(P.polysub(mul(rho, ds1), s1), 3),
        shift(P.polysub(mul(rho, ds2), 3 * s2), 5),
    )


_COEFFS = _series()


def radial(rho: np.ndarray) -> list[np.ndarray]:
    """``(s₁/ρ, s₂/ρ³, (ρ s₁′ − s₁)/ρ³, (ρ s₂′ − 3 s₂)/ρ⁵)`` at ``rho`` (any shape).

    With ``r = δρ``: ``a = f₀/δ``, ``b = f₁/δ³``, ``a′/r = f₂/δ³``, ``b′/r = f₃/δ⁵``."""
    rho = np.asarray(rho, dtype=float)
    out = [np.empty_like(rho) for _ in range(4)]
    small = rho < _SERIES_BELOW
    if small.any():
        r = rho[small]
        for f, c in zip(out, _COEFFS):
            f[small] = P.polyval(r, c)
    far = rho > _STOKESLET_BEYOND  # the blob's terms below round-off: the Stokeslet's
    if far.any():
        r = rho[far]
        inv = 1.0 / r
        inv3 = inv * inv * inv
        out[0][far] = inv
        out[1][far] = inv3
        out[2][far] = -inv3
        out[3][far] = -3.0 * inv3 * inv * inv
    big = ~small & ~far
    if big.any():
        r = rho[big]
        E = np.exp(-r * r)
        erf_r = erf(r)
        s1 = erf_r + _C * r * (3 - 2 * r * r) * E
        s2 = erf_r - _C * r * (1 - 2 * r * r) * E
        ds1 = _C * E * (4 - 12 * r * r + 4 * r**4)
        ds2 = _C * E * (8 * r * r - 4 * r**4)
        out[0][big] = s1 / r
        out[1][big] = s2 / r**3
        out[2][big] = (r * ds1 - s1) / r**3
        out[3][big] = (r * ds2 - 3 * s2) / r**5
    return out
