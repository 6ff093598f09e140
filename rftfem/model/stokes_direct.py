"""The blobs' Stokes operator as compiled direct sums: ``M F`` and ``G dx`` without a
matrix (``[fluid] operator = "direct"``, docs/stokes.md §Cost and scale).

Every target sums every source, threaded over the targets (numba):

    (M F)_i  = Σ_j [S_δij(x_i − x_j) + W(x_i, x_j)] F_j / (8πμ),
    (G dx)_i = Σ_j [T_ij (dx_i − dx_j) + W_ξ,ij dx_i + W_η,ij dx_j] / (8πμ),

with ``S_δ`` the regularized Stokeslet of the pair blob ``δ_ij² = (δ_i² + δ_j²)/2``
(``rftfem.model.stokeslets``; ``j = i`` its own blob), ``T_ij = ∂(S_δij(r) F_j)/∂r``,
and, with a wall, Blake's images ``W`` and their closed-form derivatives in the
target ``ξ`` and the source ``η`` (``rftfem.model.stokes_kernels``).  Each sum
runs in two passes: every pair with the singular Stokeslet (and the images), in
loops without branches that the compiler vectorises, its ``1/r`` from single
precision's root refined to double by two Newton steps; then each node's near
pairs (within ``_STOKESLET_BEYOND`` of the largest blob, found by a k-d tree) add
the blob's kernel minus the singular one.  Nothing is expanded or cut off: the
sums are exact to round-off.  An O(N²) sum costs about as many flops as a
multipole call's constant at the sizes a run takes (docs/stokes.md gives the
crossover measured on the project's machine), needs O(N) memory, and splits by
rows: under ``mpirun`` each process sums its share of the targets and the rows
are gathered, so every process holds the same product to round-off.  The sums of
``G dx`` are ``rftfem.model.stokes_direct_derivative``'s.
"""

from __future__ import annotations

from math import pi, sqrt
from typing import TYPE_CHECKING

import numba as nb
import numpy as np

from rftfem.model import stokes_kernels as kernels
from rftfem.model import stokes_pairs as pairs
from rftfem.model.stokes_direct_derivative import (
    _Derivative,
    _far_derivative,
    _far_derivative_wall,
    _near_derivative,
)

if TYPE_CHECKING:
    from mpi4py import MPI

    from rftfem.model.stokes_matrix_free import MatrixFreeResistance
    from rftfem.model.stokeslets import Wall

_JIT = dict(cache=True)


_FAST = pairs.FAST


@nb.njit(parallel=True, fastmath=_FAST, **_JIT)
def _far_mobility(x0, x1, x2, F0, F1, F2, lo, hi, out):
    """``out[t − lo] = Σ_j S F_j`` over every pair with the singular Stokeslet ``S``
    (no 1/8πμ; coordinates and forces by component): a loop without branches,
    which the compiler vectorises.  :func:`_near_mobility` turns the near pairs
    into the blob's kernel."""
    n = len(x0)
    for t in nb.prange(lo, hi):
        u0 = 0.0
        u1 = 0.0
        u2 = 0.0
        for j in range(n):
            s0, s1, s2 = pairs.stokeslet(
                x0[t] - x0[j], x1[t] - x1[j], x2[t] - x2[j], F0[j], F1[j], F2[j]
            )
            u0 += s0
            u1 += s1
            u2 += s2
        out[t - lo, 0] = u0
        out[t - lo, 1] = u1
        out[t - lo, 2] = u2


@nb.njit(parallel=True, fastmath=_FAST, **_JIT)
def _far_mobility_wall(x0, x1, x2, F0, F1, F2, lo, hi, out):
    """:func:`_far_mobility` with Blake's images ``W F_j`` added (the wall's frame)."""
    n = len(x0)
    for t in nb.prange(lo, hi):
        u0 = 0.0
        u1 = 0.0
        u2 = 0.0
        for j in range(n):
            r0, r1 = x0[t] - x0[j], x1[t] - x1[j]
            s0, s1, s2 = pairs.stokeslet(r0, r1, x2[t] - x2[j], F0[j], F1[j], F2[j])
            w0, w1, w2 = pairs.image_velocity(r0, r1, x2[t] + x2[j], x2[j], F0[j], F1[j], F2[j])
            u0 += s0 + w0
            u1 += s1 + w1
            u2 += s2 + w2
        out[t - lo, 0] = u0
        out[t - lo, 1] = u1
        out[t - lo, 2] = u2


@nb.njit(parallel=True, fastmath=_FAST, **_JIT)
def _near_mobility(x, delta, F, start, near, lo, hi, out):
    """Add to ``out[t − lo]`` the blob's kernel minus the singular one over the
    target's near sources ``near[start[t]:start[t + 1]]`` (``radial``'s own switch:
    beyond ``_STOKESLET_BEYOND`` pair blobs the two are one)."""
    beyond = kernels._STOKESLET_BEYOND
    for t in nb.prange(lo, hi):
        u0 = 0.0
        u1 = 0.0
        u2 = 0.0
        dt2 = delta[t] * delta[t]
        for k in range(start[t], start[t + 1]):
            j = near[k]
            r0 = x[t, 0] - x[j, 0]
            r1 = x[t, 1] - x[j, 1]
            r2 = x[t, 2] - x[j, 2]
            d2 = r0 * r0 + r1 * r1 + r2 * r2
            eps = sqrt(0.5 * (dt2 + delta[j] * delta[j]))
            if d2 > beyond * beyond * eps * eps:
                continue
            a, b, _, _ = kernels.radial(sqrt(d2), eps)
            s = pairs.singular(d2)
            a, b = a - s, b - s * s * s
            rF = b * (r0 * F[j, 0] + r1 * F[j, 1] + r2 * F[j, 2])
            u0 += a * F[j, 0] + rF * r0
            u1 += a * F[j, 1] + rF * r1
            u2 += a * F[j, 2] + rF * r2
        out[t - lo, 0] += u0
        out[t - lo, 1] += u1
        out[t - lo, 2] += u2


