"""The integrated layer's resistance of one configuration (``rftfem.model.stokes_layer``,
docs/stokes.md §Cost): nodal loads from velocities, on its own LU factors or on an
earlier configuration's, by GMRES.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp

from rftfem.model import dense_factors, stokeslets
from rftfem.model.ranks import gather_rows

if TYPE_CHECKING:
    from mpi4py import MPI

    from rftfem.model.stokes_layer import Layer


#: GMRES on kept factors (docs/stokes.md §Cost): the relative residual a solve reaches,
#: and the most iterations before the configuration is factorised itself
KEPT_RTOL, KEPT_MOST = 1e-13, 20


class LayerResistance:
    """The layer of one configuration: nodal loads from velocities,
    ``F = Iᵀ B A⁻¹ I v`` (the same contract as ``stokeslets.Resistance``, plus
    :meth:`tangent`), ``I`` the force grid's interpolation (``layer_rules.refined``).

    ``A`` is not symmetric (collocation), so it is LU-factorised.  Under MPI each
    process evaluates its ``layer.rows`` and the processes factorise together
    (ScaLAPACK, ``rftfem.model.dense_factors``); GMRES on kept factors multiplies by
    the rows where they are (only vectors are gathered); the position derivative
    stays distributed.

    ``kept``, an earlier configuration's resistance: its factors are kept instead of
    new ones.  ``A f = v`` is then solved by GMRES on this ``A``, preconditioned by
    them, to ``KEPT_RTOL`` (the loads are this configuration's to that tolerance),
    and :meth:`tangent` applies the kept factors and the kept derivative (a
    tangent of the earlier configuration, which the Stokes effect refreshes when
    GMRES slows: ``iterations``)."""

    def __init__(
        self,
        layer: Layer,
        x: np.ndarray,
        viscosity: float,
        wall: stokeslets.Wall | None = None,
        comm: MPI.Comm | None = None,
        interpolation: sp.csr_matrix | None = None,
        kept: "LayerResistance | None" = None,
    ):
        self.x = np.array(x, dtype=float)
        self.layer, self.viscosity, self.wall = layer, viscosity, wall
        self.I = (
            interpolation if interpolation is not None else sp.identity(len(self.x), format="csr")
        )
        #: the force grid's positions
        self.grid = self.I @ self.x
        self.comm = comm if comm is not None and comm.size > 1 else None
        #: this process's rows of ``A`` (all of them on one process), until factorised
        self.A = layer.matrix(self.grid, viscosity, wall)
        #: the resistance whose factors this one solves with (itself once factorised)
        self.factored = None
        #: GMRES iterations of the last solve on kept factors (0: solved directly)
        self.iterations = 0
        if kept is None:
            self.factorise()
        else:
            self._factors, self.factored = kept._factors, kept.factored
        self._mass = layer.mass_factors()[0]
        self._solved = []  # (loads, densities) of the last solves, for the derivative

    @property
    def fresh(self) -> bool:
        """Whether this configuration has its own factors."""
        return self.factored is self

    def factorise(self) -> None:
        """Factorise this configuration's ``A`` (LU; under MPI the processes together,
        ``rftfem.model.dense_factors``), then drop it: the factors replace it."""
        self._factors = dense_factors.factorise(self.A, self.comm)
        self.A, self.factored, self.iterations = None, self, 0

    def _to_grid(self, v: np.ndarray) -> np.ndarray:
        n = len(self.x)
        return (self.I @ v.reshape(n, -1)).reshape((-1,) + v.shape[1:])

    def _to_shell(self, F: np.ndarray) -> np.ndarray:
        g = len(self.grid)
        return (self.I.T @ F.reshape(g, -1)).reshape((-1,) + F.shape[1:])

    def densities(self, rhs: np.ndarray, exact: bool = True) -> np.ndarray:
        """``A⁻¹ rhs`` for grid velocities: the density's values at the grid nodes (with
        ``exact`` False and kept factors: theirs, an approximation)."""
        if self.fresh or not exact:
            return self._factors.solve(rhs)
        columns = rhs.reshape(len(rhs), -1)
        out = np.empty_like(columns)
        for k in range(columns.shape[1]):
            out[:, k], its = _gmres(
                self._product,
                columns[:, k],
                self._factors.solve,
                KEPT_RTOL,
                KEPT_MOST,
            )
            if out[:, k][0] != out[:, k][0]:  # (NaN: not converged) factorise, solve
                self.factorise()
                return self.densities(rhs)
            self.iterations = max(self.iterations if k else 0, its)
        return out.reshape(rhs.shape)

    def _product(self, z: np.ndarray) -> np.ndarray:
        """``A z``: each process its rows, gathered (every process the same vector)."""
        return gather_rows(self.A @ z, self.comm)

    def _loads(self, f: np.ndarray) -> np.ndarray:
        g = len(self.grid)
        return (self._mass @ f.reshape(g, -1)).reshape(f.shape)

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """``Iᵀ B A⁻¹ I rhs``: the shell's nodal loads for nodal velocities (3N, or 3N × k)."""
        f = self.densities(self._to_grid(np.asarray(rhs, dtype=float)))
        F = self._to_shell(self._loads(f))
        if F.ndim == 1:
            self._solved = [(F, f)] + self._solved[:3]
        return F

    def lumped(self) -> np.ndarray:
        """The nodal blocks ``Σ_j R_ij`` of the resistance (N × 3 × 3, symmetrised,
        clipped at 0)."""
        n = len(self.x)
        ones = self._to_grid(np.tile(np.eye(3), (n, 1)))
        F = self._to_shell(self._loads(self.densities(ones, exact=False)))
        return stokeslets.lumped_blocks(F.reshape(n, 3, 3))

    def position_operator(self, forces: np.ndarray) -> np.ndarray | stokeslets.RowBlocks:
        """``G = ∂(A f)/∂x_grid`` at the density ``f`` whose loads are ``forces`` (the
        result of a :meth:`solve`)."""
        forces = np.asarray(forces, dtype=float).ravel()
        for F, f in self._solved:
            if F.shape == forces.shape and np.array_equal(F, forces):
                break
        else:
            raise RuntimeError("the layer's derivative is taken at loads it did not solve for")
        G = self.layer.position_derivative(self.grid, f.reshape(-1, 3), self.viscosity, self.wall)
        return G if self.comm is None else stokeslets.RowBlocks(G, self.comm)

    def tangent(
        self, du: np.ndarray, cv: float, G: np.ndarray | stokeslets.RowBlocks
    ) -> np.ndarray:
        """``dF = Iᵀ B A⁻¹ (c_v I du − G I du)``: the loads' change for a displacement
        change ``du`` (velocities ``c_v du``), ``G`` from :meth:`position_operator`."""
        dg = self._to_grid(np.asarray(du, dtype=float))
        return self._to_shell(self._loads(self.densities(cv * dg - G @ dg, exact=False)))


def _gmres(product, b, precondition, rtol: float, most: int):
    """``A x = b`` by GMRES (``product(z) = A z``), right-preconditioned (``A M y = b``,
    ``x = M y``), from 0:
    ``(x, iterations)``, x NaN if ``rtol`` is not reached in ``most`` iterations."""
    beta = float(np.linalg.norm(b))
    if beta == 0.0:
        return np.zeros_like(b), 0
    V = np.empty((most + 1, len(b)))
    H = np.zeros((most + 1, most))
    V[0] = b / beta
    for j in range(most):
        w = product(precondition(V[j]))
        for i in range(j + 1):  # modified Gram-Schmidt
            H[i, j] = V[i] @ w
            w -= H[i, j] * V[i]
        H[j + 1, j] = np.linalg.norm(w)
        e1 = np.zeros(j + 2)
        e1[0] = beta
        y = np.linalg.lstsq(H[: j + 2, : j + 1], e1, rcond=None)[0]
        left = np.linalg.norm(e1 - H[: j + 2, : j + 1] @ y)
        if left <= rtol * beta or H[j + 1, j] == 0.0:
            return precondition(V[: j + 1].T @ y), j + 1
        V[j + 1] = w / H[j + 1, j]
    return np.full_like(b, np.nan), most
