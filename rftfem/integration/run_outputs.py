"""A run's outputs and its summary (docs/model.md §9): the tables and fields opened
(or continued after a restart), a row written per output time, the rows a periodic
run's steady watch reads, and summary.json's content.  The writers themselves are
outputs/writers.py's.
"""

from __future__ import annotations

import time as _time
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from rftfem import __version__, compat
from rftfem.errors import SceneError
from rftfem.integration.steady import SteadyWatch
from rftfem.outputs.writers import (
    CsvLog,
    FieldWriter,
    field_segments,
    keep_fields_until,
    keep_rows_until,
    merge_field_segment,
)
from rftfem.scene.time_rules import STATIC_SCHEMES
from rftfem.scene.time_rules import scene_period as steady_period

if TYPE_CHECKING:
    from collections.abc import Callable

    from mpi4py import MPI

    from rftfem.integration.run_state import RunPosition
    from rftfem.integration.schemes import Scheme
    from rftfem.integration.solver import StepSolver
    from rftfem.model.shell_model import Model
    from rftfem.outputs.progress import Progress
    from rftfem.outputs.writers import BodyLog, Probes


def make_out_dir(out: Path | None, comm: MPI.Comm) -> None:
    """Make the output folder on rank 0; a path that cannot be one is a usage error
    on every rank."""
    if out is None:
        return
    error = None
    if comm.rank == 0:
        try:
            out.mkdir(parents=True, exist_ok=True)
        except FileExistsError:
            error = (
                f"--out {out}: expected a folder (or a path where one can be made), found a file"
            )
        except OSError as exc:
            error = f"--out {out}: cannot make this folder ({exc.strerror or exc})"
    error = comm.bcast(error, root=0)
    if error:
        raise SceneError(error)


