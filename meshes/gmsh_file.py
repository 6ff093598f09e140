"""Read a user's gmsh ``.msh`` surface mesh into a :class:`~rftfem.meshes.Body`.

Also home of the gmsh plumbing shared with :mod:`.strip`: a rank-0 gmsh
session that leaves someone else's gmsh as it found it, and the collective
step that turns the rank-0 gmsh model into a distributed dolfinx mesh.
"""

from __future__ import annotations

import math
import os
import sys
from contextlib import contextmanager, nullcontext
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from rftfem.compat import create_meshtags, gmsh_model_to_mesh
from rftfem.errors import SceneError

if TYPE_CHECKING:
    from collections.abc import Callable

    from mpi4py import MPI

    from . import Body

# gmsh element types rftfem reads as surface cells: 3-node and 6-node
# triangles, 4-node and 9-node quadrilaterals (geometry degree 1 or 2).
_SURFACE_TYPES = {
    2: "3-node triangle",
    3: "4-node quadrilateral",
    9: "6-node triangle",
    10: "9-node quadrilateral",
}


# --- gmsh session (rank 0) ---------------------------------------------------


def _import_gmsh():
    # TODO(compat): importing gmsh 4.8 sets SIGINT to SIG_DFL (Ctrl-C would kill
    # the run without cleanup or outputs); put Python's handler back.
    import signal
    import threading

    main = threading.current_thread() is threading.main_thread()
    handler = signal.getsignal(signal.SIGINT) if main else None
    import gmsh

    if main and handler is not None and signal.getsignal(signal.SIGINT) is not handler:
        signal.signal(signal.SIGINT, handler)
    return gmsh


def _gmsh_is_initialized(gmsh) -> bool | None:
    """Whether gmsh is initialized, or None where that cannot be asked safely."""
    # TODO(compat): gmsh >= 4.9 has isInitialized(); gmsh 4.8 (Debian 12) does
    # not, and any call into an uninitialized gmsh 4.8 may exit the process with
    # status 1 (its error handler reads options that only initialize() sets): it
    # did, in about one launch of two in some sequences, with nothing printed.
    if hasattr(gmsh, "isInitialized"):
        return bool(gmsh.isInitialized())
    return None


@contextmanager
def _stderr_silenced():
    """File descriptor 2 to /dev/null for the block (messages printed by C++)."""
    sys.stderr.flush()
    saved = os.dup(2)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 2)
            yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)


def _gmsh_initialize(gmsh) -> None:
    # TODO(compat): gmsh >= 4.11 takes interruptible= (True replaces Python's
    # SIGINT handler, so Ctrl-C would kill the run without cleanup); 4.8 does not.
    import inspect

    kwargs = {"readConfigFiles": False}
    if "interruptible" in inspect.signature(gmsh.initialize).parameters:
        kwargs["interruptible"] = False
    gmsh.initialize(**kwargs)


class _GmshSession:
    """A fresh, current gmsh model for the ``with`` block; everything restored after.

    Initializes gmsh only if nobody has (and then finalizes it on exit);
    otherwise leaves it initialized, removes only its own model, restores the
    previously current model and every option it set (``options``, plus a
    silent terminal).  With gmsh 4.8, which cannot be asked whether it is
    initialized, initialize() is called every time (a no-op when it is) and gmsh
    is left initialized.
    """

    _count = 0

    def __init__(self, options: dict[str, float] | None = None):
        self.options = {"General.Terminal": 0.0, **(options or {})}

    def __enter__(self):
        gmsh = _import_gmsh()
        self.gmsh = gmsh
        known = _gmsh_is_initialized(gmsh)
        if known is None:
            # gmsh 4.8: initialize() on an initialized gmsh changes nothing but a warning
            # on stderr ("already initialized", silenced), so it is called every time
            # and gmsh is never finalized here (whoever else initialized it keeps their
            # models; whoever finalized it gets it back)
            self.started = False
            with _stderr_silenced():
                _gmsh_initialize(gmsh)
        else:
            self.started = not known
            if self.started:
                _gmsh_initialize(gmsh)
        self.saved = {k: gmsh.option.getNumber(k) for k in self.options}
        for k, v in self.options.items():
            gmsh.option.setNumber(k, v)
        self.previous = gmsh.model.getCurrent()
        _GmshSession._count += 1
        self.name = f"rftfem-{os.getpid()}-{_GmshSession._count}"
        gmsh.model.add(self.name)
        return gmsh

    def __exit__(self, *exc):
        gmsh = self.gmsh
        try:
            if self.name in gmsh.model.list():
                gmsh.model.setCurrent(self.name)
                gmsh.model.remove()
        finally:
            if self.started:
                gmsh.finalize()
            else:
                for k, v in self.saved.items():
                    gmsh.option.setNumber(k, v)
                if self.previous in gmsh.model.list():
                    gmsh.model.setCurrent(self.previous)
        return False


