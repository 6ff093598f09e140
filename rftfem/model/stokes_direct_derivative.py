"""The direct sums' position derivative ``G dx`` (``rftfem.model.stokes_direct``),
compiled the same way: the singular Stokeslet's over every pair, then each node's near
pairs turned into the blob's.
"""

from __future__ import annotations

from math import sqrt
from typing import TYPE_CHECKING

import numba as nb

from rftfem.model import stokes_kernels as kernels
from rftfem.model import stokes_pairs as pairs

if TYPE_CHECKING:
    from rftfem.model.stokes_direct import DirectSums

_JIT = dict(cache=True)
_FAST = pairs.FAST


@nb.njit(parallel=True, fastmath=_FAST, **_JIT)
def _far_derivative(x0, x1, x2, F0, F1, F2, v0, v1, v2, lo, hi, out):
    """``out[t − lo] = (G dx)_t`` with the singular Stokeslet, ``v = dx`` (no 1/8πμ;
    by component): ``Σ_j T_tj (dx_t − dx_j)``, vectorised as :func:`_far_mobility`;
    :func:`_near_derivative` turns the near pairs into the blob's."""
    n = len(x0)
    for t in nb.prange(lo, hi):
        acc0 = 0.0
        acc1 = 0.0
        acc2 = 0.0
        for j in range(n):
            s0, s1, s2 = pairs.stokeslet_direction(
                x0[t] - x0[j],
                x1[t] - x1[j],
                x2[t] - x2[j],
                F0[j],
                F1[j],
                F2[j],
                v0[t] - v0[j],
                v1[t] - v1[j],
                v2[t] - v2[j],
            )
            acc0 += s0
            acc1 += s1
            acc2 += s2
        out[t - lo, 0] = acc0
        out[t - lo, 1] = acc1
        out[t - lo, 2] = acc2


@nb.njit(parallel=True, fastmath=_FAST, **_JIT)
def _far_derivative_wall(x0, x1, x2, F0, F1, F2, v0, v1, v2, lo, hi, out):
    """:func:`_far_derivative` with the images' derivative in the target ``ξ`` and
    the source ``η`` added (the wall's frame)."""
    n = len(x0)
    for t in nb.prange(lo, hi):
        acc0 = 0.0
        acc1 = 0.0
        acc2 = 0.0
        for j in range(n):
            r0, r1, w0, w1 = x0[t] - x0[j], x1[t] - x1[j], v0[t] - v0[j], v1[t] - v1[j]
            s0, s1, s2 = pairs.stokeslet_direction(
                r0, r1, x2[t] - x2[j], F0[j], F1[j], F2[j], w0, w1, v2[t] - v2[j]
            )
            p0, p1, p2 = pairs.image_direction(
                r0, r1, x2[t] + x2[j], x2[j], F0[j], F1[j], F2[j], w0, w1, v2[t] + v2[j], v2[j]
            )
            acc0 += s0 + p0
            acc1 += s1 + p1
            acc2 += s2 + p2
        out[t - lo, 0] = acc0
        out[t - lo, 1] = acc1
        out[t - lo, 2] = acc2


@nb.njit(parallel=True, fastmath=_FAST, **_JIT)
def _near_derivative(x, delta, F, dx, start, near, lo, hi, out):
    """Add to ``out[t − lo]`` the blob's ``T w`` minus the singular one over the
    target's near sources (as :func:`_near_mobility`)."""
    beyond = kernels._STOKESLET_BEYOND
    for t in nb.prange(lo, hi):
        acc0 = 0.0
        acc1 = 0.0
        acc2 = 0.0
        dt2 = delta[t] * delta[t]
        for k in range(start[t], start[t + 1]):
            j = near[k]
            r0 = x[t, 0] - x[j, 0]
            r1 = x[t, 1] - x[j, 1]
            r2 = x[t, 2] - x[j, 2]
            d2 = r0 * r0 + r1 * r1 + r2 * r2
            eps = sqrt(0.5 * (dt2 + delta[j] * delta[j]))
            if j == t or d2 > beyond * beyond * eps * eps:
                continue
            _, b, da, db = kernels.radial(sqrt(d2), eps)
            inv = pairs.singular(d2)
            bs = inv * inv * inv
            b, da, db = b - bs, da + bs, db + 3.0 * bs * inv * inv
            w0 = dx[t, 0] - dx[j, 0]
            w1 = dx[t, 1] - dx[j, 1]
            w2 = dx[t, 2] - dx[j, 2]
            rF = r0 * F[j, 0] + r1 * F[j, 1] + r2 * F[j, 2]
            rw = r0 * w0 + r1 * w1 + r2 * w2
            Fw = F[j, 0] * w0 + F[j, 1] * w1 + F[j, 2] * w2
            cr = db * rF * rw + b * Fw
            acc0 += da * rw * F[j, 0] + cr * r0 + b * rF * w0
            acc1 += da * rw * F[j, 1] + cr * r1 + b * rF * w1
            acc2 += da * rw * F[j, 2] + cr * r2 + b * rF * w2
        out[t - lo, 0] += acc0
        out[t - lo, 1] += acc1
        out[t - lo, 2] += acc2


class _Derivative:
    def __init__(self, sums: DirectSums, forces_in_frame):
        self.sums, self.F = sums, forces_in_frame

    def __matmul__(self, dx):
        s = self.sums
        return s._sum(
            (_far_derivative, _far_derivative_wall), _near_derivative, self.F, s._in_frame(dx)
        )
