"""The Stokes operator without a dense matrix: fast multipoles and a local blob
correction (``[fluid] operator = "fmm"``, docs/stokes.md, Cost and scale).

The regularized mobility of ``rftfem.model.stokeslets`` splits into the singular
Stokeslet sum, which the Stokes fast multipole method of fmm3dpy evaluates in
O(N) to a requested precision, and a correction that only pairs closer than a few
blobs need:

    M F = Σ_j S(x_i − x_j) F_j/(8πμ)  +  Σ_{|x_i − x_j| < 6δ_ij} (S_δ − S)(x_i − x_j) F_j/(8πμ)
          + S_δ(0) F_i/(8πμ).

Beyond ρ = 6 the Gaussian blob differs from the Stokeslet by less than 1e-13
relatively, so the split is exact to round-off; the correction is a sparse matrix.

Forces from velocities, ``F = M⁻¹ v``, are the conjugate gradients of
``rftfem.model.stokes_matrix_free`` around these products.

The position derivative at fixed forces, ``G dx = ∂(M F)/∂x · dx``, is exact too:
for the singular part, the velocity gradient at each target (from the same FMM)
plus a Stokes doublet of strength ``F_j`` along ``dx_j`` at each source, since
``∂_y S(x − y)[F, dy] = 4π D(F, dy)`` with fmm3d's doublet ``D``; for the
correction, the sparse derivative of the pair blocks (``stokeslets.position_derivative``
restricted to the near pairs).
"""

from __future__ import annotations

from math import pi
from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from rftfem.model import stokes_matrix_free, stokes_rows, stokeslets

if TYPE_CHECKING:
    from collections.abc import Callable

    from mpi4py import MPI

#: pairs farther apart than this many pair blobs use the singular Stokeslet
CUTOFF = 6.0
#: the fast multipole method's requested precision (fmm3d meets it with room: the
#: product M F of a 5000-node plate is 2e-14 off the 1e-12 one, 25 % faster)
FMM_PRECISION = 1e-10
_I3 = np.arange(3)


def available() -> bool:
    """Whether fmm3dpy imports and its Stokes FMM takes doublets (2.x; 1.x has a
    different normalisation and no doublets)."""
    import inspect

    try:
        import fmm3dpy
    except ImportError:
        return False
    return "doublet" in inspect.signature(fmm3dpy.stfmm3d).parameters


def _block_matrix(rows, cols, blocks, n) -> sp.csr_matrix:
    """The 3n × 3n sparse matrix with 3 × 3 ``blocks`` at node ``(rows, cols)``."""
    r = (3 * rows[:, None, None] + _I3[None, :, None] + 0 * _I3[None, None, :]).ravel()
    c = (3 * cols[:, None, None] + 0 * _I3[None, :, None] + _I3[None, None, :]).ravel()
    return sp.coo_matrix((np.ravel(blocks), (r, c)), shape=(3 * n, 3 * n)).tocsr()


def FastResistance(
    x: np.ndarray, delta: np.ndarray, viscosity: float, wall: stokeslets.Wall | None = None
) -> stokes_matrix_free.MatrixFreeResistance:
    """The matrix-free resistance whose products are fast multipoles (:class:`FmmSums`),
    its clusters' mobilities compiled (the wall's images in)."""
    sums = FmmSums(x, delta, viscosity, wall)

    def cluster_mobility(c):
        M = stokes_rows.mobility_rows(sums.x[c], sums.delta[c], sums.viscosity)
        return M if wall is None else M + wall.mobility(sums.x[c], sums.viscosity)

    return stokes_matrix_free.MatrixFreeResistance(sums.x, sums, cluster_mobility)


