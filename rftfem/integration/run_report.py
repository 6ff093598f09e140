"""What a run says: its opening lines and warnings, its summary, its interrupt, its last line."""

from __future__ import annotations

import time as _time
from typing import TYPE_CHECKING

from rftfem.errors import RunInterrupted
from rftfem.integration.step_watch import StepWatch
from rftfem.outputs.progress import Progress, render_in_child
from rftfem.outputs.writers import write_json
from rftfem.scene import scales

if TYPE_CHECKING:
    from collections.abc import Callable
    from pathlib import Path

    from mpi4py import MPI

    from rftfem.integration.arclength import PathFollowing
    from rftfem.integration.error_control import ErrorControl
    from rftfem.integration.interrupts import NoStops, StopRequests
    from rftfem.integration.restart import Checkpoints
    from rftfem.integration.run_outputs import RunOutputs
    from rftfem.integration.run_state import RunPosition
    from rftfem.integration.solver import StepSolver
    from rftfem.model.shell_model import Model


class RunReport:
    """The reports of :class:`~rftfem.integration.simulation.Simulation`: the progress
    line it opens, summary.json (also of a failed or interrupted run) and the last
    line; it reads the run's parts."""

    scene: dict
    comm: MPI.Comm
    quiet: bool
    warn: Callable[[str], object] | None
    stops: StopRequests | NoStops
    out_dir: Path | None
    model: Model
    solver: StepSolver
    pos: RunPosition
    path: PathFollowing | None
    errors: ErrorControl
    outputs: RunOutputs
    checkpoints: Checkpoints
    setup_time: float

    def _summary(self, status: str, wall_start: float | None = None) -> dict:
        """summary.json's content with ``status``, its total wall seconds from
        ``wall_start`` (none before the run) plus the set-up and earlier runs'."""
        total = (
            (_time.perf_counter() - wall_start if wall_start else 0.0)
            + self.setup_time
            + self.checkpoints.wall_before
        )
        return self.outputs.summary(
            status,
            self.pos,
            self.solver,
            at=self._loads_time(self.pos.t),
            restarts=self.checkpoints.restarts,
            time_error=self.errors.summary(),
            setup=self.setup_time,
            checkpoint=self.checkpoints.wall,
            total=total,
        )

    def _open_progress(self, path: bool) -> Progress:
        """The progress line, the watch of slow steps, the opening lines and warnings."""
        progress = Progress(
            self.scene["time"]["end"],
            self.comm,
            self.quiet,
            label="load factor" if path else "t",
            warn=self.warn,
        )
        StepWatch(self.stops, self.comm, progress).attach(self.solver)
        for line in self.outputs.opening_lines():
            progress.log(line)
        for line in scales.aliasing_warnings(self.scene) + [
            line for comp in self.model.components for line in comp.warnings()
        ]:
            progress.warn("warning: " + line)
        return progress

    def _interrupted(self, exc: BaseException, wall_start: float) -> tuple[RunInterrupted, dict]:
        """The interrupt (a signal; a second one may surface inside a PETSc callback as
        another error) and the summary of a run it stopped."""
        err = (
            exc
            if isinstance(exc, RunInterrupted)
            else RunInterrupted(self.stops.signum, immediate=True)
        )
        if err.time is None:  # stopped inside a step: where the last one ended
            err.time, err.step = self.pos.completed_time, self.pos.completed
            self.pos.t = err.time  # what the outputs reached (the state may be further)
        if err.dropped:  # a slow step dropped: the last completed step's row
            self._last_row()
        summary = self._summary("interrupted", wall_start)
        summary["interrupt"] = {
            "signal": err.signal_name,
            "time": err.time,
            "step": err.step,
            "immediate": err.immediate,
            "dropped_step": err.dropped,
        }
        return err, summary

    def _close_run(self, progress: Progress, summary: dict) -> None:
        """Close the outputs and write summary.json, whatever ended the run; render."""
        self.stops.closing()
        progress.close()
        self.outputs.close()
        summary["warnings"] = list(progress.warnings)  # every warning the run said
        if self.out_dir is not None:
            write_json(self.out_dir / "summary.json", summary, self.comm)
            render = self.scene.get("output", {}).get("render", "none")
            if render != "none" and "fields" in self.outputs.logs:
                render_in_child(self.out_dir, render, self.comm, progress)

    def _report_done(self, progress: Progress, summary: dict) -> None:
        """The run's last line: its counts, wall seconds and outputs folder."""
        c, path, out = self.pos.counts, self.path is not None, self.out_dir
        progress.final(
            f"done: {c['steps']} steps, {c['newton_iterations']} Newton iterations, "
            f"{c['dt_cuts']} dt cuts"
            + (
                f", {c['rejected_steps']} steps rejected "
                + ("for turning the path too far" if path else "by the error control")
                if c["rejected_steps"]
                else ""
            )
            + f", {summary['wall_s']['total']:.1f} s"
            + (f"; outputs in {out}" if out is not None else "")
        )
