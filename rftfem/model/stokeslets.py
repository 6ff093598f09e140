"""Regularized Stokeslets (docs/stokes.md): the kernel of both Stokes methods, the
blobs' operator (``fluid.method = "blobs"``: point forces ``F_j`` at the nodes
``x_j``) and a plane wall's images.  The liquid's velocity at ``x_i`` is

    u_i = Σ_j S_δ(x_i − x_j) F_j / (8πμ),
    S_δ(r) F = a(r) F + b(r) (r·F) r,  a = s₁(ρ)/r,  b = s₂(ρ)/r³,  ρ = r/δ,

with the Gaussian blob functions

    s₁(ρ) = erf ρ + (2/√π) ρ (3 − 2ρ²) e^(−ρ²),
    s₂(ρ) = erf ρ − (2/√π) ρ (1 − 2ρ²) e^(−ρ²).

Both tend to 1 (the Stokeslet) within a few δ.  The pair is divergence-free
(ρ (s₁′ + s₂′) = s₁ − s₂), and ∫₀^∞ (sₖ − 1) dρ = 0 for both: on a flat patch the
regularized single layer then differs from the singular one by O(δ³) instead of
the O(δ) of the algebraic blob of Cortez, Fauci & Medovikov (2005).  The matrix
is symmetric positive definite (the blob's Fourier transform is positive).

Each pair's blob is ``δ_ij = √((δ_i² + δ_j²)/2)`` (symmetric for nodal sizes δ_i).
Everything here is numpy on global arrays of nodes (``rftfem.model.effects.stokes``
gathers them and scatters the forces); the radial functions are
``rftfem.model.blob_radial``'s.
"""

from __future__ import annotations

from math import pi
from typing import TYPE_CHECKING

import numpy as np

from rftfem.model.blob_radial import radial
from rftfem.model.ranks import gather_rows

if TYPE_CHECKING:
    from collections.abc import Sequence

    from mpi4py import MPI


def pair_blobs(delta: np.ndarray, rows: slice | np.ndarray = slice(None)) -> np.ndarray:
    """``δ_ij = √((δ_i² + δ_j²)/2)`` for the target rows ``rows`` and every source."""
    d2 = np.asarray(delta, dtype=float) ** 2
    return np.sqrt(0.5 * (d2[rows, None] + d2[None, :]))


def _pairs(x, delta, rows):
    r = x[rows, None, :] - x[None, :, :]
    dist = np.sqrt(np.einsum("ijk,ijk->ij", r, r))
    d = pair_blobs(delta, rows)
    return r, dist / d, d


def mobility(
    x: np.ndarray, delta: np.ndarray, viscosity: float, rows: slice | None = None
) -> np.ndarray:
    """The dense ``3N × 3N`` matrix ``M`` with ``u = M F`` (node by node, xyz), or
    its rows of the target nodes ``rows`` (``3 len(rows) × 3N``)."""
    x = np.asarray(x, dtype=float)
    n = len(x)
    lo, hi = _bounds(rows, n)
    M = np.empty((hi - lo, 3, n, 3))
    for chunk in _chunks(hi - lo, total=n):
        r, rho, d = _pairs(x, delta, _shift(chunk, lo))
        f0, f1, _, _ = radial(rho)
        a, b = f0 / d, f1 / d**3
        block = b[:, :, None, None] * r[:, :, :, None] * r[:, :, None, :]
        block += a[:, :, None, None] * np.eye(3)
        M[chunk] = block.transpose(0, 2, 1, 3)
    M /= 8 * pi * viscosity
    return M.reshape(3 * (hi - lo), 3 * n)


def _bounds(rows: slice | None, n: int) -> tuple[int, int]:
    return (0, n) if rows is None else (rows.start, rows.stop)


def _shift(chunk: slice, lo: int) -> slice:
    return slice(chunk.start + lo, chunk.stop + lo)


def velocity(
    x: np.ndarray,
    delta: np.ndarray,
    viscosity: float,
    forces: np.ndarray,
    targets: np.ndarray | None = None,
) -> np.ndarray:
    """``u_i = Σ_j S_δ(x_i − x_j) F_j/(8πμ)`` at the nodes ``targets`` (default all), ``(·, 3)``."""
    x = np.asarray(x, dtype=float)
    F = np.asarray(forces, dtype=float).reshape(-1, 3)
    idx = np.arange(len(x)) if targets is None else np.asarray(targets)
    out = np.empty((len(idx), 3))
    for rows in _chunks(len(idx), total=len(x)):
        r, rho, d = _pairs(x, delta, idx[rows])
        f0, f1, _, _ = radial(rho)
        rF = np.einsum("ijk,jk->ij", r, F)
        out[rows] = np.einsum("ij,jk->ik", f0 / d, F) + np.einsum("ij,ijk->ik", f1 / d**3 * rF, r)
    return out / (8 * pi * viscosity)


