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

A body of up to ``WHOLE_UP_TO`` nodes is one cluster: the preconditioner is then
the exact inverse of its mobility, and like the integrated layer's factors
(``rftfem.model.stokes_layer``) it can be kept for later configurations
(``kept``): the conjugate gradients on the current mobility converge in a few
iterations on an earlier one's factors, and the Newton tangent applies those
factors (an earlier configuration's tangent), until the Stokes effect asks for new
ones (``iterations`` over its limit, or an exact tangent).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from rftfem.model import dense_factors, stokeslets

if TYPE_CHECKING:
    from collections.abc import Callable

    from rftfem.model.stokes_direct import DirectSums, _Derivative
    from rftfem.model.stokes_fmm import FmmSums, PositionDerivative

#: the relative residual at which the conjugate gradients of the forces stop
SOLVE_TOLERANCE = 1e-11
#: the same for a product of the Newton tangent (inside GMRES): an update a little
#: less exact leaves Newton's convergence as fast in the few iterations a step takes
#: (an error η of the update adds η times the error to the next iterate's) and
#: halves the iterations of each product (docs/stokes.md §Cost and scale)
TANGENT_TOLERANCE = 1e-8
#: nodes per cluster of the block-Jacobi preconditioner
CLUSTER_NODES = 600
#: bodies of up to this many nodes are one cluster, their whole mobility factorised
#: (2.6 GB at 6000 nodes; about 20 s at 5000 on the project's 2-core machine)
WHOLE_UP_TO = 6000


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
    cluster alone (with the wall's images if the liquid has one; of the whole body,
    this process's rows of it under the ``sums``' ``comm``)."""

    def __init__(
        self,
        x: np.ndarray,
        sums: DirectSums | FmmSums,
        cluster_mobility: Callable[[np.ndarray], np.ndarray],
        kept: "MatrixFreeResistance | None" = None,
    ):
        self.x = np.array(x, dtype=float)
        self.n = len(self.x)
        self.sums = sums
        self._cluster_mobility = cluster_mobility
        #: one cluster: the whole mobility factorised (factors that may be kept)
        self.whole = self.n <= WHOLE_UP_TO
        #: whether :meth:`tangent` must be this configuration's: on an earlier one's
        #: factors its first product is conjugate gradients (a lifting needs one),
        #: a second makes this configuration's factors (a Newton solve needs many)
        self.exact_tangent = False
        self._exact_products = 0
        #: conjugate-gradient iterations of every solve so far
        self.history: list[int] = []
        #: those of the last solve of a residual (the forces from velocities)
        self.iterations = 0
        #: how far the last forces may be off: ‖M⁻¹ r‖ for the residual r CG stopped at
        self.force_error = 0.0
        self._lumped = None
        if kept is None or not self.whole:
            self.factorise()
        else:
            self.clusters, self._factors, self.factored = (
                kept.clusters,
                kept._factors,
                kept.factored,
            )

    @property
    def fresh(self) -> bool:
        """Whether the preconditioner is this configuration's own."""
        return self.factored is self

    def factorise(self) -> None:
        """The clusters' Cholesky factors at this configuration (one cluster: the
        whole mobility's, by the processes together under MPI)."""
        self.clusters = [np.arange(self.n)] if self.whole else clusters(self.x, CLUSTER_NODES)
        comm = getattr(self.sums, "comm", None) if self.whole else None
        self._factors = [
            dense_factors.factorise(
                self._cluster_mobility(c),
                comm,
                symmetric=True,
                remake=lambda c=c: self._cluster_mobility(c),
            )
            for c in self.clusters
        ]
        self.factored, self._lumped, self._exact_products = self, None, 0

    def apply(self, forces: np.ndarray) -> np.ndarray:
        """``M F`` for forces of length 3N."""
        return self.sums.mobility(np.asarray(forces, dtype=float))

    def _precondition(self, v):
        v = np.reshape(v, (-1, 3))
        out = np.empty_like(v)
        for c, f in zip(self.clusters, self._factors):
            out[c] = f.solve(v[c].ravel()).reshape(-1, 3)
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
        out = self._cg(rhs, guess, SOLVE_TOLERANCE if tolerance is None else tolerance)
        if tolerance is None:
            self.iterations, self.force_error = self.history[-1], self._error
        return out

    def _cg(self, b, guess, tolerance):
        """Conjugate gradients with the cluster preconditioner, to ``tolerance``."""
        norm_b = float(np.linalg.norm(b))
        if norm_b == 0.0:
            self.history.append(0)
            self._error = 0.0
            return np.zeros_like(b)
        x = self._precondition(b) if guess is None else np.array(guess, dtype=float).ravel()
        r = b - self.apply(x)
        z = self._precondition(r)
        p = z.copy()
        rz = float(r @ z)
        for k in range(1, 3 * self.n + 1):
            if np.linalg.norm(r) <= tolerance * norm_b:
                self.history.append(k - 1)
                self._error = float(np.linalg.norm(z))  # M⁻¹ r, as the preconditioner sees it
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
        """The nodal blocks ``Σ_j (M⁻¹)_ij`` (as ``stokeslets.Resistance.lumped``; with
        one cluster those of the factored configuration)."""
        if self.whole and not self.fresh:
            return self.factored.lumped()
        if self._lumped is None:
            ones = np.tile(np.eye(3), (self.n, 1))
            if self.whole:
                inverse = np.column_stack([self._precondition(c) for c in ones.T])
            else:
                inverse = self.solve(ones)
            self._lumped = stokeslets.lumped_blocks(inverse.reshape(self.n, 3, 3))
        return self._lumped

    def position_operator(self, forces: np.ndarray) -> _Derivative | PositionDerivative:
        """``dx ↦ G dx = ∂(M F)/∂x · dx`` at the fixed ``forces``."""
        return self.sums.derivative_operator(np.asarray(forces, dtype=float))

    def tangent(self, du: np.ndarray, cv: float, G: _Derivative | PositionDerivative) -> np.ndarray:
        """``dF = M⁻¹ (c_v du − G du)``: with one cluster by the factored configuration's
        factors (exact when fresh; unless ``exact_tangent`` asks for this one's),
        else by conjugate gradients to ``TANGENT_TOLERANCE``."""
        w = cv * np.asarray(du, dtype=float) - G @ du
        if self.whole and not self.fresh and self.exact_tangent:
            if self._exact_products:  # a second product: this configuration's factors
                self.factorise()
            self._exact_products += 1
        if self.whole and (self.fresh or not self.exact_tangent):
            return self._precondition(w)
        return self.solve(w, tolerance=TANGENT_TOLERANCE)
