"""Where a run is and what its loops call back (simulation.py): the time reached, the
step under way, the steps done and the run's counts (:class:`RunPosition`), and the
outputs, checkpoints and stops a loop over steps reaches through its run
(:class:`RunHooks`).  The loops themselves are step_control.py's (fixed steps),
error_control.py's (error-controlled steps) and arclength.py's (arc length).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from collections.abc import Callable

    from rftfem.outputs.progress import Progress


def _no_counts() -> dict[str, int]:
    return {"steps": 0, "newton_iterations": 0, "dt_cuts": 0, "rejected_steps": 0}


@dataclass
class RunPosition:
    """The run's time ``t`` (an arc-length run's path length), the step under way,
    the steps done with the time they reached, and the counts of summary.json."""

    t: float = 0.0
    step: int = 0
    completed: int = 0
    #: the time the completed steps reached: a second signal may stop the run after
    #: a step has moved ``t`` and before it counts as done
    completed_time: float = 0.0
    counts: dict[str, int] = field(default_factory=_no_counts)

    def complete(self, step: int) -> None:
        """Count the steps up to ``step`` as done, at the time ``t`` reached."""
        self.completed, self.completed_time = step, self.t


@dataclass
class RunHooks:
    """What a loop over steps calls back into its run: the progress line, a row of
    steps.csv (with the load factor a static run's rows end in), the observers, an
    output row at a time, a checkpoint if due (``next_step``, ``last``), a stop if a
    signal asked for one, whether a periodic run is steady, and whether an output
    row is at a time."""

    progress: Progress
    step_row: Callable[[list[float], float], None]
    observe: Callable[[], None]
    output: Callable[[float], None]
    checkpoint: Callable[..., None]
    stop_if_asked: Callable[[], None]
    steady: Callable[[], bool]
    wrote_at: Callable[[float], bool]