def position_derivative(
    x: np.ndarray,
    delta: np.ndarray,
    viscosity: float,
    forces: np.ndarray,
    rows: slice | None = None,
) -> np.ndarray:
    """``G = ∂u/∂x`` at fixed forces (dense ``3N × 3N``, or the rows of the target
    nodes ``rows``): ``du = M dF + G dx``.

    With ``T_ij = ∂(S_δ(r) F_j)/∂r`` at ``r = x_i − x_j``,
    ``T = (a′/r) F⊗r + (b′/r)(r·F) r⊗r + b r⊗F + b (r·F) I``,
    ``G_ij = −T_ij`` (j ≠ i) and ``G_ii = Σ_j T_ij``."""
    x = np.asarray(x, dtype=float)
    F = np.asarray(forces, dtype=float).reshape(-1, 3)
    n = len(x)
    lo, hi = _bounds(rows, n)
    G = np.empty((hi - lo, 3, n, 3))
    eye = np.eye(3)
    for chunk in _chunks(hi - lo, total=n):
        targets = _shift(chunk, lo)
        r, rho, d = _pairs(x, delta, targets)
        _, f1, f2, f3 = radial(rho)
        b, da, db = f1 / d**3, f2 / d**3, f3 / d**5
        rF = np.einsum("ijk,jk->ij", r, F)
        T = da[:, :, None, None] * F[None, :, :, None] * r[:, :, None, :]
        T += (db * rF)[:, :, None, None] * r[:, :, :, None] * r[:, :, None, :]
        T += b[:, :, None, None] * r[:, :, :, None] * F[None, :, None, :]
        T += (b * rF)[:, :, None, None] * eye
        T = -T
        diag = -T.sum(axis=1)
        T[np.arange(chunk.stop - chunk.start), np.arange(targets.start, targets.stop)] += diag
        G[chunk] = T.transpose(0, 2, 1, 3)
    G /= 8 * pi * viscosity
    return G.reshape(3 * (hi - lo), 3 * n)


# --- a no-slip plane wall -----------------------------------------------------


class Wall:
    """A no-slip plane through ``point`` with unit ``normal`` towards the liquid.

    Its effect is the image system of a Stokeslet above a plane (Blake 1971): in
    the wall's frame (wall z = 0, liquid z > 0), a force F at height h gives at x
    the image velocity

        W F = −S(R) F + 2h Σ_j D_jj F_j ∂Φ/∂R_j,   Φ(R) = h R/R³ − e₃/R − R R₃/R³,

    with R = x − y*, y* the source mirrored in the plane, D = diag(1, 1, −1) and
    S the (singular) Stokeslet.  The free part stays regularized; the images lie
    at least twice the body's height above the wall away from every target, so
    they are used unregularized: the velocity on the wall is then zero up to the
    difference between the regularized and the singular free part, a Gaussian
    tail e^(−(h/δ)²) of the body's height in blobs (docs/stokes.md)."""

    def __init__(self, point: Sequence[float] | np.ndarray, normal: Sequence[float] | np.ndarray):
        n = np.asarray(normal, dtype=float)
        n = n / np.linalg.norm(n)
        helper = np.eye(3)[int(np.argmin(np.abs(n)))]
        e1 = np.cross(n, helper)
        e1 /= np.linalg.norm(e1)
        #: rows: the wall's frame (two tangents, the normal)
        self.Q = np.array([e1, np.cross(n, e1), n])
        self.point = np.asarray(point, dtype=float)

    def heights(self, x: np.ndarray) -> np.ndarray:
        """Heights of the points ``x`` (N, 3) above the wall (negative: behind it)."""
        return (np.asarray(x, dtype=float) - self.point) @ self.Q[2]

    def _local(self, x):
        return (x - self.point) @ self.Q.T

    def _images(self, targets, sources) -> np.ndarray:
        """Per target the images' blocks of every source (N_t, 3, N_s, 3), global axes,
        without 1/8πμ."""
        k = _kernels()
        n = len(sources)
        W = np.zeros((len(targets), 3, n, 3))
        k.far_matrix(
            k.to_frame(self.Q, self.point, targets),
            k.to_frame(self.Q, self.point, sources),
            np.ones((n, 1)),
            np.arange(n)[:, None],
            0.0,
            False,
            True,
            W,
        )
        return k.from_frame(self.Q, W)

    def image_velocity(
        self, targets: np.ndarray, sources: np.ndarray, forces: np.ndarray
    ) -> np.ndarray:
        """``Σ_j W(x_i, y_j) F_j`` (without 1/8πμ) at every target, (N_t, 3)."""
        W = self._images(targets, sources)
        return (W.reshape(3 * len(W), -1) @ np.ravel(forces)).reshape(-1, 3)

    def mobility(self, x: np.ndarray, viscosity: float, rows: slice | None = None) -> np.ndarray:
        """The images' part of the dense mobility (3N × 3N, or the rows of ``rows``)."""
        x = np.asarray(x, dtype=float)
        n = len(x)
        lo, hi = _bounds(rows, n)
        return self._images(x[lo:hi], x).reshape(3 * (hi - lo), 3 * n) / (8 * pi * viscosity)

    def position_derivative(
        self, x: np.ndarray, viscosity: float, forces: np.ndarray, rows: slice | None = None
    ) -> np.ndarray:
        """The images' part of ``G = ∂u/∂x`` at fixed forces (or its rows of ``rows``),
        in closed form (``rftfem.model.stokes_kernels.image_gradient``)."""
        k = _kernels()
        x = k.to_frame(self.Q, self.point, x)
        F = k.to_frame(self.Q, None, np.reshape(forces, (-1, 3)))
        n = len(x)
        lo, hi = _bounds(rows, n)
        G = np.zeros((hi - lo, 3, n, 3))
        k.far_derivative(
            x[lo:hi],
            np.arange(lo, hi),
            x,
            np.ones((n, 1)),
            np.arange(n)[:, None],
            F,
            0.0,
            False,
            True,
            G,
        )
        G = k.from_frame(self.Q, G)
        return G.reshape(3 * (hi - lo), 3 * n) / (8 * pi * viscosity)


