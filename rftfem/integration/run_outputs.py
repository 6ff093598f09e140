"""A run's outputs and its summary (the part of :class:`~rftfem.integration.simulation.Simulation`
that owns them, docs/model.md §9): the tables and fields opened (or continued after a
restart), a row written per output time, and summary.json's content.  The writers
themselves are output.py's.
"""

from __future__ import annotations

import time as _time
from pathlib import Path

import numpy as np

from rftfem import __version__, compat
from rftfem.errors import SceneError
from rftfem.outputs.writers import (
    CsvLog,
    FieldWriter,
    field_segments,
    keep_fields_until,
    keep_rows_until,
    merge_field_segment,
)
from rftfem.scene.time_rules import STATIC_SCHEMES


class RunOutputs:
    """Output and summary methods of a Simulation."""

    def _last_row(self, logs: dict):
        """An output row at the last converged state, unless its time has one (a run
        that stops between output times keeps where it got to)."""
        if self.history and self.history[-1][0] != self.t:
            self._write_output(logs, self.t)

    def _opening_lines(self) -> list[str]:
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

    def _open_outputs(self) -> dict:
        logs = {}
        if self.out_dir is None:
            return logs
        out, again = self.out_dir, self.resume is not None
        fields = self.scene.get("output", {}).get("fields", True)
        segment = None
        if again:
            segment = self._continue_outputs(fields)
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
            warn = getattr(self, "progress_warn", None)
            logs["fields"] = (
                FieldWriter(self.model, segment, extra, main=main, warn=warn)
                if again
                else FieldWriter(self.model, main, extra, warn=warn)
            )
        return logs

    def _continue_outputs(self, fields: bool) -> Path | None:
        """A restart: the tables cut to the checkpoint's time (rows written after it
        go, they are written again), the probe rows kept as history, the field
        files of earlier restarts merged and cut the same way; returns the new
        segment's field file."""
        out, t = self.out_dir, self.t
        at_t = self.resume[1]["output_row"]
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

    @property
    def static_run(self) -> bool:
        """Whether the run is static (load steps or arc length): its rows carry the load factor."""
        return self.scheme.name in STATIC_SCHEMES

    def _write_output(self, logs: dict, t: float):
        t0 = _time.perf_counter()
        values = self.probes.values()
        self.history.append((t, values))
        at = self.load_factor if self.scheme.name == "arc-length" else t  # the loads' time
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
        self.wall["output"] += _time.perf_counter() - t0

    def _summary(self, status: str, wall_start: float | None = None) -> dict:
        scene = {k: v for k, v in self.scene.items() if not k.startswith("_")}
        total = (
            (_time.perf_counter() - wall_start if wall_start else 0.0)
            + self.setup_time
            + self.wall_before
        )
        timings = self.solver.timings
        return {
            "status": status,
            "scene": scene,
            "scene_file": self.scene.get("_path"),
            "overrides": list(self.scene.get("_overrides", [])),
            "active_effects": self.model.active_effects(),
            "scheme": self.scheme.name,
            "versions": {"rftfem": __version__, **compat.versions()},
            "mpi_size": self.comm.size,
            "dofs": self.model.W.dofmap.index_map.size_global * self.model.W.dofmap.index_map_bs,
            "time_reached": self.t,
            **(
                {"load_factor": self.load_factor if self.scheme.name == "arc-length" else self.t}
                if self.static_run
                else {}
            ),
            "counts": dict(self.counts),
            **({"restarts": self.restarts} if self.restarts else {}),
            **(
                {"steady": self.steady.result}
                if self.steady is not None and self.steady.result
                else {}
            ),
            "factorization": {
                "policy": self.solver.factors.policy,
                "made": self.solver.factors.made,
                "lu": self.solver.lu,
            },
            **({"fluid": self.model.fluid.describe()} if self.model.fluid is not None else {}),
            "director_unit_error": self.model.director_unit_error(),
            **({"time_error": self._time_error_summary()} if self.time_errors else {}),
            "wall_s": {
                "setup": self.setup_time,
                "compile": self.model.timings["compile"],
                "assembly": self.solver.assembly_time,
                "solve": timings["solve"],
                "output": self.wall["output"],
                "checkpoint": self.wall["checkpoint"],
                "total": total,
            },
        }
