"""Factors of a dense matrix whose rows are shared out by process (docs/stokes.md §Cost
and scale): the Stokes operators' mobilities and the integrated layer's matrix.

On one process the factors are LAPACK's (scipy): Cholesky for a symmetric positive
definite matrix, LU otherwise or when round-off breaks Cholesky.  Under ``mpirun``
they are ScaLAPACK's, through PETSc: each process hands over the rows it evaluated,
PETSc lays them out block-cyclically, and the processes factorise together, so a
factorisation of a 9000 × 9000 matrix takes about half as long on two processes
(instead of every process repeating the whole one).  A PETSc built without
ScaLAPACK falls back to gathering the rows and factorising the whole matrix on
every process, as before.

A solve is collective under ``mpirun``: every process calls it with the same
right-hand side and gets the same solution.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import scipy.linalg as sl

from rftfem.model.ranks import gather_rows

if TYPE_CHECKING:
    from collections.abc import Callable

    from mpi4py import MPI


def factorise(
    rows: np.ndarray,
    comm: MPI.Comm | None = None,
    symmetric: bool = False,
    remake: Callable[[], np.ndarray] | None = None,
) -> LapackFactors | ScalapackFactors:
    """Factors of the square matrix whose rows ``rows`` this process holds (every
    process's rows in rank order make the matrix; all of it on one process); the
    rows may be overwritten.  ``symmetric``: the matrix is symmetric positive
    definite (Cholesky); if round-off breaks Cholesky, LU of ``remake()``'s rows
    (the same rows made again)."""
    if comm is None or comm.size == 1:
        return LapackFactors(rows, symmetric, remake)
    if not shared(comm.size, rows.shape[1]):
        whole = None if remake is None else lambda: gather_rows(remake(), comm)
        return LapackFactors(gather_rows(rows, comm), symmetric, whole)
    return ScalapackFactors(rows, comm, symmetric)


#: matrices of fewer rows are factorised whole on every process: on two processes
#: ScaLAPACK's LU of 600 rows took 0.010 s against LAPACK's 0.006 s, of 3000 rows
#: 0.31 s (with the conversion) against 0.42 s
SHARED_FROM_ROWS = 3000


def shared(processes: int, rows: int) -> bool:
    """Whether ``processes`` processes factorise a matrix of ``rows`` rows together
    (ScaLAPACK)."""
    from rftfem import compat

    return processes > 1 and rows >= SHARED_FROM_ROWS and compat.has_scalapack()


class LapackFactors:
    """The whole matrix's Cholesky or LU factors on this process."""

    distributed = False

    def __init__(
        self,
        matrix: np.ndarray,
        symmetric: bool,
        remake: Callable[[], np.ndarray] | None = None,
    ):
        self.kind = "lu"
        if symmetric:
            try:
                self._factors = sl.cho_factor(
                    matrix, lower=True, overwrite_a=True, check_finite=False
                )
                self.kind = "cholesky"
                return
            except np.linalg.LinAlgError:
                if remake is None:
                    raise
                matrix = remake()  # (Cholesky may have overwritten part of it)
        self._factors = sl.lu_factor(matrix, overwrite_a=True, check_finite=False)

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """``A⁻¹ rhs`` for ``rhs`` of length n or n × k."""
        if self.kind == "cholesky":
            return sl.cho_solve(self._factors, rhs, check_finite=False)
        return sl.lu_solve(self._factors, rhs, check_finite=False)


class ScalapackFactors:
    """ScaLAPACK's factors of a matrix held by rows on the processes of ``comm``."""

    distributed = True

    def __init__(self, rows: np.ndarray, comm: MPI.Comm, symmetric: bool):
        from petsc4py import PETSc

        self.comm = comm
        n = rows.shape[1]
        counts = comm.allgather(rows.shape[0])
        if sum(counts) != n:
            raise ValueError(f"dense factors: the rows make {sum(counts)} × {n}, not square")
        # PETSc's own even rows: its conversion to ScaLAPACK's block-cyclic layout is
        # 3 to 5 times faster from them than from any other split (measured at 9075)
        rows = _even_rows(rows, counts, comm)
        pcomm = PETSc.Comm(comm)
        self.kind = "cholesky" if symmetric else "lu"
        try:
            self._mat = self._factored(rows, pcomm, symmetric)
        except PETSc.Error:
            if not symmetric:
                raise
            self.kind = "lu"  # round-off broke Cholesky (on every process alike)
            self._mat = self._factored(rows, pcomm, False)
        # ScaLAPACK's vectors have their own layout (even blocks, not the rows')
        self._x, self._b = self._mat.createVecs()
        self._b_range = self._b.getOwnershipRange()
        self._x_counts = np.diff(self._x.getOwnershipRanges())

    def _factored(self, rows, pcomm, symmetric):
        from petsc4py import PETSc

        m, n = rows.shape
        dense = PETSc.Mat().createDense(((m, n), (m, n)), comm=pcomm)
        dense.setUp()
        dense.getDenseArray()[:] = rows
        dense.assemble()
        mat = dense.convert("scalapack", out=PETSc.Mat())
        dense.destroy()
        order, _ = mat.getOrdering("natural")
        if symmetric:
            mat.factorCholesky(order)
        else:
            mat.factorLU(order, order)
        return mat

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """``A⁻¹ rhs`` for ``rhs`` of length n or n × k (the same on every process),
        the solution on every process."""
        rhs = np.asarray(rhs, dtype=float)
        if rhs.ndim == 2:
            return np.column_stack([self.solve(col) for col in rhs.T])
        lo, hi = self._b_range
        self._b.getArray()[:] = rhs[lo:hi]
        self._mat.solve(self._b, self._x)
        out = np.empty(len(rhs))
        self.comm.Allgatherv(self._x.getArray(readonly=True), [out, self._x_counts])
        return out


def _even_rows(rows: np.ndarray, counts: list[int], comm: MPI.Comm) -> np.ndarray:
    """The matrix whose rows are shared out as ``counts`` (this process's ``rows``)
    shared out evenly instead, the first ``n mod size`` processes one row more."""
    n, size = sum(counts), comm.size
    even = [n // size + (r < n % size) for r in range(size)]
    if even == counts:
        return rows
    start = np.concatenate([[0], np.cumsum(counts)])
    target = np.concatenate([[0], np.cumsum(even)])
    me = comm.rank

    def overlap(a, b):  # rows of process a's share now that process b gets
        return max(0, min(start[a + 1], target[b + 1]) - max(start[a], target[b]))

    width = rows.shape[1]
    sent = [overlap(me, r) * width for r in range(size)]
    received = [overlap(r, me) * width for r in range(size)]
    out = np.empty((even[me], width))
    comm.Alltoallv([np.ascontiguousarray(rows, dtype=float), sent], [out, received])
    return out
