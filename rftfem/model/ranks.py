"""Arrays shared out by process: the one way rftfem puts every process's rows together."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from mpi4py import MPI


def gather_rows(local: np.ndarray, comm: MPI.Comm | None) -> np.ndarray:
    """Every process's rows of a float array stacked in rank order, on every process
    (``local`` itself on one process)."""
    if comm is None or comm.size == 1:
        return local
    counts = comm.allgather(local.shape[0])
    width = int(np.prod(local.shape[1:], dtype=int))
    out = np.empty((sum(counts),) + local.shape[1:])
    comm.Allgatherv(np.ascontiguousarray(local, dtype=float), [out, [c * width for c in counts]])
    return out
