"""Checkpoints and restart of a run: whether a results folder's last checkpoint may be
continued with this scene, loading it into the model, the solver and the run's
position, step and path state, and writing one every ``output.checkpoint_every``
steps.  The file format is checkpoint.py's; the outputs' side of a restart (tables
cut back, field segments) is run_outputs.py's.
"""

from __future__ import annotations

import time as _time
from typing import TYPE_CHECKING

from rftfem.errors import SceneError
from rftfem.outputs import checkpoint

if TYPE_CHECKING:
    from pathlib import Path

    from mpi4py import MPI

    from rftfem.integration.arclength import PathState
    from rftfem.integration.run_state import RunPosition
    from rftfem.integration.schemes import Scheme
    from rftfem.integration.solver import StepSolver
    from rftfem.integration.step_control import StepState
    from rftfem.model.shell_model import Model


def checked_checkpoint(folder: Path, scene: dict, comm: MPI.Comm) -> tuple[Path, dict]:
    """The last checkpoint of ``folder`` and its meta, if ``scene`` may go on from it."""
    path, meta = checkpoint.latest(folder, comm)
    differs = checkpoint.scene_difference(meta["scene"], scene)
    if differs:
        raise SceneError(
            f"--restart {folder}: the scene differs from the checkpointed one at {differs}"
        )
    reached = meta["path"]["load_factor"] if meta.get("path") else meta["time"]
    if reached >= scene["time"]["end"] * (1 - 1e-12):
        what = "load factor" if meta.get("path") else "t"
        raise SceneError(
            f"--restart {folder}: the checkpoint is at {what} = {reached:.6g}, "
            f"not before time.end = {scene['time']['end']:g}; raise "
            "time.end to go on"
        )
    return path, meta


class Checkpoints:
    """The run's checkpoints in ``out_dir``: the one it goes on from (``resume``, from
    :func:`checked_checkpoint`, or None), the earlier parts' ``restarts`` and wall
    seconds, and one written every ``output.checkpoint_every`` steps."""

    def __init__(
        self,
        scene: dict,
        model: Model,
        solver: StepSolver,
        scheme: Scheme,
        comm: MPI.Comm,
        out_dir: Path | None,
        resume: tuple[Path, dict] | None,
    ):
        self.scene, self.model, self.solver, self.scheme = scene, model, solver, scheme
        self.comm, self.out_dir, self.resume = comm, out_dir, resume
        self.wall_before = 0.0  # wall seconds of the run's earlier parts (restarts)
        self.restarts = []
        #: wall seconds spent writing checkpoints
        self.wall = 0.0
        self._digest = None

    def load(self, pos: RunPosition, steps: StepState, path: PathState | None) -> None:
        """The checkpoint of ``resume`` into the model, the solver, the scheme's last
        step, the run's position and counts, the step state and the path's."""
        folder, meta = self.resume
        arrays = checkpoint.read_arrays(folder, self.comm, self._mesh_digest(), meta)
        self.model.set_state(arrays, meta["increment_steps"])
        self.solver.F_n.array[:] = arrays["forces"]
        if hasattr(self.scheme, "dt_prev"):
            self.scheme.dt_prev = meta["last_step"]
        pos.t = meta["time"]
        pos.complete(meta["step"])
        steps.level, steps.last_turn = meta.get("substep_level", 0), meta.get("last_turn", 0.0)
        pos.step = pos.completed
        if meta.get("path") and path is not None:  # where on the path, which way, how far
            state = meta["path"]
            path.load_factor, path.arc = state["load_factor"], state["arc"]
            path.first_arc, path.first_increment = state["first_arc"], state["first_increment"]
            path.path_direction = arrays.get("path_direction")
        pos.counts.update(meta["counts"])
        self.wall_before = meta["wall_s"]
        self.restarts = meta.get("restarts", []) + [
            {"time": pos.t, "step": pos.completed, "checkpoint": folder.name}
        ]

    def _mesh_digest(self) -> str:
        """This process's mesh digest (checkpoint.py), computed once: the mesh never moves."""
        if self._digest is None:
            self._digest = checkpoint.mesh_digest(self.model)
        return self._digest

    def write_if_due(
        self,
        pos: RunPosition,
        steps: StepState,
        path: PathState | None,
        *,
        output_row: bool,
        elapsed: float,
        next_step: float | None = None,
        last: bool = False,
    ) -> None:
        """After a step: a checkpoint every ``output.checkpoint_every`` steps, and after
        the ``last`` (a finished run can be taken further: a larger time.end).
        ``output_row``: whether a row at ``pos.t`` is an output row (else one an
        interrupt or a failure writes after it, which a restart drops); ``elapsed``:
        this part's wall seconds so far; ``next_step``: the error control's."""
        every = self.scene["output"].get("checkpoint_every", 0)
        if not every or self.out_dir is None or (pos.completed % every and not last):
            return
        t0 = _time.perf_counter()
        arrays, increment_steps = self.model.state()
        arrays["forces"] = self.solver.F_n.array.copy()
        state = None
        if path is not None:
            state = {
                "load_factor": path.load_factor,
                "arc": path.arc,
                "first_arc": path.first_arc,
                "first_increment": path.first_increment,
            }
            if path.path_direction is not None:
                arrays["path_direction"] = path.path_direction
        meta = {
            "path": state,
            "time": pos.t,
            "step": pos.completed,
            "counts": dict(pos.counts),
            "increment_steps": increment_steps,
            "last_step": getattr(self.scheme, "dt_prev", None),
            "next_step": next_step,
            "substep_level": steps.level,
            "last_turn": steps.last_turn,
            "wall_s": self.wall_before + elapsed,
            "restarts": self.restarts,
            "output_row": output_row,
            "scene": {k: v for k, v in self.scene.items() if not k.startswith("_")},
            "mesh_digest": self._mesh_digest(),
        }
        checkpoint.write(self.out_dir, pos.completed, arrays, meta, self.comm)
        self.wall += _time.perf_counter() - t0