def _kernels():
    """The compiled kernels (imported when first used: numba compiles or loads them)."""
    from rftfem.model import stokes_kernels

    return stokes_kernels


def _chunks(n: int, pairs: int = 250_000, total: int | None = None):
    """Slices of ``n`` rows of about ``pairs`` node pairs each (bounded temporary
    memory), each row pairing with ``total`` nodes (default ``n``)."""
    step = max(1, pairs // max(total or n, 1))
    return [slice(i, min(i + step, n)) for i in range(0, n, step)]


class Resistance:
    """The factorised mobility of one configuration: forces from velocities.

    Cholesky of the symmetric positive definite ``M`` (LU if round-off breaks it);
    with a ``wall``, ``M`` includes its images.  Under MPI (``comm`` of more than
    one process) each process evaluates the kernel on its ``rows`` (a slice of
    target nodes, the slices in rank order covering all) and the processes
    factorise together (``rftfem.model.dense_factors``); the position derivative
    stays distributed by rows."""

    def __init__(
        self,
        x: np.ndarray,
        delta: np.ndarray,
        viscosity: float,
        wall: Wall | None = None,
        comm: MPI.Comm | None = None,
        rows: slice | None = None,
    ):
        from rftfem.model import dense_factors

        self.x = np.array(x, dtype=float)
        self.delta, self.viscosity, self.wall = delta, viscosity, wall
        parallel = comm is not None and comm.size > 1
        self.comm = comm if parallel else None
        self.rows = rows if parallel else None
        self._factors = dense_factors.factorise(
            self._matrix(), self.comm, symmetric=True, remake=self._matrix
        )

    def _matrix(self) -> np.ndarray:
        """This process's rows of ``M`` (all of them on one process), compiled."""
        from rftfem.model import stokes_rows

        M = stokes_rows.mobility_rows(self.x, self.delta, self.viscosity, self.rows)
        if self.wall is not None:
            M += self.wall.mobility(self.x, self.viscosity, self.rows)
        return M

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """``M⁻¹ rhs`` (``rhs`` of length 3N, or 3N × k)."""
        return self._factors.solve(rhs)

    def lumped(self) -> np.ndarray:
        """The nodal blocks ``Σ_j (M⁻¹)_ij`` (N × 3 × 3, symmetrised, eigenvalues
        clipped at 0): the force each node feels when the whole body translates,
        the local drag that preconditions the coupled tangent."""
        n = len(self.x)
        ones = np.tile(np.eye(3), (n, 1))
        return lumped_blocks(self.solve(ones).reshape(n, 3, 3))

    def position_operator(self, forces: np.ndarray) -> np.ndarray | RowBlocks:
        """``G = ∂(M F)/∂x`` at the fixed ``forces`` (dense, the images' part included;
        under MPI an operator holding this process's rows)."""
        from rftfem.model import stokes_rows

        G = stokes_rows.derivative_rows(self.x, self.delta, self.viscosity, forces, self.rows)
        if self.wall is not None:
            G += self.wall.position_derivative(self.x, self.viscosity, forces, self.rows)
        return G if self.comm is None else RowBlocks(G, self.comm)


class RowBlocks:
    """A matrix distributed by rows in rank order: ``A @ v`` gathers the rows' products."""

    def __init__(self, local: np.ndarray, comm: MPI.Comm):
        self.local, self.comm = local, comm

    def __matmul__(self, v):
        return gather_rows(self.local @ v, self.comm)


def lumped_blocks(blocks: np.ndarray) -> np.ndarray:
    """Nodal 3 × 3 ``blocks`` symmetrised, their eigenvalues clipped at 0."""
    blocks = 0.5 * (blocks + blocks.transpose(0, 2, 1))
    w, v = np.linalg.eigh(blocks)
    return np.einsum("nij,nj,nkj->nik", v, np.clip(w, 0.0, None), v)
