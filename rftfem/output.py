"""Everything a run writes (docs/scenes.md "Outputs"): the one place for output.

Only rank 0 writes CSV and JSON; rows are flushed as they are written, so a run
that fails keeps everything up to its last good step.  Fields go to XDMF
(displacement, director and, on magnetic parts, the magnetization direction),
interpolated to first-order Lagrange, which XDMF and ParaView show directly.
"""

from __future__ import annotations

import json
import math
import os
import sys
import time as _time
from pathlib import Path

import numpy as np
from dolfinx import fem, io

from . import compat
from .errors import SceneError
from .selectors import owned_cells


class Probes:
    """Displacement of material points given in reference coordinates."""

    def __init__(self, model, probes: list[dict]):
        self.model = model
        self.names = [p["name"] for p in probes]
        self.points = np.array([p["at"] for p in probes], dtype=float).reshape(-1, 3)
        self.cells, on_body = owned_cells(model.mesh, self.points)
        for i, (p, inside) in enumerate(zip(probes, on_body)):
            if not inside:
                raise SceneError(f"output.probes.{i}.at: probe '{p['name']}' at {p['at']} "
                                 "is outside the body")

    def header(self) -> list[str]:
        return [f"{n}_{c}" for n in self.names for c in ("ux", "uy", "uz")]

    def values(self) -> np.ndarray:
        """(n_probes, 3) displacements, on every rank."""
        comm = self.model.comm
        out = np.zeros((len(self.names), 3))
        for i, cell in enumerate(self.cells):
            if cell is not None:
                out[i] = self.model.displacement.eval(self.points[i], np.array([cell], dtype=np.int32))
        return comm.allreduce(out)


class BodyLog:
    """Whole-body diagnostics, one row per output step (``body.csv``): the centroid
    and the stored energy, then the columns of each active effect (the kinetic
    energy with inertia, the drag power, the field and the magnetic moment, ...).
    Every value is global."""

    def __init__(self, model):
        self.model = model
        self.columns = ["centroid_x", "centroid_y", "centroid_z", "elastic_energy"]
        self.columns += [c for comp in model.components for c in comp.columns]

    def header(self) -> list[str]:
        return self.columns

    def values(self, t: float) -> list[float]:
        m = self.model
        row = [*m.centroid(), m.elastic_energy()]
        for comp in m.components:
            row += comp.values(t)
        return row


class CsvLog:
    """A CSV file written by rank 0, flushed after every row."""

    def __init__(self, path: Path, header: list[str], comm):
        self.rank = comm.rank
        self.file = open(path, "w", encoding="utf-8") if self.rank == 0 else None
        self.row(header)

    def row(self, values):
        if self.file is not None:
            self.file.write(",".join(_fmt(v) for v in values) + "\n")
            self.file.flush()

    def close(self):
        if self.file is not None:
            self.file.close()


def _fmt(v) -> str:
    if isinstance(v, str):
        return v
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    return repr(float(v))


class FieldWriter:
    """Displacement, director (and magnetization direction) for ParaView, in XDMF.

    The fields live on the mesh's geometry nodes (XDMF stores one value per node):
    the vertices of a straight mesh, all nine or six nodes of a curved
    (second-order) gmsh mesh, which ParaView then draws as curved cells."""

    def __init__(self, model, path: Path, extra: dict | None = None):
        mesh = model.mesh
        self.model = model
        V = compat.function_space(mesh, "Lagrange", compat.geometry_cells(mesh)[1], (3,))
        self.fields = {"displacement": (model.displacement, fem.Function(V, name="displacement")),
                       "director": (model.nodal_director(), fem.Function(V, name="director"))}
        for name, f in (extra or {}).items():  # Functions, or UFL expressions of the state
            source = f if isinstance(f, fem.Function) else compat.expression(f, V)
            self.fields[name] = (source, fem.Function(V, name=name))
        self.path = Path(path)
        self.file = io.XDMFFile(mesh.comm, str(path), "w")
        self.file.write_mesh(mesh)

    def write(self, t: float):
        self.model.nodal_director()  # refreshed from the triads (hinged bodies)
        for source, target in self.fields.values():
            target.interpolate(source)
            self.file.write_function(target, t)

    def close(self):
        self.file.close()
        if self.model.comm.rank == 0:
            compat.repair_xdmf_namespace(self.path)


