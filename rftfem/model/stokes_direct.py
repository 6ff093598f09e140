"""The blobs' Stokes operator as compiled direct sums: ``M F`` and ``G dx`` without a
matrix (``[fluid] operator = "direct"``, docs/stokes.md §Cost and scale).

Every target sums every source, threaded over the targets (numba):

    (M F)_i  = Σ_j [S_δij(x_i − x_j) + W(x_i, x_j)] F_j / (8πμ),
    (G dx)_i = Σ_j [T_ij (dx_i − dx_j) + W_ξ,ij dx_i + W_η,ij dx_j] / (8πμ),

with ``S_δ`` the regularized Stokeslet of the pair blob ``δ_ij² = (δ_i² + δ_j²)/2``
(``rftfem.model.stokeslets``; ``j = i`` its own blob), ``T_ij = ∂(S_δij(r) F_j)/∂r``,
and, with a wall, Blake's images ``W`` and their closed-form derivatives in the
target ``ξ`` and the source ``η`` (``rftfem.model.stokes_kernels``).  The sums are
exact: no multipole expansion, no near-field correction.  An O(N²) sum costs about
as many flops as a multipole call's constant at the sizes a run takes (docs/stokes.md
gives the crossover measured on the project's machine), needs O(N) memory, and
splits by rows: under ``mpirun`` each process sums its share of the targets and
the rows are gathered, so every process holds the same product to round-off.
"""

from __future__ import annotations

from math import pi, sqrt
from typing import TYPE_CHECKING

import numba as nb
import numpy as np

from rftfem.model import stokes_kernels as kernels

if TYPE_CHECKING:
    from mpi4py import MPI

    from rftfem.model.stokes_matrix_free import MatrixFreeResistance
    from rftfem.model.stokeslets import Wall

_JIT = dict(cache=True)


#: numba's floating-point freedoms for the sums: reassociation (vectorised loops),
#: fused multiply-adds and signless zeros; never approximate reciprocals or roots
_FAST = {"reassoc", "contract", "nsz"}


@nb.njit(fastmath=_FAST, **_JIT)
def _image_velocity(R0, R1, R2, h, f0, f1, f2):
    """Blake's images' velocity ``W f`` at ``R = ξ − Dη``, ``h = η₃`` (the wall's
    frame; ``stokes_kernels.image_block`` applied to ``f``):
    ``W f = R (a R·f + b R·Df) + c f + d Df + e (R·Df) e₃ + e f₃ R`` with
    ``a = −1/R³, b = 6h(R₃ − h)/R⁵, c = −1/R, d = 2h(h − R₃)/R³, e = 2h/R³``."""
    i1 = 1.0 / sqrt(R0 * R0 + R1 * R1 + R2 * R2)
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


@nb.njit(fastmath=_FAST, **_JIT)
def _image_direction(R0, R1, R2, h, f0, f1, f2, P0, P1, P2, hp):
    """The derivative of :func:`_image_velocity` along ``R′ = P``, ``h′ = hp`` (at
    fixed ``f``), term by term of its coefficients."""
    i1 = 1.0 / sqrt(R0 * R0 + R1 * R1 + R2 * R2)
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


@nb.njit(parallel=True, fastmath=_FAST, **_JIT)
def _mobility_product(x, delta, F, lo, hi, wall, out):
    """``out[t − lo] = Σ_j (S_δ + W) F_j`` for the targets ``lo ≤ t < hi`` (no 1/8πμ);
    positions and forces in the wall's frame when ``wall``.  Beyond
    ``_STOKESLET_BEYOND`` pair blobs the blob is the Stokeslet (``radial``'s own
    switch), summed inline."""
    n = len(x)
    beyond = kernels._STOKESLET_BEYOND
    largest = delta.max()
    for t in nb.prange(lo, hi):
        u0 = 0.0
        u1 = 0.0
        u2 = 0.0
        dt2 = delta[t] * delta[t]
        far2 = beyond * beyond * 0.5 * (dt2 + largest * largest)
        for j in range(n):
            r0 = x[t, 0] - x[j, 0]
            r1 = x[t, 1] - x[j, 1]
            r2 = x[t, 2] - x[j, 2]
            d2 = r0 * r0 + r1 * r1 + r2 * r2
            if d2 > far2:
                a = 1.0 / sqrt(d2)
                b = a * a * a
            else:
                a, b, _, _ = kernels.radial(sqrt(d2), sqrt(0.5 * (dt2 + delta[j] * delta[j])))
            rF = b * (r0 * F[j, 0] + r1 * F[j, 1] + r2 * F[j, 2])
            u0 += a * F[j, 0] + rF * r0
            u1 += a * F[j, 1] + rF * r1
            u2 += a * F[j, 2] + rF * r2
            if wall:
                w0, w1, w2 = _image_velocity(
                    r0, r1, x[t, 2] + x[j, 2], x[j, 2], F[j, 0], F[j, 1], F[j, 2]
                )
                u0 += w0
                u1 += w1
                u2 += w2
        out[t - lo, 0] = u0
        out[t - lo, 1] = u1
        out[t - lo, 2] = u2


