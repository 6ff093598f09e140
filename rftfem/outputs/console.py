"""What the command line prints: on rank 0 only, and one exit status for every rank."""

from __future__ import annotations

import os
import sys
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from mpi4py import MPI

# Environment variables set by the common MPI launchers (Open MPI, MPICH/Hydra, PMIx, Slurm).
_MPI_ENV = ("OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK", "PMI_RANK", "MPI_LOCALNRANKS")


def mpi_comm() -> MPI.Comm | None:
    """COMM_WORLD if this process runs under an MPI launcher (or mpi4py is loaded)."""
    if "mpi4py.MPI" not in sys.modules and not any(v in os.environ for v in _MPI_ENV):
        return None
    try:
        from mpi4py import MPI
    except ImportError:
        return None
    return MPI.COMM_WORLD


class Console:
    """Prints on rank 0 only."""

    def __init__(self) -> None:
        self.comm = mpi_comm()

    def refresh(self) -> None:
        if self.comm is None:
            self.comm = mpi_comm()

    @property
    def rank(self) -> int:
        return 0 if self.comm is None else self.comm.rank

    def out(self, text: str) -> None:
        if self.rank == 0:
            print(text, flush=True)

    def err(self, text: str) -> None:
        if self.rank == 0:
            print(" ".join(text.split()), file=sys.stderr, flush=True)

    def agree(self, status: int) -> int:
        """The same exit status on every rank (the largest)."""
        if self.comm is None or self.comm.size == 1:
            return status
        from mpi4py import MPI

        return int(self.comm.allreduce(status, op=MPI.MAX))
