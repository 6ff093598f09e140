"""The ``where`` language: which parts of the body a scene entry selects.

Selectors are ``"all"``, the edges ``"x=0"``, ``"x=L"``, ``"y=0"``, ``"y=W"`` of a
strip-like body, the lines ``"x=c"`` / ``"y=c"`` of hinges, region names
(``[[mesh.regions]]``, the three-link's built-in links, gmsh physical surfaces),
gmsh physical curves and gmsh physical points.  The first half of this module
checks selectors in a scene before any mesh exists; the second half finds the
cells, facets and vertices they select on a built body (dolfinx is imported there only, so
checking a scene
stays light).
"""

from __future__ import annotations

import math
import re
from typing import TYPE_CHECKING, Any, Sequence

import numpy as np

from rftfem.errors import SceneError
from rftfem.scene.schema import fmt, suggest

if TYPE_CHECKING:  # (dolfinx is imported where a mesh is used)
    import dolfinx.fem
    import dolfinx.mesh

#: ``where`` selectors that always exist on a strip (besides region names).
EDGE_SELECTORS = ("x=0", "x=L", "y=0", "y=W")
SPECIAL_SELECTORS = ("all",) + EDGE_SELECTORS
#: the built-in regions (across Y: left, middle, right) and hinge lines of a three-link body
THREE_LINK_REGIONS = ("left", "middle", "right")
THREE_LINK_HINGES = ("hinge-left", "hinge-right")
#: mesh kinds made of straight lines x = const, y = const (strip-like rectangles)
LINED_KINDS = ("strip", "three-link")
BODY_NAME = {"strip": "strip", "three-link": "three-link body", "gmsh": "body"}
#: a straight line of a strip-like mesh, ``x=c`` or ``y=c`` (no spaces, c a finite number)
_LINE_RE = re.compile(r"^([xy])=([+-]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?)$")


def hinge_line(where: str) -> tuple[str, float] | None:
    """``("x", c)`` or ``("y", c)`` for a line selector ``"x=c"`` / ``"y=c"`` with c a
    finite number (``"y=0.5"``, ``"x=-1e-3"``); ``None`` for anything else."""
    match = _LINE_RE.match(where)
    if not match:
        return None
    c = float(match.group(2))
    return (match.group(1), c) if math.isfinite(c) else None


def region_names(scene: dict) -> list[str]:
    """The region names of a strip-like mesh: built-in (three-link) then [[mesh.regions]]."""
    builtin = list(THREE_LINK_REGIONS) if scene["mesh"]["kind"] == "three-link" else []
    return builtin + [r["name"] for r in scene["mesh"]["regions"]]


def check_region_ref(name: str, path: str, scene: dict) -> None:
    """For strip-like meshes, a part's region must be built in or one of [[mesh.regions]];
    ``"all"`` is the whole body."""
    if scene["mesh"]["kind"] not in LINED_KINDS:
        return  # gmsh: checked against the file's physical groups later
    names = region_names(scene)
    if name in names or name == "all":
        return
    if not names:
        raise SceneError(
            f"{path}: unknown region '{name}'; expected a name defined in "
            "[[mesh.regions]], but the scene defines none"
        )
    raise SceneError(
        f"{path}: unknown region '{name}'; expected one of: {', '.join(names)}"
        + suggest(name, names)
    )


def scene_selectors(scene: dict) -> list[str]:
    """The ``where`` selectors of a strip-like mesh: special ones, the three-link's hinge
    lines, the [[hinge]] lines, then region names."""
    valid = list(SPECIAL_SELECTORS)
    if scene["mesh"]["kind"] == "three-link":
        valid += THREE_LINK_HINGES
    valid += [h["where"] for h in scene["hinge"] if h["where"] not in valid]
    return valid + region_names(scene)


def check_where(value: str, path: str, scene: dict) -> None:
    if value in SPECIAL_SELECTORS or scene["mesh"]["kind"] not in LINED_KINDS:
        return
    valid = scene_selectors(scene)
    if value not in valid:
        raise SceneError(
            f"{path}: unknown selector '{value}'; expected one of: "
            f"{', '.join(valid)}" + suggest(value, valid)
        )


