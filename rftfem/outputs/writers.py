"""Everything a run writes into its folder (docs/scenes.md "Outputs"): the one place
for output files (what it prints while running: :mod:`rftfem.outputs.progress`).

Only rank 0 writes CSV and JSON; rows are flushed as they are written, so a run
that fails keeps everything up to its last good step.  Fields go to XDMF
(displacement, director and, on magnetic parts, the magnetization direction),
interpolated to first-order Lagrange, which XDMF and ParaView show directly.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from dolfinx import fem, io

from rftfem import compat
from rftfem.errors import SceneError
from rftfem.scene.selectors import owned_cells

if TYPE_CHECKING:
    from collections.abc import Callable, Iterable
    from typing import Any

    from dolfinx.mesh import Mesh
    from mpi4py import MPI


class Probes:
    """Displacement of material points given in reference coordinates."""

    def __init__(self, model: Any, probes: list[dict]):
        self.model = model
        self.names = [p["name"] for p in probes]
        self.points = np.array([p["at"] for p in probes], dtype=float).reshape(-1, 3)
        self.cells, on_body = owned_cells(model.mesh, self.points)
        for i, (p, inside) in enumerate(zip(probes, on_body)):
            if not inside:
                raise SceneError(
                    f"output.probes.{i}.at: probe '{p['name']}' at {p['at']} is outside the body"
                )

    def header(self) -> list[str]:
        return [f"{n}_{c}" for n in self.names for c in ("ux", "uy", "uz")]

    def values(self) -> np.ndarray:
        """(n_probes, 3) displacements, on every rank."""
        comm = self.model.comm
        out = np.zeros((len(self.names), 3))
        for i, cell in enumerate(self.cells):
            if cell is not None:
                out[i] = self.model.displacement.eval(
                    self.points[i], np.array([cell], dtype=np.int32)
                )
        return comm.allreduce(out)


class BodyLog:
    """Whole-body diagnostics, one row per output step (``body.csv``): the centroid
    and the stored energy, then the columns of each active effect (the kinetic
    energy with inertia, the drag power, the field and the magnetic moment, ...),
    then the named entries' reactions (reactions.py), then with several bodies a
    block per body (rftfem/model/body_parts.py).  Every value is global."""

    def __init__(self, model: Any, reactions: Any | None = None):
        from rftfem.model.body_parts import PartMeasures, body_parts

        self.model, self.reactions = model, reactions
        self.columns = ["centroid_x", "centroid_y", "centroid_z", "elastic_energy"]
        self.columns += [c for comp in model.components for c in comp.columns]
        if reactions:
            self.columns += reactions.columns
        #: several bodies: a block of columns each (NAME_centroid_x, ...)
        self.parts = [PartMeasures(model, part) for part in body_parts(model)]
        self.columns += [c for part in self.parts for c in part.columns]

    def header(self) -> list[str]:
        return self.columns

    def values(self, t: float) -> list[float]:
        m = self.model
        row = [*m.centroid(), m.elastic_energy()]
        for comp in m.components:
            row += comp.values(t)
        if self.reactions:
            row += list(self.reactions.last.ravel())
        for part in self.parts:
            row += part.values()
        return row


class CsvLog:
    """A CSV file written by rank 0, flushed after every row; ``append``: rows added
    to the file as it is (a restarted run), the header not written again."""

    def __init__(self, path: Path, header: list[str], comm: MPI.Comm, append: bool = False):
        self.rank = comm.rank
        self.file = open(path, "a" if append else "w", encoding="utf-8") if self.rank == 0 else None
        if not append:
            self.row(header)

    def row(self, values: Iterable[str | float]) -> None:
        if self.file is not None:
            self.file.write(",".join(_fmt(v) for v in values) + "\n")
            self.file.flush()

    def close(self) -> None:
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

    The fields are written at the solution's degree, on second-order cells whose
    nodes are the P2 dofs (:mod:`rftfem.outputs.field_mesh`): a rolled strip is drawn
    round, not as a polygon through its vertices.  Rank 0 writes the file.

    The file is opened for each output time and closed after it (under a
    millisecond): HDF5 left open by a process that dies (SIGKILL, a node going
    down) is unreadable as a whole, closed after every write it keeps every
    time step written before."""

    def __init__(
        self,
        model: Any,
        path: Path,
        extra: dict | None = None,
        main: Path | None = None,
        warn: Callable[[str], object] | None = None,
    ):
        from mpi4py import MPI

        from rftfem.outputs.field_mesh import FieldMesh

        #: the run's field file that this one (a restart's segment) is merged into on close
        self.main = main
        self.model = model
        V = model.Vu  # [P2]^3 on the body's mesh
        self.nodes = FieldMesh(V)
        self.fields = {"displacement": model.displacement, "director": model.nodal_director()}
        for name, f in (extra or {}).items():  # Functions, or UFL expressions of the state
            self.fields[name] = f if isinstance(f, fem.Function) else compat.expression(f, V)
        self._at_nodes = fem.Function(V)
        #: how a failure to write is told (a warning of the run); then the fields stop
        self.warn, self.failed = warn or (lambda text: None), False
        self.out = {}
        self.path = Path(path)
        if self.nodes.mesh is not None:
            self.out = {name: fem.Function(self.nodes.space, name=name) for name in self.fields}
            with io.XDMFFile(MPI.COMM_SELF, str(path), "w") as file:
                file.write_mesh(self.nodes.mesh)

    def write(self, t: float) -> None:
        from mpi4py import MPI

        self.model.nodal_director()  # refreshed from the triads (hinged bodies)
        self.model.directors.sync()  # the extra fields may be expressions of the state
        for name, source in self.fields.items():
            if isinstance(source, fem.Function) and source.function_space == self.model.Vu:
                values = source
            else:
                self._at_nodes.interpolate(source)
                values = self._at_nodes
            self.nodes.gather(values, self.out.get(name))
        if self.nodes.mesh is not None and not self.failed:
            try:
                with io.XDMFFile(MPI.COMM_SELF, str(self.path), "a") as file:
                    for target in self.out.values():
                        file.write_function(target, t)
            except RuntimeError as error:  # dolfinx 0.5 on strongly curved coarse cells
                self.failed = True
                self.warn(
                    f"warning: {self.path.name}: no fields written from t = {t:.6g} on "
                    f"(dolfinx {compat.versions()['dolfinx']} could not write them on "
                    f"this mesh: {error}); the tables go on. Refine the mesh or run "
                    "on the current stack for fields"
                )

    def close(self) -> None:
        if self.model.comm.rank == 0:
            declare_double_precision(self.path)
            if self.main is not None:
                merge_field_segment(self.main, self.path)