def near_pairs(x: np.ndarray, delta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each node's near sources as compressed rows ``(start, near)``: itself and every
    node within ``_STOKESLET_BEYOND`` of the largest blob, where the blob's kernel
    may differ from the Stokeslet.  Refuses what :func:`pairs.inverse_root` cannot take:
    nodes 1e-18 apart or a body 1e18 across."""
    from scipy.spatial import cKDTree

    n = len(x)
    reach = kernels._STOKESLET_BEYOND * float(delta.max()) * (1.0 + 1e-9)
    close = cKDTree(x).query_pairs(reach, output_type="ndarray")
    extent = float(np.ptp(x, axis=0).max()) if n else 0.0
    gaps = np.einsum("ij,ij->i", *(x[close[:, 0]] - x[close[:, 1]],) * 2)
    if extent > 1e18 or (len(gaps) and gaps.min() < 1e-36):
        where = f"a body {extent:.3g} across" if extent > 1e18 else "nodes closer than 1e-18"
        from rftfem.errors import SceneError

        raise SceneError(f"fluid: {where}: the Stokes sums need distinct nodes within 1e18")
    rows = np.concatenate([close[:, 0], close[:, 1], np.arange(n)])
    cols = np.concatenate([close[:, 1], close[:, 0], np.arange(n)])
    order = np.argsort(rows, kind="stable")
    start = np.zeros(n + 1, dtype=np.int64)
    start[1:] = np.cumsum(np.bincount(rows, minlength=n))
    return start, np.ascontiguousarray(cols[order], dtype=np.int64)


def warm() -> None:
    """Compile (or load from numba's cache) both sums on a tiny problem."""
    x = np.array([[0.0, 0.0, 1.0], [0.3, 0.1, 1.2]])
    d, F, out = np.full(2, 0.1), np.ones((2, 3)), np.empty((2, 3))
    start, near = near_pairs(x, d)
    c = [np.ascontiguousarray(x[:, k]) for k in range(3)]
    for far in (_far_mobility, _far_mobility_wall):
        far(*c, *c, 0, 2, out)
        _near_mobility(x, d, F, start, near, 0, 2, out)
    for far in (_far_derivative, _far_derivative_wall):
        far(*c, *c, *c, 0, 2, out)
        _near_derivative(x, d, F, F, start, near, 0, 2, out)
    for wall in (False, True):
        _mobility_matrix(x, d, wall, np.eye(3), 0, 2, np.empty((2, 3, 2, 3)))
    from rftfem.model import stokes_rows

    stokes_rows.derivative_rows(x, d, 1.0, F)


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
        #: the near sources of every node (:func:`near_pairs`): part of the set-up
        self.near = near_pairs(self.x, self.delta)

    def _sum(self, far, near, *fields):
        """``far`` (free, wall) over every pair, by component, then ``near``'s
        correction: the rows ``lo … hi`` gathered, out of the wall's frame, scaled."""
        out = np.empty((self.hi - self.lo, 3))
        columns = [np.ascontiguousarray(v[:, k]) for v in (self.x, *fields) for k in range(3)]
        far[self.wall is not None](*columns, self.lo, self.hi, out)
        near(self.x, self.delta, *fields, *self.near, self.lo, self.hi, out)
        return self._gathered(out)

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
        return self._sum(
            (_far_mobility, _far_mobility_wall), _near_mobility, self._in_frame(forces)
        )

    def derivative(self, forces: np.ndarray, dx: np.ndarray) -> np.ndarray:
        """``G dx`` (3N): ``∂(M F)/∂x · dx`` at the fixed ``forces``."""
        return self.derivative_operator(forces) @ dx

    def matrix(self, nodes: np.ndarray) -> np.ndarray:
        """The dense mobility of the ``nodes`` alone (3k × 3k, the wall's images in);
        of the whole body under ``comm``, this process's rows of it (its share of
        the targets), which the processes factorise together."""
        x, d = self.x[nodes], self.delta[nodes]
        Q = np.eye(3) if self.wall is None else self.wall.Q
        whole = self.comm is not None and len(nodes) == self.n
        lo, hi = (self.lo, self.hi) if whole else (0, len(nodes))
        out = np.empty((hi - lo, 3, len(nodes), 3))
        _mobility_matrix(x, d, self.wall is not None, Q, lo, hi, out)
        out = out.reshape(3 * (hi - lo), -1)
        out *= self.scale
        return out

    def derivative_operator(self, forces: np.ndarray) -> "_Derivative":
        """``dx ↦ G dx`` at the fixed ``forces``, applied with ``@``."""
        return _Derivative(self, self._in_frame(forces))


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
