"""What callers and observers read of a run: its time, steps, counts, load factor, arcs."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from rftfem.integration.arclength import PathFollowing
    from rftfem.integration.restart import Checkpoints
    from rftfem.integration.run_outputs import RunOutputs
    from rftfem.integration.run_state import RunPosition
    from rftfem.integration.step_control import StepController


class RunView:
    """The read-only face of :class:`~rftfem.integration.simulation.Simulation`: its
    position (``pos``), path-following, outputs, steps and checkpoints, as read."""

    pos: RunPosition
    path: PathFollowing | None
    outputs: RunOutputs
    steps: StepController
    checkpoints: Checkpoints

    @property
    def t(self) -> float:
        """The time reached (an arc-length run's path length)."""
        return self.pos.t

    @property
    def step(self) -> int:
        """The step under way, or the last one done."""
        return self.pos.step

    @property
    def completed(self) -> int:
        """Steps done (``step`` may be the one under way)."""
        return self.pos.completed

    @property
    def counts(self) -> dict[str, int]:
        """Steps, Newton iterations, dt cuts and rejected steps so far."""
        return self.pos.counts

    @property
    def load_factor(self) -> float:
        """The time the loads and motions are evaluated at: ``t`` itself, except in an
        arc-length run, whose ``t`` is the path's length."""
        return self.path.state.load_factor if self.path is not None else self.pos.t

    @property
    def arc(self) -> float | None:
        """An arc-length run's next arc (None: the first step, or no arc length)."""
        return self.path.state.arc if self.path is not None else None

    @property
    def first_arc(self) -> float | None:
        """An arc-length run's first arc (None before it, or no arc length)."""
        return self.path.state.first_arc if self.path is not None else None

    @property
    def history(self) -> list:
        """The (t, probe values) output rows, as written to probes.csv."""
        return self.outputs.history

    @property
    def wall(self) -> dict[str, float]:
        """Wall seconds outside the solver: outputs, loads and motions set for a step,
        the state and triad update after it, checkpoints."""
        steps = self.steps.wall
        return {
            "output": self.outputs.wall,
            "loads": steps["loads"],
            "update": steps["update"],
            "checkpoint": self.checkpoints.wall,
        }

    def _loads_time(self, t: float) -> float:
        """The loads' time of an output at ``t``: an arc-length run's load factor."""
        return self.path.state.load_factor if self.path is not None else t
