"""Stopping a run cleanly on SIGINT and SIGTERM (docs/scenes.md, "Interrupts").

The first signal is a request: the run finishes the step it is in, writes a last
output row and its summary (``"status": "interrupted"``), closes every file and
exits with 128 + the signal's number (130 for Ctrl-C, 143 for SIGTERM).  The
ranks of an MPI run agree after every step (one small allreduce), so they stop
at the same step even when the signal reached only some of them.  A second
signal stops at once, inside the step: no last row, but the files are still
closed, so everything flushed before is valid.  Signals that arrive while the
run is closing its files are only recorded.

Handlers can be installed only from the main thread; elsewhere (a run started
from a worker thread) the process keeps the handlers it had.
"""

from __future__ import annotations

import signal
import threading
from typing import TYPE_CHECKING

from rftfem.errors import RunInterrupted

if TYPE_CHECKING:
    from mpi4py import MPI

SIGNALS = (signal.SIGINT, signal.SIGTERM)


class StopRequests:
    """Context manager that turns SIGINT and SIGTERM into stop requests."""

    def __init__(self, comm: MPI.Comm):
        self.comm = comm
        self.signum = 0
        self.immediate = False
        self._closing = False
        self._previous = {}

    def __enter__(self):
        if threading.current_thread() is threading.main_thread():
            for s in SIGNALS:
                self._previous[s] = signal.signal(s, self._handler)
        return self

    def __exit__(self, *exc):
        for s, handler in self._previous.items():
            signal.signal(s, handler)
        self._previous = {}
        return False

    def _handler(self, signum, frame):
        if self.signum and not self._closing:
            self.immediate = True
            raise RunInterrupted(self.signum, immediate=True)
        self.signum = self.signum or signum

    def closing(self) -> None:
        """The run is closing its files: later signals are recorded, not raised."""
        self._closing = True

    def requested(self) -> int:
        """The signal that any rank received (0: none).  Collective under MPI."""
        if self.comm.size == 1:
            return self.signum
        from mpi4py import MPI

        return int(self.comm.allreduce(self.signum, op=MPI.MAX))


class NoStops:
    """Stand-in when the run keeps the process's own handlers (the Python API)."""

    signum = 0
    immediate = False

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False

    def closing(self) -> None:
        pass

    def requested(self) -> int:
        return 0
