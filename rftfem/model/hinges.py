"""Jointed bodies: hinge lines, the panels they cut, and the panels' colours.

A hinge is a line of the mesh (a set of interior facets).  The hinge lines cut
the body into *panels*: sets of cells connected across facets that are not on
a hinge.  Panels are coloured so that two panels that touch (along a hinge or
at a single point) have different colours; each colour gets its own rotation
field and nodal triad in the model (``forms/hinge.py``), so the director may
jump across a hinge while the displacement, one continuous field, may not.

Everything here is collective and independent of the ghost mode of the mesh:
panels are found by propagating the smallest global cell index through the
facet degrees of freedom of a scalar P2 space (each facet has exactly one),
whose values are shared between processes by the usual ghost updates.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import ufl
from dolfinx import fem
from dolfinx import mesh as dmesh
from petsc4py import PETSc

from rftfem import compat
from rftfem.errors import SceneError
from rftfem.scene.selectors import facets_of

if TYPE_CHECKING:
    from rftfem.model.shell_model import Model


@dataclass
class Hinge:
    """One hinge line: its scene key, its ``where`` selector, its spring
    stiffness (per unit length, 0 for a free hinge) and its local facets."""

    key: str
    where: str
    stiffness: float
    facets: np.ndarray


def hinge_specs(scene: dict, body: Any) -> list[tuple[str, str, float]]:
    """``(key, where, stiffness)`` of every hinge: the mesh kind's own lines
    (three-link: ``mesh.hinge_stiffness``) first, then the ``[[hinge]]`` tables."""
    own = getattr(body, "hinges", []) or []
    k_own = scene["mesh"].get("hinge_stiffness") or 0.0
    specs = [("mesh.kind", name, float(k_own)) for name in own]
    specs += [
        (f"hinge.{i}.where", h["where"], float(h["stiffness"]))
        for i, h in enumerate(scene.get("hinge") or [])
    ]
    return specs


def resolve(model: Model, scene: dict) -> list[Hinge]:
    """The scene's hinges with their facets; a line on the boundary of the body,
    or two hinges on one line, is a SceneError at the hinge's key."""
    mesh = model.mesh
    tdim = mesh.topology.dim
    mesh.topology.create_connectivity(tdim - 1, tdim)
    boundary = dmesh.exterior_facet_indices(mesh.topology)
    hinges, owner = [], {}
    for key, where, k in hinge_specs(scene, model.body):
        facets = facets_of(model.body, where, key, line=True)
        on_boundary = model.comm.allreduce(int(np.isin(facets, boundary).sum()))
        if on_boundary:
            raise SceneError(
                f"{key}: '{where}' lies on the body's boundary ({on_boundary} "
                "edges); a hinge joins two sides, so it must be an interior line"
            )
        for other_key, other in owner.items():
            if model.comm.allreduce(int(np.isin(facets, other).sum())):
                raise SceneError(
                    f"{key}: two hinges on one line ('{where}' and {other_key}); "
                    "give each line one hinge"
                )
        owner[key] = facets
        hinges.append(Hinge(key, where, k, facets))
    return hinges


def _facet_dofs(V) -> np.ndarray:
    """(cells, facets per cell) table of the one dof of each facet of a scalar P2 space."""
    layout = V.dofmap.dof_layout
    cells = compat.cell_dofs(V)
    tdim = V.mesh.topology.dim
    n_facets = 3 if V.mesh.topology.cell_type == dmesh.CellType.triangle else 4
    local = [layout.entity_dofs(tdim - 1, i) for i in range(n_facets)]
    assert all(len(d) == 1 for d in local), "P2 has one dof per facet"
    return cells[:, [d[0] for d in local]]


