"""Dense factors of a matrix held by rows (``rftfem.model.dense_factors``): on one
process LAPACK's, under ``mpirun`` ScaLAPACK's through PETSc, the processes
factorising together.  Both solve to round-off of numpy's dense solve, Cholesky
falls back to LU when the matrix is not positive definite, and under ``mpirun``
the factors are distributed ones, not a gathered copy on every process."""

from __future__ import annotations

import sys
import textwrap

import numpy as np
import pytest
from conftest import ROOT, run_command

from rftfem.model import dense_factors

#: a matrix made alike on every process: symmetric positive definite (``spd``),
#: symmetric indefinite (Cholesky breaks) or not symmetric; with its solution of ones
MATRICES = """
import numpy as np

def matrix(kind, n=301):
    g = np.random.default_rng(7)
    B = g.standard_normal((n, n))
    if kind == "spd":
        return B @ B.T / n + 0.5 * np.eye(n)
    if kind == "indefinite":
        return B + B.T
    return B + n ** 0.5 * np.eye(n)
"""

SCRIPT = """
import sys
try:
    import dolfinx_solver  # noqa: F401  (the current stack: before petsc4py)
except ImportError:
    pass
import numpy as np
from mpi4py import MPI
from rftfem.model import dense_factors
from matrices import matrix

comm = MPI.COMM_WORLD
dense_factors.SHARED_FROM_ROWS = 0  # (a small matrix: shared all the same)
for kind, symmetric in (("spd", True), ("indefinite", True), ("general", False)):
    A = matrix(kind)
    n = len(A)
    # rows shared unevenly (a third to the first process): ScaLAPACK's vectors are laid
    # out otherwise, in even blocks
    counts = [n // 3] + [(n - n // 3) // (comm.size - 1)] * (comm.size - 1)
    counts[-1] += n - sum(counts)
    lo = sum(counts[: comm.rank])
    rows = A[lo : lo + counts[comm.rank]].copy()
    f = dense_factors.factorise(rows, comm, symmetric=symmetric, remake=lambda: rows.copy())
    rhs = A @ np.ones(n)
    x = f.solve(rhs)
    X = f.solve(np.column_stack([rhs, 2 * rhs]))
    same = comm.allgather(x)
    error = max(np.abs(x - 1).max(), np.abs(X[:, 1] - 2).max())
    spread = max(np.abs(s - x).max() for s in same)
    if comm.rank == 0:
        print(kind, f.kind, type(f).__name__, f"{error:.3e}", f"{spread:.3e}", flush=True)
"""


def _check(lines):
    got = {line.split()[0]: line.split()[1:] for line in lines}
    assert set(got) == {"spd", "indefinite", "general"}, lines
    assert got["spd"][0] == "cholesky" and got["indefinite"][0] == "lu", got
    assert got["general"][0] == "lu", got
    for kind, (_, _, error, spread) in got.items():
        assert float(error) < 5e-12, (kind, error)  # reached 3.8e-13 (the indefinite one)
        assert float(spread) == 0.0, (kind, spread)  # every process the same solution
    return {kind: v[1] for kind, v in got.items()}


def test_one_process_matches_numpy(tmp_path):
    """LAPACK's factors: Cholesky for the positive definite matrix, LU when Cholesky
    breaks (the indefinite one, made again by ``remake``) and for the general one."""
    scope: dict = {}
    exec(MATRICES, scope)
    for kind, symmetric in (("spd", True), ("indefinite", True), ("general", False)):
        A = scope["matrix"](kind)
        f = dense_factors.factorise(A.copy(), symmetric=symmetric, remake=lambda A=A: A.copy())
        assert f.kind == ("cholesky" if kind == "spd" else "lu")
        x = f.solve(A @ np.ones(len(A)))
        assert np.abs(x - 1).max() < 5e-12, kind
    with pytest.raises(np.linalg.LinAlgError):  # no way back to LU without remake
        dense_factors.factorise(scope["matrix"]("indefinite"), symmetric=True)


@pytest.mark.mpi
def test_two_processes_factorise_together(tmp_path, mpirun):
    """Under ``mpirun -n 2`` each process holds some of the rows (a third and two
    thirds, not ScaLAPACK's vectors' layout): the factors are
    ScaLAPACK's (``ScalapackFactors``), each process's solution is the same and within
    5e-12 of the exact one (reached 3.8e-13).  Broke: the right-hand side's slice taken
    from the first rows on every process → errors of order 1; the rows' layout taken for
    the vectors' → a failed run."""
    (tmp_path / "matrices.py").write_text(MATRICES)
    (tmp_path / "script.py").write_text(textwrap.dedent(SCRIPT))
    exe, env = mpirun
    env = dict(env, PYTHONPATH=f"{tmp_path}:{ROOT}")
    done = run_command(
        [exe, "-n", "2", sys.executable, str(tmp_path / "script.py")], env=env, cwd=tmp_path
    )
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    kinds = _check(done.stdout.split("\n")[:-1])
    from rftfem import compat

    expected = "ScalapackFactors" if compat.has_scalapack() else "LapackFactors"
    assert set(kinds.values()) == {expected}, kinds
