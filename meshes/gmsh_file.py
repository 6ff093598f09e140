"""Read a user's gmsh ``.msh`` surface mesh into a :class:`~rftfem.meshes.Body`.

The gmsh plumbing every builder shares (the rank-0 session, :class:`Recipe` and
:func:`realize`, the collective step to a dolfinx mesh) is :mod:`.gmsh_session`'s;
its two names are imported here too.
"""

from __future__ import annotations

import os
from typing import TYPE_CHECKING, Any

import numpy as np

from rftfem.errors import SceneError

from .gmsh_session import Recipe, realize

if TYPE_CHECKING:
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


# --- reading a .msh file -------------------------------------------------------


def _one_line(text: str) -> str:
    return " ".join(str(text).split())


def _fail(path: str, what: str):
    raise SceneError(f"mesh.file: {what} ('{path}')")


def _merge(gmsh: Any, path: str) -> None:
    """Rank 0: ``path`` merged into the current model, if it is a readable ``.msh`` file."""
    if not path.lower().endswith(".msh"):
        # other extensions may be run by gmsh as .geo scripts: scenes are data
        _fail(path, "expected a gmsh mesh file ending in .msh")
    if not os.path.isfile(path):
        _fail(path, "no such file")
    try:
        gmsh.merge(path)
    except Exception as e:
        _fail(path, f"gmsh cannot read it as a mesh: {_one_line(e)}")


def _physical_surfaces(model: Any, path: str, groups: list) -> list:
    """The tags of the physical surfaces among ``groups``; refused without them, with
    physical volumes or without 2D elements."""
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
    return surfaces


def _named_regions(model: Any, path: str, surfaces: list) -> tuple[dict, dict, set]:
    """``(regions, owner, types)``: names → physical surface tags, each surface entity's
    physical surface, and the element types of the entities; each entity in one."""
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
    return regions, owner, types


def _check_cell_types(model: Any, path: str, owner: dict, types: set) -> None:
    """Refuse unsupported or mixed 2D element types, and physical surfaces without
    elements."""
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


def _edges_and_points(model: Any, path: str, groups: list, owner: dict) -> tuple[dict, dict]:
    """``(edges, points)``: named physical curves → tags, named physical points → their
    coordinates (each a node of the body's cells)."""
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
    return edges, points


def _prepare_file(gmsh: Any, path: str) -> tuple:
    """Rank 0: load ``path`` into the current model, check it, return names."""
    _merge(gmsh, path)
    model = gmsh.model

    groups = model.getPhysicalGroups()
    surfaces = _physical_surfaces(model, path, groups)
    regions, owner, types = _named_regions(model, path, surfaces)
    _check_cell_types(model, path, owner, types)

    # Surfaces in no physical surface: drop them (and their mesh) here, so that
    # every dolfinx version builds the same mesh from the tagged cells.
    untagged = [(2, t) for _, t in model.getEntities(2) if t not in owner]
    if untagged:
        model.removeEntities(untagged, recursive=False)
    report = _check_cells(model, path, types.pop(), sorted(owner))
    model.mesh.renumberNodes()  # dolfinx wants node tags 1..N
    edges, points = _edges_and_points(model, path, groups, owner)
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
