"""Forces from velocities without a dense matrix: conjugate gradients on the blobs'
mobility, whose products ``M F`` and ``G dx`` come from a ``sums`` object (the
compiled direct sums of ``rftfem.model.stokes_direct`` or the fast multipoles of
``rftfem.model.stokes_fmm``; docs/stokes.md §Cost and scale).

``M`` is symmetric positive definite.  The preconditioner is the exact dense
inverse of ``M`` on spatial clusters of nodes (block Jacobi): the clusters resolve
the small scales that make a first-kind operator ill-conditioned, leaving the few
large eigenvalues of the body's long-range motion to the Krylov iteration.
A solve may start from a guess (the last residual's forces: the configuration
changes little between Newton iterations and steps) and stops at a relative
residual of ``SOLVE_TOLERANCE``.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sl

from rftfem.model import stokeslets

#: the relative residual at which the conjugate gradients of the forces stop
SOLVE_TOLERANCE = 1e-11
#: the same for a product of the Newton tangent (inside GMRES): an update a little
#: less exact leaves Newton's convergence as fast in the few iterations a step takes
#: (an error η of the update adds η times the error to the next iterate's) and
#: halves the iterations of each product (docs/stokes.md §Cost and scale)
TANGENT_TOLERANCE = 1e-8
#: nodes per cluster of the block-Jacobi preconditioner
CLUSTER_NODES = 600


def clusters(x: np.ndarray, size: int) -> list[np.ndarray]:
    """Node sets of at most ``size`` nodes by recursive bisection along the longest extent."""
    out, todo = [], [np.arange(len(x))]
    while todo:
        idx = todo.pop()
        if len(idx) <= size:
            out.append(idx)
            continue
        axis = int(np.argmax(np.ptp(x[idx], axis=0)))
        order = idx[np.argsort(x[idx, axis], kind="stable")]
        half = len(order) // 2
        todo += [order[:half], order[half:]]
    return out


class MatrixFreeResistance:
    """Forces from velocities at one configuration (the interface of
    ``stokeslets.Resistance``: ``x``, ``solve``, ``lumped``, ``position_operator``).

    ``sums`` gives ``mobility(F)`` (``M F``, 3N) and ``derivative_operator(F)`` (an
    operator ``dx ↦ G dx``); ``cluster_mobility(nodes)`` gives the dense mobility of a
    cluster alone (with the wall's images if the liquid has one)."""

    def __init__(self, x, sums, cluster_mobility):
        self.x = np.array(x, dtype=float)
        self.n = len(self.x)
        self.sums = sums
        self.clusters = clusters(self.x, CLUSTER_NODES)
        self._factors = [
            sl.cho_factor(cluster_mobility(c), lower=True, check_finite=False)
            for c in self.clusters
        ]
        #: conjugate-gradient iterations of every solve so far
        self.iterations: list[int] = []
        self._lumped = None

    def apply(self, forces: np.ndarray) -> np.ndarray:
        """``M F`` for forces of length 3N."""
        return self.sums.mobility(np.asarray(forces, dtype=float))

    def _precondition(self, v):
        v = np.reshape(v, (-1, 3))
        out = np.empty_like(v)
        for c, f in zip(self.clusters, self._factors):
            out[c] = sl.cho_solve(f, v[c].ravel(), check_finite=False).reshape(-1, 3)
        return out.ravel()

    def solve(
        self, rhs: np.ndarray, guess: np.ndarray | None = None, tolerance: float | None = None
    ) -> np.ndarray:
        """``M⁻¹ rhs`` (length 3N, or 3N × k column by column) by preconditioned CG,
        from ``guess`` if given (one column), to the relative residual ``tolerance``
        (``SOLVE_TOLERANCE``)."""
        rhs = np.asarray(rhs, dtype=float)
        if rhs.ndim == 2:
            return np.column_stack([self.solve(col, tolerance=tolerance) for col in rhs.T])
        return self._cg(rhs, guess, SOLVE_TOLERANCE if tolerance is None else tolerance)

    def _cg(self, b, guess, tolerance):
        """Conjugate gradients with the cluster preconditioner, to ``tolerance``."""
        norm_b = float(np.linalg.norm(b))
        if norm_b == 0.0:
            self.iterations.append(0)
            return np.zeros_like(b)
        x = self._precondition(b) if guess is None else np.array(guess, dtype=float).ravel()
        r = b - self.apply(x)
        z = self._precondition(r)
        p = z.copy()
        rz = float(r @ z)
        for k in range(1, 3 * self.n + 1):
            if np.linalg.norm(r) <= tolerance * norm_b:
                self.iterations.append(k - 1)
                return x
            q = self.apply(p)
            alpha = rz / float(p @ q)
            x += alpha * p
            r -= alpha * q
            z = self._precondition(r)
            rz, rz_old = float(r @ z), rz
            p = z + (rz / rz_old) * p
        raise RuntimeError("fluid: the Stokes solve did not converge")

    def lumped(self) -> np.ndarray:
        """The nodal blocks ``Σ_j (M⁻¹)_ij`` (as ``stokeslets.Resistance.lumped``)."""
        if self._lumped is None:
            ones = np.tile(np.eye(3), (self.n, 1))
            self._lumped = stokeslets.lumped_blocks(self.solve(ones).reshape(self.n, 3, 3))
        return self._lumped

    def position_operator(self, forces):
        """``dx ↦ G dx = ∂(M F)/∂x · dx`` at the fixed ``forces``."""
        return self.sums.derivative_operator(np.asarray(forces, dtype=float))
