"""Checkpoints and restart of a run (the part of :class:`~rftfem.integration.simulation.Simulation`
that owns them): whether a results folder's last checkpoint may be continued with
this scene, loading it into the model and the solver, and writing one every
``output.checkpoint_every`` steps.  The file format is checkpoint.py's; the outputs'
side of a restart (tables cut back, field segments) is run_outputs.py's.
"""

from __future__ import annotations

import time as _time
from pathlib import Path

from rftfem.errors import SceneError
from rftfem.outputs import checkpoint


class Restarts:
    """Checkpoint and restart methods of a Simulation."""

    def _checked_checkpoint(self, folder: Path):
        """The last checkpoint of ``folder``, if this scene may go on from it."""
        path, meta = checkpoint.latest(folder, self.comm)
        differs = checkpoint.scene_difference(meta["scene"], self.scene)
        if differs:
            raise SceneError(
                f"--restart {folder}: the scene differs from the checkpointed one at {differs}"
            )
        reached = meta["path"]["load_factor"] if meta.get("path") else meta["time"]
        if reached >= self.scene["time"]["end"] * (1 - 1e-12):
            what = "load factor" if meta.get("path") else "t"
            raise SceneError(
                f"--restart {folder}: the checkpoint is at {what} = {reached:.6g}, "
                f"not before time.end = {self.scene['time']['end']:g}; raise "
                "time.end to go on"
            )
        return path, meta

    def _load_checkpoint(self):
        path, meta = self.resume
        arrays = checkpoint.read_arrays(path, self.comm, self._mesh_digest(), meta)
        self.model.set_state(arrays, meta["increment_steps"])
        self.solver.F_n.array[:] = arrays["forces"]
        if hasattr(self.scheme, "dt_prev"):
            self.scheme.dt_prev = meta["last_step"]
        self.t, self.completed = meta["time"], meta["step"]
        self.level, self.last_turn = meta.get("substep_level", 0), meta.get("last_turn", 0.0)
        self.step = self.completed
        if meta.get("path"):  # an arc-length run: where on the path, which way, how far
            state = meta["path"]
            self.load_factor, self.arc = state["load_factor"], state["arc"]
            self.first_arc, self.first_increment = state["first_arc"], state["first_increment"]
            self.path_direction = arrays.get("path_direction")
        self.counts.update(meta["counts"])
        self.wall_before = meta["wall_s"]
        self.restarts = meta.get("restarts", []) + [
            {"time": self.t, "step": self.completed, "checkpoint": path.name}
        ]

    def _mesh_digest(self) -> str:
        """This process's mesh digest (checkpoint.py), computed once: the mesh never moves."""
        if not hasattr(self, "_digest"):
            self._digest = checkpoint.mesh_digest(self.model)
        return self._digest

    def _checkpoint_if_due(self, next_step: float | None = None, last: bool = False):
        """After a step: a checkpoint every ``output.checkpoint_every`` steps, and after
        the ``last`` (a finished run can be taken further: a larger time.end)."""
        every = self.scene["output"].get("checkpoint_every", 0)
        if not every or self.out_dir is None or (self.completed % every and not last):
            return
        t0 = _time.perf_counter()
        arrays, increment_steps = self.model.state()
        arrays["forces"] = self.solver.F_n.array.copy()
        path = None
        if self.scheme.name == "arc-length":
            path = {
                "load_factor": self.load_factor,
                "arc": self.arc,
                "first_arc": self.first_arc,
                "first_increment": self.first_increment,
            }
            if self.path_direction is not None:
                arrays["path_direction"] = self.path_direction
        meta = {
            "path": path,
            "time": self.t,
            "step": self.completed,
            "counts": dict(self.counts),
            "increment_steps": increment_steps,
            "last_step": getattr(self.scheme, "dt_prev", None),
            "next_step": next_step,
            "substep_level": self.level,
            "last_turn": self.last_turn,
            "wall_s": self.wall_before + _time.perf_counter() - self._wall_start + self.setup_time,
            "restarts": self.restarts,
            # a row at this time is an output row (else one an interrupt or a
            # failure writes after it, which a restart drops)
            "output_row": bool(self.history) and self.history[-1][0] == self.t,
            "scene": {k: v for k, v in self.scene.items() if not k.startswith("_")},
            "mesh_digest": self._mesh_digest(),
        }
        checkpoint.write(self.out_dir, self.completed, arrays, meta, self.comm)
        self.wall["checkpoint"] += _time.perf_counter() - t0