def _model_to_body(comm, prepare, options=None):
    """Collective: ``prepare(gmsh)`` on rank 0, then the dolfinx mesh on all ranks.

    ``prepare`` fills the current (fresh) gmsh model and returns a tuple of
    names (``(regions, edges)``, a file's also its points); a :class:`SceneError`
    it raises is raised on every rank (no rank is left waiting). Returns
    ``(mesh, cell_tags, facet_tags, *names)``.
    """
    root = comm.rank == 0
    with _GmshSession(options) if root else nullcontext() as gmsh:
        result = None
        if root:
            try:
                result = ("ok", prepare(gmsh))
            except SceneError as e:
                result = ("scene", str(e))
            except Exception as e:  # a bug or a gmsh failure: still tell every rank
                result = ("error", f"{type(e).__name__}: {e}")
        status, payload = comm.bcast(result, root=0)
        if status == "scene":
            raise SceneError(payload)
        if status == "error":
            raise RuntimeError(f"building the mesh with gmsh failed: {payload}")
        mesh, cell_tags, facet_tags = gmsh_model_to_mesh(gmsh.model if root else None, comm, 0, 3)
    if facet_tags is None:  # dolfinx >= 0.10 gives None when no curve is tagged
        facet_tags = _empty_meshtags(mesh, mesh.topology.dim - 1)
    return (mesh, cell_tags, facet_tags, *payload)


def _empty_meshtags(mesh, dim):
    # TODO(compat): compat.gmsh_model_to_mesh could return these itself.
    mesh.topology.create_entities(dim)
    empty = np.empty(0, dtype=np.int32)
    return create_meshtags(mesh, dim, empty, empty)


# --- reading a .msh file -------------------------------------------------------


def _one_line(text: str) -> str:
    return " ".join(str(text).split())


def _fail(path: str, what: str):
    raise SceneError(f"mesh.file: {what} ('{path}')")