class Progress:
    """What a run tells while it runs, on rank 0.

    - on a terminal: a progress bar redrawn in place after every step;
    - elsewhere (CI, cluster logs, a pipe): a plain line at most every
      ``interval`` seconds (default 5 s, or ``RFTFEM_LOG_INTERVAL``), so a run of
      many cheap steps does not fill its log;
    - ``quiet``: only what :meth:`final` says; errors go to stderr as always.

    Notices (:meth:`log`: the opening line, step cuts) are printed unless quiet.
    A hand-written bar rather than tqdm or rich: it is twenty lines, works the
    same on both stacks and under MPI (one rank prints), and needs no package.
    """

    def __init__(self, end: float, comm, quiet: bool = False, stream=None,
                 interval: float | None = None):
        self.end = end
        self.stream = stream or sys.stdout
        self.active = comm.rank == 0
        self.quiet = quiet
        self.bar = self.active and not quiet and self.stream.isatty()
        if interval is None:
            try:
                interval = float(os.environ.get("RFTFEM_LOG_INTERVAL", "5"))
            except ValueError:
                interval = 5.0
        self.interval = interval
        self.t0 = _time.perf_counter()
        self.last_line = -math.inf

    def _write(self, text: str):
        if self.bar:
            self.stream.write("\r\033[K")
        self.stream.write(text + "\n")
        self.stream.flush()

    def log(self, text: str):
        """A notice: printed unless quiet."""
        if self.active and not self.quiet:
            self._write(text)

    def final(self, text: str):
        """The run's last line: always printed."""
        if self.active:
            self.close()
            self._write(text)

    def update(self, t: float, step: int, newton: int, residual: float):
        if not self.active or self.quiet:
            return
        now = _time.perf_counter()
        elapsed = now - self.t0
        eta = elapsed * (self.end - t) / t if t > 0 else float("nan")
        if self.bar:
            width = 30
            done = int(width * min(t / self.end, 1.0))
            self.stream.write(f"\r[{'#' * done}{'.' * (width - done)}] t = {t:.4g}/{self.end:.4g}"
                              f"  step {step}  newton {newton}  eta {eta:.0f} s\033[K")
            self.stream.flush()
        elif now - self.last_line >= self.interval:
            self.last_line = now
            self._write(f"t = {t:.6g}/{self.end:.6g}  step {step}  newton {newton}  "
                        f"residual {residual:.3e}  elapsed {elapsed:.1f} s  eta {eta:.0f} s")

    def close(self):
        if self.bar:
            self.stream.write("\n")
            self.stream.flush()
            self.bar = False


def render_in_child(folder: Path, kind: str, comm, progress: Progress) -> None:
    """``output.render``: draw ``folder/render.<kind>`` with ``rftfem render`` in a
    child process of rank 0 (pyvista must not share a process with dolfinx, see
    :mod:`rftfem.compat_render`). A failed drawing is reported, and the run's
    own status is kept."""
    from .render_cli import draw_in_child

    if comm.rank == 0:
        out = Path(folder) / f"render.{kind}"
        proc = draw_in_child(folder, out)
        if proc.returncode == 0:
            progress.log(f"rendered {out}")
        else:
            lines = (proc.stderr or proc.stdout).strip().splitlines()
            why = lines[-1] if lines else f"exit status {proc.returncode}"
            print(f"rftfem: warning: output.render: {out} not drawn: {why}", file=sys.stderr,
                  flush=True)
    comm.Barrier()


def write_json(path: Path, data: dict, comm):
    if comm.rank == 0:
        tmp = path.with_suffix(".json.tmp")
        tmp.write_text(json.dumps(data, indent=2, default=_json_default) + "\n", encoding="utf-8")
        tmp.replace(path)


def _json_default(obj):
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"not JSON serialisable: {type(obj).__name__}")