def write_json(path: Path, data: dict, comm: MPI.Comm) -> None:
    if comm.rank == 0:
        tmp = path.with_suffix(".json.tmp")
        tmp.write_text(json.dumps(data, indent=2, default=json_default) + "\n", encoding="utf-8")
        tmp.replace(path)


def json_default(obj: object) -> object:
    """``json.dumps``' default for numpy values and paths."""
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"not JSON serialisable: {type(obj).__name__}")


# --- continuing the outputs of a restarted run (checkpoint.py) ---------------------


def keep_rows_until(path: Path, t: float, at_t: bool = True) -> list[list[str]]:
    """Cut a CSV table of this module to its header and the rows up to time ``t``
    (``at_t``: and at it); a row cut short by a killed run is dropped too.
    Returns the rows kept."""
    lines = Path(path).read_text(encoding="utf-8").splitlines(keepends=True)
    kept, rows = lines[:1], []
    tol = 1e-12 * max(1.0, abs(t))
    for line in lines[1:]:
        if not line.endswith("\n"):
            break
        cells = line.rstrip("\n").split(",")
        try:
            if float(cells[0]) > t + tol or (not at_t and float(cells[0]) > t - tol):
                break
        except ValueError:
            break
        kept.append(line)
        rows.append(cells)
    tmp = Path(str(path) + ".tmp")
    tmp.write_text("".join(kept), encoding="utf-8")
    tmp.replace(path)
    return rows