def panel_labels(mesh: dmesh.Mesh, hinge_facets: np.ndarray) -> np.ndarray:
    """Per local cell (owned and ghost), the smallest global index of a cell of its
    panel: cells connected across facets that are not in ``hinge_facets``."""
    tdim = mesh.topology.dim
    V = compat.function_space(mesh, "Lagrange", 2)
    mesh.topology.create_connectivity(tdim, tdim - 1)
    c2f = mesh.topology.connectivity(tdim, tdim - 1)
    cell_map = mesh.topology.index_map(tdim)
    n_cells = cell_map.size_local + cell_map.num_ghosts
    facet_dofs = _facet_dofs(V)[:n_cells]
    facets = np.asarray(c2f.array, dtype=np.int64).reshape(n_cells, -1)
    open_ = ~np.isin(facets, hinge_facets)  # (cell, local facet) not on a hinge

    label = np.asarray(
        cell_map.local_to_global(np.arange(n_cells, dtype=np.int32)), dtype=np.float64
    )
    # the panels of this process's own cells, found at once (a label spreads one cell
    # per exchange below: a 4000-cell-long panel took 4000 of them, 20 s); the
    # exchanges then only carry labels across process boundaries
    root = _local_components(n_cells, facets, open_)
    f = fem.Function(V)
    vec = compat.petsc_vec(f)
    big = float(cell_map.size_global)
    while True:
        # cells -> facet dofs (the smallest label of the open facets' cells)
        f.x.array[:] = -big
        cols, rows = np.nonzero(open_.T)
        np.maximum.at(f.x.array, facet_dofs[rows, cols], -label[rows])
        # every process's copy of a dof gets the largest -label (smallest label)
        vec.ghostUpdate(addv=PETSc.InsertMode.MAX_VALUES, mode=PETSc.ScatterMode.REVERSE)
        vec.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        # facet dofs -> cells
        through = np.where(open_, -f.x.array[facet_dofs], big)
        new = np.minimum(label, through.min(axis=1))
        smallest = np.full(n_cells, big)
        np.minimum.at(smallest, root, new)
        new = smallest[root]
        changed = int((new < label).sum())
        label = new
        if mesh.comm.allreduce(changed) == 0:
            return label.astype(np.int64)


def _local_components(n_cells: int, facets: np.ndarray, open_: np.ndarray) -> np.ndarray:
    """For each local cell, the smallest local cell of its panel within this process
    (cells joined by a shared facet that is open), by hooking and pointer jumping."""
    cells, slots = np.nonzero(open_)
    ids = facets[cells, slots]
    order = np.argsort(ids, kind="stable")
    ids, cells = ids[order], cells[order]
    pair = ids[1:] == ids[:-1]  # a facet shared by two local cells
    a, b = cells[:-1][pair], cells[1:][pair]
    parent = np.arange(n_cells)
    while True:
        pa, pb = parent[a], parent[b]
        if (pa == pb).all():
            return parent
        np.minimum.at(parent, np.maximum(pa, pb), np.minimum(pa, pb))
        while True:  # point every cell at its root
            up = parent[parent]
            if (up == parent).all():
                break
            parent = up


def colour_panels(
    mesh: dmesh.Mesh, label: np.ndarray, hinge_facets: np.ndarray, hinges: list[Hinge]
) -> tuple[np.ndarray, int]:
    """Colour the panels (greedy, in order of their labels, the same on every
    process) so that panels sharing a point differ.  Returns the colour of every
    local cell and the number of colours.  A hinge whose two sides are one panel
    (a line that does not cut the body) is a SceneError at its key."""
    tdim = mesh.topology.dim
    V = compat.function_space(mesh, "Lagrange", 2)
    dofs = compat.cell_dofs(V)[: len(label)]
    imap = V.dofmap.index_map
    # the dofs on the hinge lines (their facets' and vertices' dofs)
    on_line = np.zeros(imap.size_local + imap.num_ghosts, dtype=bool)
    line_dofs = fem.locate_dofs_topological(V, tdim - 1, hinge_facets)
    on_line[np.asarray(line_dofs)] = True
    cells, slots = np.nonzero(on_line[dofs])
    local = np.asarray(dofs[cells, slots], dtype=np.int32)
    pairs = np.column_stack([imap.local_to_global(local), label[cells]]).astype(np.int64)
    pairs = np.unique(pairs, axis=0) if len(pairs) else pairs.reshape(0, 2)
    every = np.concatenate(mesh.comm.allgather(pairs)) if mesh.comm.size > 1 else pairs
    every = np.unique(every, axis=0)

    touching: dict[int, set[int]] = {}
    for dof, panel in every:
        touching.setdefault(int(dof), set()).add(int(panel))
    # each hinge's facet dofs must see two panels
    facet_dof_of = _facet_dofs(V)[: len(label)]
    mesh.topology.create_connectivity(tdim, tdim - 1)
    c2f = np.asarray(mesh.topology.connectivity(tdim, tdim - 1).array).reshape(len(label), -1)
    for hinge in hinges:
        c, s = np.nonzero(np.isin(c2f, hinge.facets))
        glob = imap.local_to_global(np.asarray(facet_dof_of[c, s], dtype=np.int32))
        single = int(sum(len(touching.get(int(g), ())) < 2 for g in np.unique(glob)))
        if mesh.comm.allreduce(single):
            raise SceneError(
                f"{hinge.key}: '{hinge.where}' does not cut the body into two "
                "panels (the sides are joined around the line's end); a hinge "
                "line must run from edge to edge or close on itself"
            )

    neighbours: dict[int, set[int]] = {p: set() for s in touching.values() for p in s}
    for panels in touching.values():
        for p in panels:
            neighbours[p] |= panels - {p}
    colour_of: dict[int, int] = {}
    for p in sorted(neighbours):
        used = {colour_of[q] for q in neighbours[p] if q in colour_of}
        colour_of[p] = next(c for c in range(len(used) + 1) if c not in used)
    colours = np.array([colour_of.get(int(p), 0) for p in label], dtype=np.int32)
    n = max(colour_of.values(), default=0) + 1
    return colours, n