class FmmSums:
    """``M F`` and ``G dx`` by fast multipoles plus the near blobs' sparse correction,
    at the positions ``x`` with blobs ``delta``; with a plane ``wall``, its images
    by fast multipoles too (``rftfem.model.stokes_fmm_wall``)."""

    def __init__(
        self,
        x: np.ndarray,
        delta: np.ndarray,
        viscosity: float,
        wall: stokeslets.Wall | None = None,
    ):
        from rftfem.model.stokes_fmm_wall import FmmImages

        self.x = np.array(x, dtype=float)
        self.delta = np.asarray(delta, dtype=float)
        self.viscosity = float(viscosity)
        self.n = len(self.x)
        #: the wall's images (None: no wall)
        self.images = None if wall is None else FmmImages(self.x, wall, FMM_PRECISION)
        self._sources = np.ascontiguousarray(self.x.T)
        self._near_pairs()
        self.correction = self._near_blocks()

    # --- the operator -----------------------------------------------------

    def _near_pairs(self):
        """Node pairs (both orders) closer than ``CUTOFF`` pair blobs: ``i``, ``j``,
        ``r = x_i − x_j``, their distance and pair blob."""
        reach = CUTOFF * float(self.delta.max())
        pairs = cKDTree(self.x).query_pairs(reach, output_type="ndarray")
        i, j = pairs[:, 0], pairs[:, 1]
        d = np.sqrt(0.5 * (self.delta[i] ** 2 + self.delta[j] ** 2))
        r = self.x[i] - self.x[j]
        dist = np.linalg.norm(r, axis=1)
        keep = dist < CUTOFF * d
        i, j, r, dist, d = i[keep], j[keep], r[keep], dist[keep], d[keep]
        self.i, self.j = np.r_[i, j], np.r_[j, i]
        self.r, self.dist, self.d = np.r_[r, -r], np.r_[dist, dist], np.r_[d, d]

    def _near_blocks(self) -> sp.csr_matrix:
        """``(S_δ − S)/(8πμ)`` on the near pairs and ``S_δ(0)/(8πμ)`` on the diagonal."""
        f0, f1, _, _ = stokeslets.radial(self.dist / self.d)
        da = f0 / self.d - 1.0 / self.dist
        db = f1 / self.d**3 - 1.0 / self.dist**3
        r = self.r
        blocks = da[:, None, None] * np.eye(3) + db[:, None, None] * r[:, :, None] * r[:, None, :]
        a0 = stokeslets.radial(np.zeros(1))[0][0] / self.delta
        own = a0[:, None, None] * np.eye(3)
        nodes = np.arange(self.n)
        rows, cols = np.r_[self.i, nodes], np.r_[self.j, nodes]
        return _block_matrix(rows, cols, np.concatenate([blocks, own]), self.n) / (
            8 * pi * self.viscosity
        )

    def _fmm(self, **sources):
        import fmm3dpy

        flat = {
            k: np.ascontiguousarray(np.reshape(v, (-1, 3)).T)
            for k, v in sources.items()
            if k != "ifppreg"
        }
        return fmm3dpy.stfmm3d(
            eps=FMM_PRECISION, sources=self._sources, ifppreg=sources.get("ifppreg", 1), **flat
        )

    def mobility(self, forces: np.ndarray) -> np.ndarray:
        """``M F`` for forces of length 3N."""
        if self.images is None:
            u = self._fmm(stoklet=forces).pot.reshape(3, self.n).T
        else:  # the free Stokeslets and their images in one multipole call
            u = self.images.velocity(forces, free=True)
        return u.ravel() / self.viscosity + self.correction @ forces

    def derivative_operator(self, forces: np.ndarray) -> "PositionDerivative":
        """``dx ↦ G dx = ∂(M F)/∂x · dx`` at the fixed ``forces``."""
        return PositionDerivative(self, np.asarray(forces, dtype=float).reshape(-1, 3))


class PositionDerivative:
    """``G dx`` of :class:`FmmSums` at fixed forces, applied with ``@``."""

    def __init__(self, res: FmmSums, F: np.ndarray):
        self.res, self.F = res, F
        if res.images is None:
            out = res._fmm(stoklet=F, ifppreg=3)
            gradient = np.moveaxis(out.grad.reshape(3, 3, res.n), -1, 0)
        else:
            gradient = res.images.gradient(F, free=True)
        #: ∂u_a/∂x_k at every node, (N, k, a)
        self.gradient = gradient / res.viscosity
        self.near = self._near_derivative()

    def _near_derivative(self) -> sp.csr_matrix:
        """The near pairs' part: ``−ΔT_ij`` off the diagonal, ``Σ_j ΔT_ij`` on it, with
        ``T = ∂(S F_j)/∂r`` of the regularized minus the singular kernel."""
        res, F = self.res, self.F
        r, dist, d = res.r, res.dist, res.d
        _, f1, f2, f3 = stokeslets.radial(dist / d)
        b = f1 / d**3 - 1.0 / dist**3
        da = f2 / d**3 + 1.0 / dist**3
        db = f3 / d**5 + 3.0 / dist**5
        Fj = F[res.j]
        rF = np.einsum("pk,pk->p", r, Fj)
        T = da[:, None, None] * Fj[:, :, None] * r[:, None, :]
        T += (db * rF)[:, None, None] * r[:, :, None] * r[:, None, :]
        T += b[:, None, None] * r[:, :, None] * Fj[:, None, :]
        T += (b * rF)[:, None, None] * np.eye(3)
        diag = np.zeros((res.n, 3, 3))
        np.add.at(diag, res.i, T)
        nodes = np.arange(res.n)
        return _block_matrix(
            np.r_[res.i, nodes], np.r_[res.j, nodes], np.concatenate([-T, diag]), res.n
        ) / (8 * pi * res.viscosity)

    def __matmul__(self, dx: np.ndarray) -> np.ndarray:
        res = self.res
        d = np.reshape(dx, (-1, 3))
        target = np.einsum("nka,nk->na", self.gradient, d)
        if res.images is None:
            sources = 0.5 * res._fmm(doublet=self.F, doubvec=d).pot.reshape(3, res.n).T
        else:
            sources = res.images.source_motion(self.F, d, free=True)
        return (target + sources / res.viscosity).ravel() + self.near @ np.ravel(dx)


class OnFirst:
    """A resistance made and applied on the first process only, its results
    broadcast: the matrix-free operator is threaded, and every process must see
    the same forces to round-off."""

    def __init__(
        self,
        comm: MPI.Comm,
        x: np.ndarray,
        make: Callable[[], stokes_matrix_free.MatrixFreeResistance],
    ):
        self.comm, self.x = comm, np.array(x)
        self.res = make() if comm.rank == 0 else None

    def _first(self, compute):
        value = compute() if self.comm.rank == 0 else None
        return self.comm.bcast(value, root=0) if self.comm.size > 1 else value

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        return self._first(lambda: self.res.solve(rhs))

    def lumped(self) -> np.ndarray:
        return self._first(self.res.lumped if self.res is not None else None)

    def position_operator(self, forces: np.ndarray) -> _FirstProduct:
        return _FirstProduct(self, None if self.res is None else self.res.position_operator(forces))


class _FirstProduct:
    def __init__(self, owner: OnFirst, operator):
        self.owner, self.operator = owner, operator

    def __matmul__(self, dx):
        return self.owner._first(lambda: self.operator @ dx)
