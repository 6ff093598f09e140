"""A slow step made visible and stoppable (docs/scenes.md, "Interrupts").

A step of a large Stokes body can take minutes: a dense factorisation, many
Krylov iterations.  The solver calls :meth:`StepWatch.newton` after each Newton
update and :meth:`StepWatch.krylov` after each Krylov iteration; once a step has
run ``SLOW_STEP`` seconds the watch

- prints a line at most every ``interval`` seconds (the progress's own): the
  step, its time, the Newton update, the Krylov iteration and its residual;
- and, if a first SIGINT or SIGTERM has come, drops the step: it raises
  :class:`~rftfem.errors.RunInterrupted` (``dropped``), the model returns to the
  last completed step, which gets the last output row, and the run stops as it
  would between steps (exit 130 or 143; a restart continues from its last
  checkpoint).  A signal in a step shorter than that waits for the step's end.

Under MPI every rank reaches the same checks (the Krylov and Newton iterations
are collective), and they agree on the signal with one small allreduce, made
only once a step is slow.
"""

from __future__ import annotations

import os
import time as _time
from typing import TYPE_CHECKING

from rftfem.errors import RunInterrupted
from rftfem.integration.weak_callbacks import weak_method

if TYPE_CHECKING:
    from mpi4py import MPI

    from rftfem.integration.interrupts import NoStops, StopRequests
    from rftfem.integration.solver import StepSolver
    from rftfem.outputs.progress import Progress

#: seconds after which a step counts as slow: it reports and may be dropped
#: (``RFTFEM_SLOW_STEP`` sets another, e.g. 0 to drop any step a signal meets)
SLOW_STEP = 5.0


def slow_step() -> float:
    try:
        return float(os.environ.get("RFTFEM_SLOW_STEP", SLOW_STEP))
    except ValueError:
        return SLOW_STEP


class StepWatch:
    """The checks of one run's steps (``stops``: its StopRequests, ``progress``: its
    Progress or None)."""

    def __init__(
        self,
        stops: StopRequests | NoStops,
        comm: MPI.Comm,
        progress: Progress | None = None,
        slow: float | None = None,
    ):
        self.stops, self.comm, self.progress = stops, comm, progress
        self.slow = slow_step() if slow is None else slow
        self.started = None
        #: the RunInterrupted that dropped the last step (raised inside a PETSc
        #: callback, which PETSc reports as its own error: the solver raises this)
        self.dropped = None
        self.t, self.step = 0.0, 0
        self.newton_its, self.krylov_its, self.residual = 0, 0, float("nan")
        self.last_line = 0.0

    def attach(self, solver: StepSolver) -> None:
        """Watch ``solver`` (a StepSolver): its Newton test calls :meth:`newton`, and
        with a nonlocal tangent (Krylov iterations that may take long) a monitor
        calls :meth:`krylov`."""
        solver.watch = self
        if solver.coupled is not None:
            solver.snes.getKSP().setMonitor(weak_method(self._krylov_monitor))

    def start(self, t: float, step: int) -> None:
        """A step's attempt begins (toward time ``t``)."""
        self.started = _time.perf_counter()
        self.last_line = self.started
        self.dropped = None
        self.t, self.step = t, step
        self.newton_its, self.krylov_its, self.residual = 0, 0, float("nan")

    def newton(self, it: int, residual: float) -> None:
        self.newton_its, self.krylov_its, self.residual = it, 0, residual
        self._check()

    def _krylov_monitor(self, ksp, it: int, residual: float) -> None:
        self.krylov(it, residual)

    def krylov(self, it: int, residual: float) -> None:
        self.krylov_its = it
        self._check(residual)

    def _check(self, krylov_residual: float | None = None):
        if self.started is None:
            return
        now = _time.perf_counter()
        elapsed = now - self.started
        signum = self.stops.signum if elapsed >= self.slow else 0
        if self.comm.size > 1:  # every rank checks here: they agree on one answer
            from mpi4py import MPI

            signum = int(self.comm.allreduce(signum, op=MPI.MAX))
        if signum:
            self.started = None
            self.dropped = RunInterrupted(signum, dropped=True)
            raise self.dropped
        if elapsed < self.slow:
            return
        progress = self.progress
        if progress is not None and now - self.last_line >= progress.interval:
            self.last_line = now
            krylov = (
                ""
                if krylov_residual is None
                else f", Krylov iteration {self.krylov_its} (residual {krylov_residual:.3e})"
            )
            progress.log(
                f"  step {self.step} towards t = {self.t:.6g}: {elapsed:.0f} s in, "
                f"Newton update {self.newton_its + 1} (residual {self.residual:.3e})"
                f"{krylov}"
            )