def check_on_body(point: Sequence[float], path: str, what: str, scene: dict) -> None:
    """A material point of a strip-like body (a probe, a point force) must lie on it,
    at z = 0; points of a gmsh body are checked on the mesh."""
    mesh = scene["mesh"]
    if mesh["kind"] not in LINED_KINDS:
        return
    length, width = mesh["length"], mesh["width"]
    tol = 1e-9 * length
    x, y, z = point
    if not (-tol <= x <= length + tol and -tol <= y <= width + tol and abs(z) <= tol):
        raise SceneError(
            f"{path}: {what} outside the body: expected a point on the "
            f"{BODY_NAME[mesh['kind']]} (0 <= x <= {fmt(length)}, "
            f"0 <= y <= {fmt(width)}, z = 0), found {fmt(point)}"
        )


# ------------------------------------------------------------------ on a mesh


def cells_of(body: Any, names: list[str], key: str = "region") -> np.ndarray:
    """Local cells of the named regions (``"all"``: every cell, unless a region has that
    name); an unknown name is a SceneError at ``key``."""
    if "all" in names and "all" not in body.regions:
        tdim = body.mesh.topology.dim
        imap = body.mesh.topology.index_map(tdim)
        return np.arange(imap.size_local + imap.num_ghosts, dtype=np.int32)
    for n in names:
        if n not in body.regions:
            known = ", ".join(sorted(body.regions)) or "none"
            raise SceneError(f"{key}: unknown region '{n}'; the mesh's regions are: {known}")
    tags = [t for n in names for t in body.regions[n]]
    ct = body.cell_tags
    return np.unique(ct.indices[np.isin(ct.values, tags)]).astype(np.int32)


def mesh_selectors(body: Any) -> list[str]:
    """Every selector of a built body."""
    return ["all", *EDGE_SELECTORS, *body.regions, *body.edges, *body.points]


def facets_of(body: Any, where: str, key: str, line: bool = False) -> np.ndarray:
    """Local facets selected by an edge selector or a named curve group; with
    ``line`` (hinges) also ``"x=c"`` / ``"y=c"``: the facets on that line."""
    from dolfinx import mesh as dmesh

    mesh = body.mesh
    tdim = mesh.topology.dim
    at_line = hinge_line(where) if line and where not in body.edges else None
    tol = 1e-8 * max(body.length, body.width)
    if at_line:
        axis, at = "xy".index(at_line[0]), at_line[1]
        facets = dmesh.locate_entities(mesh, tdim - 1, lambda x: np.abs(x[axis] - at) < tol)
        if mesh.comm.allreduce(len(facets)) == 0:
            raise SceneError(
                f"{key}: '{where}' is not a line of the mesh (no cell edge lies on it)"
            )
    elif where in EDGE_SELECTORS:
        axis = 0 if where[0] == "x" else 1
        at = 0.0 if where[2] == "0" else (body.length if axis == 0 else body.width)
        facets = dmesh.locate_entities_boundary(
            mesh, tdim - 1, lambda x: np.abs(x[axis] - at) < tol
        )
    elif where in body.edges:
        ft = body.facet_tags
        facets = ft.indices[np.isin(ft.values, body.edges[where])]
    elif where in body.regions or where == "all" or where in body.points:
        what = "a point" if where in body.points else "a surface region"
        raise SceneError(
            f"{key}: '{where}' is {what}; this needs an edge "
            f"({', '.join(EDGE_SELECTORS + tuple(body.edges))})"
        )
    else:
        raise SceneError(
            f"{key}: unknown selector '{where}'; expected one of {', '.join(mesh_selectors(body))}"
        )
    facets = np.unique(np.asarray(facets, dtype=np.int32))
    if mesh.comm.allreduce(len(facets)) == 0:
        raise SceneError(f"{key}: '{where}' selects no edge of the body")
    return facets