class RunOutputs:
    """The run's output rows (``history``: (t, probe values) as written to
    probes.csv), its tables and fields in ``out_dir`` (``logs``), the steady watch of
    ``time.until = "periodic"`` with the rows it reads, and the wall seconds spent
    writing them."""

    def __init__(
        self,
        scene: dict,
        model: Model,
        scheme: Scheme,
        comm: MPI.Comm,
        probes: Probes,
        body: BodyLog,
        out_dir: Path | None,
    ):
        self.scene, self.model, self.scheme, self.comm = scene, model, scheme, comm
        self.probes, self.body, self.out_dir = probes, body, out_dir
        #: time.until = "periodic": the watch of the period means (steady.py) and the
        #: output rows (time, probes, body) it reads
        self.steady = None
        if scene["time"].get("until", "end") == "periodic":
            self.steady = SteadyWatch(
                steady_period(scene),
                scene["time"]["steady_tolerance"],
                self.probes.header() + self.body.header(),
            )
        self.rows = []
        self.history = []  # (t, probe values) rows, as written to probes.csv
        self.logs = {}
        #: wall seconds spent writing output rows
        self.wall = 0.0

    @property
    def static_run(self) -> bool:
        """Whether the run is static (load steps or arc length): its rows carry the load factor."""
        return self.scheme.name in STATIC_SCHEMES

    def opening_lines(self) -> list[str]:
        """What a run says first: itself, a mesh's turned cells, a Stokes liquid's
        discretisation and cost (as ``rftfem check`` says them)."""
        scene, m = self.scene, self.model
        im = m.W.dofmap.index_map
        lines = [
            f"rftfem {__version__}: {scene['title']} — effects: "
            f"{', '.join(m.active_effects())}; scheme {self.scheme.name}; "
            f"{im.size_global * m.W.dofmap.index_map_bs} dofs on {self.comm.size} "
            "process(es)"
        ]
        report = m.body.report
        if report is not None and report.turned:
            lines.append(
                f"mesh: turned {report.turned} cell(s) of {scene['mesh']['file']} "
                f"to face as their neighbours"
            )
        if m.fluid is not None:
            lines += m.fluid.opening_lines()
        return lines

    def open(self, t: float, resumed_row: bool | None, warn: Callable[[str], object]) -> None:
        """Open the tables and fields in ``out_dir``; a restart from a checkpoint at
        ``t`` (``resumed_row``: whether its row there is an output row; None: no
        restart) continues them."""
        if self.out_dir is None:
            return
        logs, out, again = self.logs, self.out_dir, resumed_row is not None
        fields = self.scene.get("output", {}).get("fields", True)
        segment = None
        if again:
            segment = self._continue(t, resumed_row, fields)
        # static runs end their rows with the load factor (time itself under load
        # control; an arc-length run's time is the path's length)
        lf = ["load_factor"] if self.static_run else []
        logs["probes"] = CsvLog(
            out / "probes.csv", ["time", *self.probes.header(), *lf], self.comm, append=again
        )
        logs["steps"] = CsvLog(
            out / "steps.csv",
            ["time", "dt", "newton_its", "residual", "wall_s", *lf],
            self.comm,
            append=again,
        )
        logs["body"] = CsvLog(
            out / "body.csv", ["time", *self.body.header(), *lf], self.comm, append=again
        )
        if fields:
            extra = {name: f for comp in self.model.components for name, f in comp.fields().items()}
            main = out / "fields.xdmf"
            logs["fields"] = (
                FieldWriter(self.model, segment, extra, main=main, warn=warn)
                if again
                else FieldWriter(self.model, main, extra, warn=warn)
            )

    def _continue(self, t: float, at_t: bool, fields: bool) -> Path | None:
        """A restart: the tables cut to the checkpoint's time (rows written after it
        go, they are written again), the probe rows kept as history, the field
        files of earlier restarts merged and cut the same way; returns the new
        segment's field file."""
        out = self.out_dir
        rows, segment = None, None
        if self.comm.rank == 0:
            try:
                keep_rows_until(out / "steps.csv", t)
                keep_rows_until(out / "body.csv", t, at_t)
                rows = keep_rows_until(out / "probes.csv", t, at_t)
                if fields:
                    main = out / "fields.xdmf"
                    done = field_segments(main)
                    for earlier in done:
                        merge_field_segment(main, earlier)
                    keep_fields_until(main, t, at_t)
                    number = int(done[-1].stem.rsplit("-", 1)[1]) + 1 if done else 1
                    segment = str(out / f"fields-{number}.xdmf")
            except (OSError, ValueError) as exc:
                rows = f"--restart {out}: cannot continue its outputs ({exc})"
        rows, segment = self.comm.bcast((rows, segment), root=0)
        if isinstance(rows, str):
            raise SceneError(rows)
        n = len(self.probes.names)
        self.history = [
            (float(r[0]), np.array([float(v) for v in r[1 : 1 + 3 * n]]).reshape(n, 3))
            for r in rows
        ]
        return Path(segment) if segment else None

    def write(self, t: float, at: float) -> None:
        """An output row at time ``t``, the loads' time ``at`` (an arc-length run's
        load factor, else ``t``)."""
        logs = self.logs
        t0 = _time.perf_counter()
        values = self.probes.values()
        self.history.append((t, values))
        lf = [at] if self.static_run else []
        body = self.body.values(at) if ("body" in logs or self.steady is not None) else None
        if self.steady is not None:
            self.rows.append([t, *values.ravel(), *body])
        if "probes" in logs:
            logs["probes"].row([t, *values.ravel(), *lf])
        if "body" in logs:
            logs["body"].row([t, *body, *lf])
        if "fields" in logs:
            logs["fields"].write(t)
        self.wall += _time.perf_counter() - t0

    def wrote_at(self, t: float) -> bool:
        """Whether the last output row is at ``t``."""
        return bool(self.history) and self.history[-1][0] == t

    def last_row(self, t: float, at: float) -> None:
        """An output row at the last converged state, unless its time has one (a run
        that stops between output times keeps where it got to)."""
        if self.history and self.history[-1][0] != t:
            self.write(t, at)

    def step_row(self, values: list[float], load_factor: float) -> None:
        """A row of steps.csv; a static run's ends with its ``load_factor``."""
        if "steps" in self.logs:
            self.logs["steps"].row(values + ([load_factor] if self.static_run else []))

    def steady_after_step(self, t: float, step: int, progress: Progress) -> bool:
        """At the end of a period (time.until = "periodic"): whether the run is steady."""
        watch = self.steady
        if watch is None:
            return False
        per_period = round(watch.period / self.scene["time"]["dt"])
        if step % per_period:
            return False
        start = t - watch.period * (1 + 1e-9)
        rows = np.array([r for r in self.rows if r[0] >= start])
        if len(rows) < 2:
            return False
        steady = watch.add_period(rows[:, 0], rows[:, 1:])
        if steady:
            progress.log(
                f"steady after {len(watch.means)} periods (t = {t:.6g}): "
                f"extrapolated values agree to {watch.tolerance:g}"
            )
        self.rows = [r for r in self.rows if r[0] >= t - watch.period * 1e-9]
        return steady

    def close(self) -> None:
        """Close the tables and fields (``logs`` keeps which were open)."""
        for log in self.logs.values():
            log.close()

    def summary(
        self,
        status: str,
        pos: RunPosition,
        solver: StepSolver,
        *,
        at: float,
        restarts: list[dict],
        time_error: dict | None,
        setup: float,
        checkpoint: float,
        total: float,
    ) -> dict:
        """summary.json's content: the run at ``pos``, the loads' time ``at``, its
        restarts, time-error estimate and wall seconds (``setup``, ``checkpoint``
        and ``total`` are the run's)."""
        scene = {k: v for k, v in self.scene.items() if not k.startswith("_")}
        timings, model = solver.timings, self.model
        return {
            "status": status,
            "scene": scene,
            "scene_file": self.scene.get("_path"),
            "overrides": list(self.scene.get("_overrides", [])),
            "active_effects": model.active_effects(),
            "scheme": self.scheme.name,
            "versions": {"rftfem": __version__, **compat.versions()},
            "mpi_size": self.comm.size,
            "dofs": model.W.dofmap.index_map.size_global * model.W.dofmap.index_map_bs,
            "time_reached": pos.t,
            **({"load_factor": at} if self.static_run else {}),
            "counts": dict(pos.counts),
            **({"restarts": restarts} if restarts else {}),
            **(
                {"steady": self.steady.result}
                if self.steady is not None and self.steady.result
                else {}
            ),
            "factorization": {
                "policy": solver.factors.policy,
                "made": solver.factors.made,
                "lu": solver.lu,
            },
            **({"fluid": model.fluid.describe()} if model.fluid is not None else {}),
            "director_unit_error": model.director_unit_error(),
            **({"time_error": time_error} if time_error is not None else {}),
            "wall_s": {
                "setup": setup,
                "compile": model.timings["compile"],
                "assembly": solver.assembly_time,
                "solve": timings["solve"],
                "output": self.wall,
                "checkpoint": checkpoint,
                "total": total,
            },
        }