def indicators(mesh: dmesh.Mesh, colours: np.ndarray, n: int) -> list:
    """DG0 indicator functions ``χ_c`` (1 on the cells of colour c)."""
    V0 = compat.function_space(mesh, "DG", 0)
    cell_dof = compat.cell_dofs(V0)[: len(colours), 0]
    out = []
    for c in range(n):
        chi = fem.Function(V0, name=f"colour_{c}")
        chi.x.array[cell_dof] = (colours == c).astype(float)
        out.append(chi)
    return out


def facet_measure(mesh: dmesh.Mesh, hinges: list[Hinge]) -> ufl.Measure:
    """``dS`` over the hinge lines, hinge ``i`` tagged ``i + 1``."""
    tdim = mesh.topology.dim
    facets = np.concatenate([h.facets for h in hinges]).astype(np.int32)
    tags = np.concatenate([np.full(len(h.facets), i + 1) for i, h in enumerate(hinges)])
    ft = compat.create_meshtags(mesh, tdim - 1, facets, tags)
    return ufl.Measure("dS", domain=mesh, subdomain_data=ft, metadata={"quadrature_degree": 4})


def cells_of_colour(colours: np.ndarray, c: int) -> np.ndarray:
    return np.nonzero(colours == c)[0].astype(np.int32)


def entities_of_colour(model: Model, dim: int, entities: np.ndarray, c: int) -> np.ndarray:
    """The cells (``dim`` = tdim) of colour ``c`` among ``entities``, or the facets
    (vertices) among them that touch a local cell of colour ``c``."""
    if model.n_colours == 1:
        return entities
    tdim = model.mesh.topology.dim
    if dim == tdim:
        return entities[model.colours[entities] == c]
    model.mesh.topology.create_connectivity(dim, tdim)
    f2c = model.mesh.topology.connectivity(dim, tdim)
    return np.asarray(
        [f for f in entities if (model.colours[f2c.links(f)] == c).any()], dtype=np.int32
    )


def inactive_rotation_bcs(model: Model) -> list:
    """θ_c = 0 away from the cells of colour c: there it does not enter any form."""
    if model.n_colours == 1:
        return []
    tdim = model.mesh.topology.dim
    bcs = []
    for c in range(model.n_colours):
        for i in range(2):
            sub = model.rotation_space(c, i)
            V, zero = model.dirichlet.space(sub, f"theta{i + 1}_{c}")
            own = fem.locate_dofs_topological((sub, V), tdim, cells_of_colour(model.colours, c))
            other = fem.locate_dofs_topological(
                (sub, V), tdim, np.nonzero(model.colours != c)[0].astype(np.int32)
            )
            keep = ~np.isin(other[0], own[0])
            dofs = [np.asarray(other[0])[keep], np.asarray(other[1])[keep]]
            bcs.append(fem.dirichletbc(zero, dofs, sub))
    return bcs


def colouring(mesh: dmesh.Mesh, lines: list[Hinge]) -> tuple:
    """The hinge ``lines`` cut the body into panels; panels that touch get different
    colours, each with its own rotation field and triad (forms/hinge.py).  Returns
    ``(colours, n_colours, indicators)``: the cells' colours (None without hinges), their
    number, and χ_c, 1 on the cells of colour c (DG0; None for one colour)."""
    if not lines:
        return None, 1, None
    cut = np.unique(np.concatenate([h.facets for h in lines]))
    colours, n = colour_panels(mesh, panel_labels(mesh, cut), cut, lines)
    return colours, n, indicators(mesh, colours, n) if n > 1 else None