def _prepare_file(gmsh, path: str):
    """Rank 0: load ``path`` into the current model, check it, return names."""
    if not path.lower().endswith(".msh"):
        # other extensions may be run by gmsh as .geo scripts: scenes are data
        _fail(path, "expected a gmsh mesh file ending in .msh")
    if not os.path.isfile(path):
        _fail(path, "no such file")
    try:
        gmsh.merge(path)
    except Exception as e:
        _fail(path, f"gmsh cannot read it as a mesh: {_one_line(e)}")
    model = gmsh.model

    groups = model.getPhysicalGroups()
    if any(dim == 3 for dim, _ in groups):
        _fail(path, "has physical volumes; expected a surface mesh (2D elements in 3D)")
    if len(model.mesh.getElementTypes(2)) == 0:
        _fail(path, "is not a surface mesh: it has no 2D elements")
    surfaces = [tag for dim, tag in groups if dim == 2]
    if not surfaces:
        _fail(
            path,
            "has no physical surface; name the surfaces that make the body "
            '(Physical Surface("name") = {...})',
        )

    regions: dict[str, list[int]] = {}
    owner: dict[int, int] = {}  # surface entity -> physical surface
    types: set[int] = set()
    for tag in surfaces:
        name = model.getPhysicalName(2, tag)
        for entity in model.getEntitiesForPhysicalGroup(2, tag):
            entity = int(entity)
            if entity in owner:
                _fail(
                    path,
                    f"surface {entity} is in two physical surfaces "
                    f"({owner[entity]} and {tag}); each cell must be in one",
                )
            owner[entity] = tag
            types.update(int(t) for t in model.mesh.getElementTypes(2, entity))
        if name:
            regions.setdefault(name, []).append(int(tag))
    if not regions:
        _fail(path, "has no named physical surface")
    bad = sorted(types - set(_SURFACE_TYPES))
    if bad:
        names = ", ".join(model.mesh.getElementProperties(t)[0] for t in bad)
        _fail(
            path,
            f"has unsupported 2D elements ({names}); use 3- or 6-node triangles "
            "or 4- or 9-node quadrilaterals",
        )
    if len(types) != 1:
        names = " and ".join(_SURFACE_TYPES[t] for t in sorted(types))
        _fail(path, f"mixes {names} cells in its physical surfaces; use one cell type")
    if not any(len(model.mesh.getElements(2, e)[0]) for e in owner):
        _fail(path, "its physical surfaces hold no elements")

    # Surfaces in no physical surface: drop them (and their mesh) here, so that
    # every dolfinx version builds the same mesh from the tagged cells.
    untagged = [(2, t) for _, t in model.getEntities(2) if t not in owner]
    if untagged:
        model.removeEntities(untagged, recursive=False)
    report = _check_cells(model, path, types.pop(), sorted(owner))
    model.mesh.renumberNodes()  # dolfinx wants node tags 1..N

    edges: dict[str, list[int]] = {}
    points: dict[str, np.ndarray] = {}
    on_body = None  # the nodes of the body's cells, once a point needs them
    for dim, tag in groups:
        name = model.getPhysicalName(dim, tag)
        if dim == 1 and name:
            edges.setdefault(name, []).append(int(tag))
        elif dim == 0:
            nodes, xyz = model.mesh.getNodesForPhysicalGroup(0, tag)
            if on_body is None:
                on_body = set()
                for e in owner:
                    on_body.update(int(n) for n in model.mesh.getNodes(2, e, True)[0])
            if not set(int(n) for n in nodes) <= on_body:
                # a node outside every cell would leave the mesh a free vertex
                _fail(
                    path,
                    f"physical point '{name or tag}' is not on the body's "
                    "surface; a named point must be a node of its mesh",
                )
            if name:
                points[name] = np.vstack(
                    [points.get(name, np.empty((0, 3))), np.asarray(xyz).reshape(-1, 3)]
                )
    return regions, edges, points, report


