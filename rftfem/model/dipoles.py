"""The magnetic interaction energy of point dipoles and its exact derivatives, as
compiled direct sums (numba, threaded over the targets).

Dipoles ``m_i`` at ``x_i`` in groups (a magnetized part of a body): only dipoles of
different groups interact.  With ``k = μ₀/4π``, ``r = x_j − x_i``, ``ρ = |r|``,
``s_a = m_i·r``, ``s_b = m_j·r`` and ``p = m_i·m_j``, a pair holds

    e = k (p/ρ³ − 3 s_a s_b/ρ⁵)                   (= −m_i·B_j(x_i))

and the energy is ``E = Σ_{i<j} e``.  Per target ``i`` the sums give
``G_i = ∂E/∂m_i = −B(x_i)`` (minus the others' field), ``H_i = ∂E/∂x_i`` (minus
the force on it) and, for a direction ``(dm, dx)`` of every dipole, the exact
directional derivatives ``dG_i``, ``dH_i`` (the Hessian's product, written out
term by term below; tests/test_magnetic_interactions.py checks them against
finite differences and the point-dipole formulas).
"""

from __future__ import annotations

from math import sqrt

import numba as nb
import numpy as np

_JIT = dict(cache=True)


@nb.njit(inline="always", **_JIT)
def _pair_gradient(a, b, r0, r1, r2):
    """``(e, ∂e/∂a, ∂e/∂r)`` of a pair, without ``k`` (``a = m_i``, ``b = m_j``)."""
    rho2 = r0 * r0 + r1 * r1 + r2 * r2
    i1 = 1.0 / sqrt(rho2)
    i3 = i1 * i1 * i1
    i5 = i3 * i1 * i1
    i7 = i5 * i1 * i1
    sa = a[0] * r0 + a[1] * r1 + a[2] * r2
    sb = b[0] * r0 + b[1] * r1 + b[2] * r2
    p = a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
    e = p * i3 - 3.0 * sa * sb * i5
    ga = np.empty(3)
    gr = np.empty(3)
    r = (r0, r1, r2)
    for c in range(3):
        ga[c] = b[c] * i3 - 3.0 * sb * r[c] * i5
        gr[c] = -3.0 * (p * r[c] + sb * a[c] + sa * b[c]) * i5 + 15.0 * sa * sb * r[c] * i7
    return e, ga, gr


@nb.njit(parallel=True, **_JIT)
def gradient(
    m: np.ndarray,
    x: np.ndarray,
    group: np.ndarray,
    lo: int,
    hi: int,
    scale: float,
    G: np.ndarray,
    H: np.ndarray,
    energy: np.ndarray,
) -> None:
    """For the targets ``lo ≤ i < hi``: ``G[i − lo] = ∂E/∂m_i``, ``H[i − lo] = ∂E/∂x_i``
    and ``energy[i − lo]`` half the target's pair energies (their sum is ``E``);
    every value times ``scale`` (``k``)."""
    n = len(x)
    for i in nb.prange(lo, hi):
        g = np.zeros(3)
        h = np.zeros(3)
        half = 0.0
        for j in range(n):
            if group[j] == group[i]:
                continue
            e, ga, gr = _pair_gradient(
                m[i], m[j], x[j, 0] - x[i, 0], x[j, 1] - x[i, 1], x[j, 2] - x[i, 2]
            )
            half += 0.5 * e
            for c in range(3):
                g[c] += ga[c]
                h[c] -= gr[c]  # r = x_j − x_i: ∂/∂x_i = −∂/∂r
        for c in range(3):
            G[i - lo, c] = scale * g[c]
            H[i - lo, c] = scale * h[c]
        energy[i - lo] = scale * half