@nb.njit(parallel=True, fastmath=_FAST, **_JIT)
def _derivative_product(x, delta, F, dx, lo, hi, wall, out):
    """``out[t − lo] = (G dx)_t`` (no 1/8πμ), the wall's frame when ``wall``.  With
    ``w = dx_t − dx_j`` the free part is ``T w = a′/r (r·w) F + b′/r (r·F)(r·w) r
    + b (F·w) r + b (r·F) w`` (``stokes_kernels.free_gradient`` contracted)."""
    n = len(x)
    beyond = kernels._STOKESLET_BEYOND
    largest = delta.max()
    for t in nb.prange(lo, hi):
        acc0 = 0.0
        acc1 = 0.0
        acc2 = 0.0
        dt2 = delta[t] * delta[t]
        far2 = beyond * beyond * 0.5 * (dt2 + largest * largest)
        for j in range(n):
            r0 = x[t, 0] - x[j, 0]
            r1 = x[t, 1] - x[j, 1]
            r2 = x[t, 2] - x[j, 2]
            d2 = r0 * r0 + r1 * r1 + r2 * r2
            if j != t:
                if d2 > far2:
                    inv = 1.0 / sqrt(d2)
                    b = inv * inv * inv
                    da = -b
                    db = -3.0 * b * inv * inv
                else:
                    _, b, da, db = kernels.radial(sqrt(d2), sqrt(0.5 * (dt2 + delta[j] * delta[j])))
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
            if wall:
                w0, w1, w2 = _image_direction(
                    r0,
                    r1,
                    x[t, 2] + x[j, 2],
                    x[j, 2],
                    F[j, 0],
                    F[j, 1],
                    F[j, 2],
                    dx[t, 0] - dx[j, 0],
                    dx[t, 1] - dx[j, 1],
                    dx[t, 2] + dx[j, 2],
                    dx[j, 2],
                )
                acc0 += w0
                acc1 += w1
                acc2 += w2
        out[t - lo, 0] = acc0
        out[t - lo, 1] = acc1
        out[t - lo, 2] = acc2


def warm() -> None:
    """Compile (or load from numba's cache) both sums on a tiny problem."""
    x = np.array([[0.0, 0.0, 1.0], [0.3, 0.1, 1.2]])
    d, F, out = np.full(2, 0.1), np.ones((2, 3)), np.empty((2, 3))
    for wall in (False, True):
        _mobility_product(x, d, F, 0, 2, wall, out)
        _derivative_product(x, d, F, F, 0, 2, wall, out)
        _mobility_matrix(x, d, wall, np.eye(3), 0, 2, np.empty((2, 3, 2, 3)))