def vertices_of(body: Any, where: str, key: str) -> np.ndarray:
    """Local vertices at the coordinates of a named point group (a gmsh physical
    point); each of its points must be a vertex of the body."""
    from dolfinx import mesh as dmesh

    points = np.asarray(body.points[where], dtype=float).reshape(-1, 3)
    tol = 1e-8 * max(body.length, body.width, 1e-300)
    found = np.zeros(len(points), dtype=bool)

    def near(x):
        close = np.linalg.norm(x.T[:, None, :] - points[None, :, :], axis=2) < tol
        found[:] |= close.any(axis=0)
        return close.any(axis=1)

    vertices = dmesh.locate_entities(body.mesh, 0, near)
    everywhere = body.mesh.comm.allreduce(found.astype(int))
    missing = points[np.asarray(everywhere) == 0]
    if len(missing):
        raise SceneError(
            f"{key}: point '{where}' at {fmt(list(missing[0]))} is not a vertex of the body"
        )
    return np.unique(np.asarray(vertices, dtype=np.int32))


def entities_of(body: Any, where: str, key: str) -> tuple[int, np.ndarray]:
    """(dim, local entities) selected by any ``where`` selector: cells for "all" and
    regions, vertices for a named point, facets otherwise."""
    mesh = body.mesh
    tdim = mesh.topology.dim
    if where in body.points and where not in body.regions and where not in body.edges:
        return 0, vertices_of(body, where, key)
    if where == "all":
        n = mesh.topology.index_map(tdim).size_local + mesh.topology.index_map(tdim).num_ghosts
        return tdim, np.arange(n, dtype=np.int32)
    if where in body.regions:
        cells = cells_of(body, [where])
        if mesh.comm.allreduce(len(cells)) == 0:
            raise SceneError(f"{key}: region '{where}' selects no cell")
        return tdim, cells
    return tdim - 1, facets_of(body, where, key)


#: a point of a curved body may lie this share of a cell's size off the discrete
#: surface and still be on the body (an analytic point of a sphere lies off the
#: surface of a coarse mesh of it by about 1 % of a cell)
OFF_SURFACE = 0.05


def owned_cells(mesh: dolfinx.mesh.Mesh, points: np.ndarray) -> tuple[list, list[bool]]:
    """For each reference point (rows of ``points``): the one process that owns a
    cell containing it gets that local cell, the others None; and whether the point
    lies on the body at all (the same on every process).  A point within
    ``OFF_SURFACE`` of a cell's size of the discrete surface is on it: the cell
    nearest to it holds it (evaluation there takes the nearest point of the cell)."""
    from mpi4py import MPI

    from rftfem import compat

    comm = mesh.comm
    n_owned = mesh.topology.index_map(mesh.topology.dim).size_local
    found = compat.colliding_cells(mesh, points) if len(points) else []
    cells, on_body = [], []
    for i, candidates in enumerate(found):
        local = [c for c in candidates if c < n_owned]
        owner = comm.allreduce(comm.rank if local else comm.size, op=MPI.MIN)
        if owner == comm.size:  # off the discrete surface: the nearest cell, if near
            near, dist, size = compat.nearest_cells(mesh, points[i : i + 1])
            ok = near[0] >= 0 and near[0] < n_owned and dist[0] <= OFF_SURFACE * size[0]
            best = comm.allreduce((dist[0] if ok else np.inf, comm.rank), op=MPI.MIN)
            if np.isfinite(best[0]):
                owner, local = best[1], [int(near[0])] if best[1] == comm.rank else []
        cells.append(int(local[0]) if owner == comm.rank else None)
        on_body.append(owner < comm.size)
    return cells, on_body


def indicator(mesh: dolfinx.mesh.Mesh, cells: np.ndarray, name: str) -> dolfinx.fem.Function:
    """A DG0 Function, 1 on the given local cells and 0 elsewhere: a region in a form
    over the plain ``dx`` (one form may hold cell integrals of one tagging only)."""
    from dolfinx import fem

    from rftfem import compat

    V0 = compat.function_space(mesh, "DG", 0)
    chi = fem.Function(V0, name=name)
    chi.x.array[compat.cell_dofs(V0)[np.asarray(cells, dtype=np.int32), 0]] = 1.0
    chi.x.scatter_forward()
    return chi