@nb.njit(inline="always", **_JIT)
def _add_pair_product(
    a: np.ndarray,
    da: np.ndarray,
    b: np.ndarray,
    db: np.ndarray,
    r: np.ndarray,
    dr: np.ndarray,
    out_g: np.ndarray,
    out_h: np.ndarray,
) -> None:
    """Add a pair's derivatives of ``∂e/∂a`` and of ``∂e/∂x_i = −∂e/∂r`` along
    ``(da, db, dr)`` to ``out_g`` and ``out_h``, without ``k``."""
    rho2 = r[0] * r[0] + r[1] * r[1] + r[2] * r[2]
    i1 = 1.0 / sqrt(rho2)
    i2 = i1 * i1
    i5 = i2 * i2 * i1
    i3 = i2 * i1
    i7 = i5 * i2
    i9 = i7 * i2
    sa = a[0] * r[0] + a[1] * r[1] + a[2] * r[2]
    sb = b[0] * r[0] + b[1] * r[1] + b[2] * r[2]
    p = a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
    q = r[0] * dr[0] + r[1] * dr[1] + r[2] * dr[2]
    dp = da[0] * b[0] + da[1] * b[1] + da[2] * b[2] + a[0] * db[0] + a[1] * db[1]
    dp += a[2] * db[2]
    dsa = da[0] * r[0] + da[1] * r[1] + da[2] * r[2] + a[0] * dr[0] + a[1] * dr[1]
    dsa += a[2] * dr[2]
    dsb = db[0] * r[0] + db[1] * r[1] + db[2] * r[2] + b[0] * dr[0] + b[1] * dr[1]
    dsb += b[2] * dr[2]
    for c in range(3):
        # d(∂e/∂a) = db/ρ³ − 3 b q/ρ⁵ − 3 ds_b r/ρ⁵ − 3 s_b dr/ρ⁵ + 15 s_b r q/ρ⁷
        out_g[c] += (
            db[c] * i3
            - 3.0 * b[c] * q * i5
            - 3.0 * (dsb * r[c] + sb * dr[c]) * i5
            + 15.0 * sb * r[c] * q * i7
        )
        # d(∂e/∂r), then ∂/∂x_i = −∂/∂r
        d_gr = (
            -3.0 * (dp * r[c] + p * dr[c]) * i5
            + 15.0 * p * r[c] * q * i7
            - 3.0 * (dsb * a[c] + sb * da[c] + dsa * b[c] + sa * db[c]) * i5
            + 15.0 * (sb * a[c] + sa * b[c]) * q * i7
            + 15.0 * (dsa * sb + sa * dsb) * r[c] * i7
            + 15.0 * sa * sb * dr[c] * i7
            - 105.0 * sa * sb * r[c] * q * i9
        )
        out_h[c] -= d_gr


@nb.njit(parallel=True, **_JIT)
def hessian_product(
    m: np.ndarray,
    x: np.ndarray,
    group: np.ndarray,
    dm: np.ndarray,
    dx: np.ndarray,
    lo: int,
    hi: int,
    scale: float,
    dG: np.ndarray,
    dH: np.ndarray,
) -> None:
    """For the targets ``lo ≤ i < hi``: the derivatives of ``G_i`` and ``H_i`` along
    ``(dm, dx)`` (every dipole's), times ``scale``."""
    n = len(x)
    for i in nb.prange(lo, hi):
        a, da = m[i], dm[i]
        out_g = np.zeros(3)
        out_h = np.zeros(3)
        for j in range(n):
            if group[j] == group[i]:
                continue
            b, db = m[j], dm[j]
            r = np.empty(3)
            dr = np.empty(3)
            for c in range(3):
                r[c] = x[j, c] - x[i, c]
                dr[c] = dx[j, c] - dx[i, c]
            _add_pair_product(a, da, b, db, r, dr, out_g, out_h)
        for c in range(3):
            dG[i - lo, c] = scale * out_g[c]
            dH[i - lo, c] = scale * out_h[c]


def warm() -> None:
    """Compile (or load from numba's cache) the sums on a tiny problem."""
    m = np.eye(3)[:2].copy()
    x = np.array([[0.0, 0.0, 0.0], [1.0, 0.2, 0.1]])
    group = np.array([0, 1])
    G, H, e = np.empty((2, 3)), np.empty((2, 3)), np.empty(2)
    gradient(m, x, group, 0, 2, 1.0, G, H, e)
    hessian_product(m, x, group, m, x, 0, 2, 1.0, G, H)