class DirectSums:
    """``M F`` and ``G dx`` at the positions ``x`` (N, 3) with blobs ``delta`` (N,),
    in the liquid of ``viscosity``, with an optional plane ``wall``
    (``stokeslets.Wall``); under ``comm`` each process sums its share of the rows."""

    def __init__(
        self,
        x: np.ndarray,
        delta: np.ndarray,
        viscosity: float,
        wall: Wall | None = None,
        comm: MPI.Comm | None = None,
    ):
        self.n = len(x)
        self.wall = wall
        self.comm = comm if comm is not None and comm.size > 1 else None
        self.scale = 1.0 / (8 * pi * float(viscosity))
        self.x = self._in_frame(np.asarray(x, dtype=float), True)
        self.delta = np.ascontiguousarray(delta, dtype=float)
        size, rank = (self.comm.size, self.comm.rank) if self.comm else (1, 0)
        counts = [self.n // size + (r < self.n % size) for r in range(size)]
        self.counts = counts
        self.lo = int(sum(counts[:rank]))
        self.hi = self.lo + counts[rank]

    def _in_frame(self, v, points=False):
        v = np.reshape(v, (-1, 3))
        if self.wall is None:
            return np.ascontiguousarray(v, dtype=float)
        return kernels.to_frame(self.wall.Q, self.wall.point if points else None, v)

    def _out_of_frame(self, rows):
        return rows if self.wall is None else rows @ self.wall.Q

    def _gathered(self, rows):
        rows = self._out_of_frame(rows) * self.scale
        if self.comm is None:
            return rows.ravel()
        out = np.empty(3 * self.n)
        self.comm.Allgatherv(
            np.ascontiguousarray(rows.ravel()), [out, [3 * c for c in self.counts]]
        )
        return out

    def mobility(self, forces: np.ndarray) -> np.ndarray:
        """``M F`` (3N) for forces of length 3N."""
        out = np.empty((self.hi - self.lo, 3))
        _mobility_product(
            self.x, self.delta, self._in_frame(forces), self.lo, self.hi, self.wall is not None, out
        )
        return self._gathered(out)

    def derivative(self, forces: np.ndarray, dx: np.ndarray) -> np.ndarray:
        """``G dx`` (3N): ``∂(M F)/∂x · dx`` at the fixed ``forces``."""
        return self.derivative_operator(forces) @ dx

    def matrix(self, nodes: np.ndarray) -> np.ndarray:
        """The dense mobility of the ``nodes`` alone (3k × 3k, the wall's images in);
        the whole body's is made by rows on every process and gathered."""
        from rftfem.model.ranks import gather_rows

        x, d = self.x[nodes], self.delta[nodes]
        Q = np.eye(3) if self.wall is None else self.wall.Q
        whole = self.comm is not None and len(nodes) == self.n
        lo, hi = (self.lo, self.hi) if whole else (0, len(nodes))
        out = np.empty((hi - lo, 3, len(nodes), 3))
        _mobility_matrix(x, d, self.wall is not None, Q, lo, hi, out)
        out = out.reshape(3 * (hi - lo), -1)
        out *= self.scale
        return gather_rows(out, self.comm) if whole else out

    def derivative_operator(self, forces: np.ndarray) -> "_Derivative":
        """``dx ↦ G dx`` at the fixed ``forces``, applied with ``@``."""
        return _Derivative(self, self._in_frame(forces))


class _Derivative:
    def __init__(self, sums: DirectSums, forces_in_frame):
        self.sums, self.F = sums, forces_in_frame

    def __matmul__(self, dx):
        s = self.sums
        out = np.empty((s.hi - s.lo, 3))
        _derivative_product(
            s.x, s.delta, self.F, s._in_frame(dx), s.lo, s.hi, s.wall is not None, out
        )
        return s._gathered(out)


def DirectResistance(
    x: np.ndarray,
    delta: np.ndarray,
    viscosity: float,
    wall: Wall | None = None,
    comm: MPI.Comm | None = None,
    kept: MatrixFreeResistance | None = None,
) -> MatrixFreeResistance:
    """The matrix-free resistance whose products are direct sums (every process sums
    its rows); its clusters' mobilities compiled the same way (the wall's images
    in); ``kept``: an earlier configuration's, whose factors it keeps (one cluster)."""
    from rftfem.model import stokes_matrix_free

    sums = DirectSums(x, delta, viscosity, wall, comm)
    return stokes_matrix_free.MatrixFreeResistance(x, sums, sums.matrix, kept=kept)


@nb.njit(parallel=True, **_JIT)
def _mobility_matrix(x, delta, wall, Q, lo, hi, out):
    """``out[t − lo, :, j, :]``: the 3 × 3 blocks of ``M`` (no 1/8πμ) of the targets
    ``lo ≤ t < hi`` and every source; with a ``wall`` the positions are in its frame
    and each block is turned back, ``Qᵀ B Q``."""
    n = len(x)
    for t in nb.prange(lo, hi):
        B = np.empty((3, 3))
        W = np.empty((3, 3))
        r = np.empty(3)
        dt2 = delta[t] * delta[t]
        for j in range(n):
            for c in range(3):
                r[c] = x[t, c] - x[j, c]
            kernels.free_block(r, sqrt(0.5 * (dt2 + delta[j] * delta[j])), B)
            if wall:
                kernels.image_block(x[t], x[j], W)
                for i in range(3):
                    for k in range(3):
                        W[i, k] += B[i, k]
                for i in range(3):  # B = W Q, then out = Qᵀ B
                    for k in range(3):
                        B[i, k] = W[i, 0] * Q[0, k] + W[i, 1] * Q[1, k] + W[i, 2] * Q[2, k]
                for i in range(3):
                    for k in range(3):
                        turned = Q[0, i] * B[0, k] + Q[1, i] * B[1, k] + Q[2, i] * B[2, k]
                        out[t - lo, i, j, k] = turned
            else:
                for i in range(3):
                    for k in range(3):
                        out[t - lo, i, j, k] = B[i, k]