def _check_cells(model, path: str, cell_type: int, entities: list[int]):
    """Rank 0: the checks of :mod:`.surface_checks` on the body's cells; cells that
    face the other way from their neighbours are written back turned (their nodes
    reordered), so that dolfinx reads one orientation.  Returns the report."""
    from .surface_checks import REVERSED, check_surface

    tags, nodes, entity_of = [], [], []
    for e in entities:
        _, element_tags, node_tags = model.mesh.getElements(2, e)
        if len(element_tags):
            tags.append(np.asarray(element_tags[0]))
            nodes.append(np.asarray(node_tags[0]).reshape(len(element_tags[0]), -1))
            entity_of.append(np.full(len(element_tags[0]), e))
    tags, nodes, entity_of = np.concatenate(tags), np.vstack(nodes), np.concatenate(entity_of)
    node_tags, xyz, _ = model.mesh.getNodes()
    index = np.zeros(int(np.max(node_tags)) + 1, dtype=np.int64)
    index[np.asarray(node_tags, dtype=np.int64)] = np.arange(len(node_tags))
    points = model.mesh.getIntegrationPoints(cell_type, "Gauss4")[0]
    # (components, values[, orientations]): gmsh 4.8 and later differ in the tuple's length
    grads = model.mesh.getBasisFunctions(cell_type, points, "GradLagrange")[1]
    grads = np.asarray(grads).reshape(len(points) // 3, nodes.shape[1], 3)[:, :, :2]
    try:
        turn, report = check_surface(
            cell_type, index[nodes], np.asarray(xyz).reshape(-1, 3), grads, tags
        )
    except ValueError as e:
        _fail(path, str(e))
    if turn.any():
        nodes[turn] = nodes[turn][:, REVERSED[cell_type]]
        for e in np.unique(entity_of[turn]):
            inside, coords, _ = model.mesh.getNodes(2, int(e), includeBoundary=False)
            mine = entity_of == e
            model.mesh.clear([(2, int(e))])
            model.mesh.addNodes(2, int(e), inside, coords)
            model.mesh.addElements(2, int(e), [cell_type], [tags[mine]], [nodes[mine].ravel()])
    return report


def _extents(comm, mesh) -> tuple[float, float]:
    from mpi4py import MPI

    x = mesh.geometry.x
    out = []
    for k in (0, 1):
        lo = float(x[:, k].min()) if x.shape[0] else math.inf
        hi = float(x[:, k].max()) if x.shape[0] else -math.inf
        out.append(comm.allreduce(hi, op=MPI.MAX) - comm.allreduce(lo, op=MPI.MIN))
    return out[0], out[1]


@dataclass
class Recipe:
    """How to make a body in gmsh, before any dolfinx mesh: ``prepare(gmsh)`` fills
    the current model on rank 0 and returns ``(regions, edges, points, report)``
    (names → physical tags; named points' coordinates; a gmsh file's
    :class:`~.surface_checks.SurfaceReport` or None) under the gmsh ``options``.
    ``extents``: the reference body's (length, width) if known (else measured);
    ``hinges``: its built-in hinge lines' names.  :func:`realize` makes the Body;
    :mod:`.bodies` puts several recipes into one mesh."""

    prepare: Callable[[Any], tuple]
    options: dict[str, float] | None = None
    extents: tuple[float, float] | None = None
    hinges: list[str] = field(default_factory=list)


def realize(comm: MPI.Comm, recipe: Recipe) -> Body:
    """Collective: the Body of ``recipe`` (gmsh on rank 0, dolfinx on every rank)."""
    from . import Body

    mesh, cell_tags, facet_tags, regions, edges, points, report = _model_to_body(
        comm, recipe.prepare, recipe.options
    )
    length, width = recipe.extents or _extents(comm, mesh)
    return Body(
        mesh=mesh,
        cell_tags=cell_tags,
        facet_tags=facet_tags,
        regions=regions,
        edges=edges,
        points=points,
        length=length,
        width=width,
        hinges=list(recipe.hinges),
        report=report,
    )


def file_recipe(path: str | os.PathLike[str]) -> Recipe:
    """The :class:`Recipe` of a gmsh ``.msh`` file (:func:`read_gmsh`)."""
    path = os.fspath(path)
    return Recipe(lambda gmsh: _prepare_file(gmsh, path))


def read_gmsh(comm: MPI.Comm, path: str | os.PathLike[str]) -> Body:
    """Read a gmsh ``.msh`` surface mesh (2D elements in 3D) into a Body.

    The file may hold a curved surface and second-order geometry (6-node
    triangles or 9-node quadrilaterals); one cell type per file. Named physical
    surfaces become ``regions`` (name -> physical tags), named physical curves
    become ``edges`` and the facet tags, named physical points ``points`` (name ->
    their coordinates: supports for a rigid mode). Unnamed physical groups still tag
    cells/facets but get no name.

    Only cells in a physical surface are in the mesh: surfaces that no
    physical surface contains are dropped with their elements (gmsh/dolfinx
    behaviour; done explicitly here so every dolfinx version agrees). A
    surface entity may belong to one physical surface only (each cell carries
    one tag). The normal of each cell follows the node order in the file, except
    that cells facing the other way from their neighbours are turned to face as
    most of their piece does (:mod:`.surface_checks`, which also refuses cells of
    no area or turned inside out, unmerged coincident nodes and a surface that
    cannot be oriented); ``report`` says what was found.

    ``length`` and ``width`` are the global bounding-box extents in X and Y.
    The file is read on rank 0; names are broadcast. Errors (not a ``.msh``
    name, missing or unreadable file, no 2D elements, no named physical
    surface, mixed or unsupported cell types) raise a one-line
    ``SceneError("mesh.file: ...")`` on every rank.
    """
    return realize(comm, file_recipe(path))