_XI = "http://www.w3.org/2001/XInclude"


def _xdmf_tree(path: Path):
    import xml.etree.ElementTree as ET

    ET.register_namespace("xi", _XI)
    compat.repair_xdmf_namespace(path)
    return ET.parse(path)


def declare_double_precision(path: Path) -> None:
    """Say in the XDMF file that its real arrays are doubles (``Precision="8"``).

    dolfinx writes the geometry and the fields' data items without a number
    type, and XDMF's default is a 4-byte float: ParaView then reads the doubles of
    fields.h5 as float32.  Also repairs the XInclude namespace (compat)."""
    tree = _xdmf_tree(path)
    if _declare_doubles(tree):
        _write_xdmf(tree, path)


def _declare_doubles(tree) -> bool:
    """Set ``Precision="8"`` on the HDF real data items that lack it; whether any did."""
    changed = False
    for item in tree.iter("DataItem"):
        if (
            item.get("Format") == "HDF"
            and item.get("NumberType", "Float") == "Float"
            and item.get("Precision") is None
        ):
            item.set("NumberType", "Float")
            item.set("Precision", "8")
            changed = True
    return changed


def _collections(tree) -> dict:
    return {
        g.get("Name"): g
        for g in tree.getroot().find("Domain").findall("Grid")
        if g.get("GridType") == "Collection"
    }


def _write_xdmf(tree, path: Path):
    tmp = Path(str(path) + ".tmp")
    tree.write(tmp, encoding="utf-8", xml_declaration=True)
    tmp.replace(path)


def field_segments(main: Path) -> list[Path]:
    """The field files of a run's restarts (``fields-1.xdmf``, ...), in order."""
    main = Path(main)
    found = main.parent.glob(f"{main.stem}-*.xdmf")
    return sorted(
        (p for p in found if p.stem.rsplit("-", 1)[1].isdigit()),
        key=lambda p: int(p.stem.rsplit("-", 1)[1]),
    )


def merge_field_segment(main: Path, segment: Path) -> None:
    """Add the time steps of ``segment`` (a restart's field file) to the run's
    ``main`` field file, whose mesh they share; their data stay in the segment's
    own HDF5 file.  A segment already in ``main`` is left out.  Both are declared
    double precision here too: a run killed outright (SIGKILL) never closed its
    writer, which is where that is otherwise done."""
    tree = _xdmf_tree(main)
    _declare_doubles(tree)
    h5 = Path(segment).with_suffix(".h5").name + ":"
    if any((item.text or "").strip().startswith(h5) for item in tree.iter("DataItem")):
        _write_xdmf(tree, main)
        return
    ours = _collections(tree)
    theirs = _xdmf_tree(segment)
    _declare_doubles(theirs)
    for name, grid in _collections(theirs).items():
        if name in ours:
            ours[name].extend(list(grid))
        else:
            tree.getroot().find("Domain").append(grid)
    _write_xdmf(tree, main)


def keep_fields_until(main: Path, t: float, at_t: bool = True) -> None:
    """Drop the time steps after ``t`` (``at_t``: keep the one at it) from a field
    file, and declare its real arrays double precision (see :func:`merge_field_segment`)."""
    tree = _xdmf_tree(main)
    _declare_doubles(tree)
    tol = 1e-12 * max(1.0, abs(t))
    limit = t + tol if at_t else t - tol
    for grid in _collections(tree).values():
        for step in list(grid):
            time = step.find("Time")
            if time is not None and float(time.get("Value")) > limit:
                grid.remove(step)
    _write_xdmf(tree, main)


def write_cell_field(path: Path, mesh: Mesh, f: fem.Function) -> None:
    """One cellwise (DG0) Function, or one of the mesh's own degree (P1), on the body's
    mesh, in XDMF for ParaView (all ranks write collectively)."""
    with io.XDMFFile(mesh.comm, str(path), "w") as file:
        file.write_mesh(mesh)
        file.write_function(f)
    if mesh.comm.rank == 0:
        compat.repair_xdmf_namespace(path)
        declare_double_precision(path)
