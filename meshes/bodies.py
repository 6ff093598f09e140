"""Several bodies in one mesh (a scene's ``[[body]]`` tables).

Each body is made from its own :class:`~.gmsh_session.Recipe` in a gmsh model of its
own, then turned and moved into place (``x ↦ R x + at``, ``R`` the turns about X,
then Y, then Z) and copied into one model as discrete entities: its nodes, its
elements and its physical groups, tags shifted past the bodies before it.  The
dolfinx mesh is then made from that model as from any other, so every effect sees
one body whose pieces do not touch.

Names are the body's own, prefixed: ``"NAME"`` is the whole body (a region),
``"NAME:REGION"`` its regions, ``"NAME:EDGE"`` its edges (a strip's ``x=0`` …
``y=W`` and hinge lines included), ``"NAME:POINT"`` a gmsh file's named points (at
their placed coordinates).  A proper rotation keeps each cell's normal as its own
mesh made it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from rftfem.errors import SceneError

from .gmsh_session import Recipe

if TYPE_CHECKING:
    from collections.abc import Sequence

#: gmsh's names of the surface cell types, for the refusal of mixed types
_CELLS = {2: "triangle", 3: "quadrilateral", 9: "6-node triangle", 10: "9-node quadrilateral"}
#: what separates a body's name from the names in its own mesh
SEPARATOR = ":"


def rotation(turn: Sequence[float]) -> np.ndarray:
    """``R = R_z R_y R_x`` for the turns ``[about X, about Y, about Z]`` in degrees
    (about the fixed axes: X first)."""
    ax, ay, az = (math.radians(float(a)) for a in turn)
    cx, sx, cy, sy, cz, sz = (
        math.cos(ax),
        math.sin(ax),
        math.cos(ay),
        math.sin(ay),
        math.cos(az),
        math.sin(az),
    )
    Rx = np.array([[1.0, 0.0, 0.0], [0.0, cx, -sx], [0.0, sx, cx]])
    Ry = np.array([[cy, 0.0, sy], [0.0, 1.0, 0.0], [-sy, 0.0, cy]])
    Rz = np.array([[cz, -sz, 0.0], [sz, cz, 0.0], [0.0, 0.0, 1.0]])
    return Rz @ Ry @ Rx


@dataclass
class Placed:
    """One body: its name, recipe, and placement (``at``, ``turn`` in degrees)."""

    name: str
    recipe: Recipe
    at: Sequence[float] = (0.0, 0.0, 0.0)
    turn: Sequence[float] = (0.0, 0.0, 0.0)

    def place(self, x: np.ndarray) -> np.ndarray:
        """Reference points ``(k, 3)`` of the body's own mesh, placed."""
        return np.asarray(x, dtype=float).reshape(-1, 3) @ rotation(self.turn).T + np.asarray(
            self.at, dtype=float
        )


class Reports:
    """The gmsh files' surface reports of several bodies, as one."""

    def __init__(self, reports: dict[str, object]):
        self.reports = reports

    @property
    def turned(self) -> int:
        """Cells turned in all the bodies."""
        return sum(r.turned for r in self.reports.values())

    def lines(self) -> list[str]:
        """Each body's lines, named."""
        return [f"{name}: {line}" for name, r in self.reports.items() for line in r.lines()]


def _copy_out(gmsh) -> tuple:
    """Rank 0: the current model's nodes (tags 1…n in order), surface and curve
    entities with their elements, and physical groups of dimension 1 and 2."""
    model = gmsh.model
    tags, coords, _ = model.mesh.getNodes()
    order = np.argsort(tags)
    renumber = {int(t): k + 1 for k, t in enumerate(np.asarray(tags)[order])}
    x = np.asarray(coords, dtype=float).reshape(-1, 3)[order]
    groups, entities = [], {}
    for dim, tag in model.getPhysicalGroups():
        if dim not in (1, 2):
            continue
        members = [int(e) for e in model.getEntitiesForPhysicalGroup(dim, tag)]
        for e in members:
            if (dim, e) not in entities:
                types, _, nodes = model.mesh.getElements(dim, e)
                entities[(dim, e)] = [
                    (int(t), np.array([renumber[int(n)] for n in ns], dtype=np.int64))
                    for t, ns in zip(types, nodes)
                ]
        groups.append((dim, int(tag), model.getPhysicalName(dim, tag), members))
    return x, entities, groups


def _cells(model, entities) -> list[tuple[np.ndarray, int]]:
    """A copied body's surface cells: blocks of (nodes per cell as rows, corners)."""
    out = []
    for (dim, _), blocks in entities.items():
        if dim != 2:
            continue
        for t, ns in blocks:
            properties = model.mesh.getElementProperties(t)
            out.append((ns.reshape(-1, properties[3]) - 1, int(properties[5])))  # 1-based
    return out


def _made_alone(gmsh: Any, body: Placed, alone: str, combined: str) -> tuple:
    """Rank 0: ``body``'s recipe prepared in a gmsh model ``alone`` of its own under its
    options, copied out (:func:`_copy_out`) and removed, ``combined`` current again and
    the options restored.  Returns ``(names, x, entities, groups)``, ``names`` the
    recipe's ``(regions, edges, points, report)``."""
    model = gmsh.model
    model.add(alone)
    options = body.recipe.options or {}
    saved = {key: gmsh.option.getNumber(key) for key in options}
    try:
        for key, value in options.items():
            gmsh.option.setNumber(key, value)
        own_regions, own_edges, own_points, report = body.recipe.prepare(gmsh)
        x, entities, groups = _copy_out(gmsh)
    finally:
        model.remove()
        for key, value in saved.items():
            gmsh.option.setNumber(key, value)
        model.setCurrent(combined)
    return (own_regions, own_edges, own_points, report), x, entities, groups


def _one_cell_type(k: int, entities: dict, cell_type: set[int] | None) -> set[int]:
    """The surface cell types of body ``k``'s ``entities``, refused unless they are
    ``cell_type``, body 0's (None for body 0 itself)."""
    types = {t for (dim, _), blocks in entities.items() if dim == 2 for t, _ in blocks}
    if cell_type is None:
        return types
    if types != cell_type:
        raise SceneError(
            f"body.{k}.mesh: its {', '.join(_CELLS.get(t, str(t)) for t in types)} "
            f"cells differ from body.0's "
            f"({', '.join(_CELLS.get(t, str(t)) for t in cell_type)}); "
            "every body needs one cell type"
        )
    return cell_type


def _copy_in(
    model: Any, body: Placed, x: np.ndarray, entities: dict, nodes: int, elements: int
) -> tuple[dict, tuple[np.ndarray, np.ndarray], int]:
    """Rank 0: a copied body's entities added to the current model as discrete ones,
    its nodes placed and numbered after ``nodes``, its elements after ``elements``.
    Returns the new entities (by the body's own), its surface samples
    (:func:`surface_samples`) and the number of elements now in the model."""
    new = {key: model.addDiscreteEntity(key[0]) for key in sorted(entities)}
    first = next(new[key] for key in sorted(entities) if key[0] == 2)
    placed = body.place(x)
    samples = surface_samples(placed, _cells(model, entities))
    model.mesh.addNodes(2, first, list(range(nodes + 1, nodes + len(x) + 1)), placed.ravel())
    for key, blocks in entities.items():
        for t, ns in blocks:
            count = len(ns) // model.mesh.getElementProperties(t)[3]
            tags = list(range(elements + 1, elements + count + 1))
            model.mesh.addElements(key[0], new[key], [t], [tags], [list(ns + nodes)])
            elements += count
    return new, samples, elements


def _add_groups(model: Any, name: str, groups: list, new: dict, shift: int) -> None:
    """Rank 0: a copied body's physical groups, tags shifted by ``shift``, on its new
    entities; the named ones prefixed with ``name``."""
    for dim, tag, label, members in groups:
        model.addPhysicalGroup(dim, [new[(dim, e)] for e in members], tag + shift)
        if label:
            model.setPhysicalName(dim, tag + shift, f"{name}{SEPARATOR}{label}")


def _prepare_bodies(gmsh: Any, bodies: Sequence[Placed]) -> tuple:
    """Rank 0: every body made alone and copied into the current model, then checked
    apart; returns the :class:`~.gmsh_session.Recipe`'s names of them all."""
    model = gmsh.model
    combined = model.getCurrent()
    regions: dict[str, list[int]] = {}
    edges: dict[str, list[int]] = {}
    points: dict[str, np.ndarray] = {}
    reports, cell_type, samples = {}, None, []
    nodes = elements = shift = 0
    for k, body in enumerate(bodies):
        made, x, entities, groups = _made_alone(gmsh, body, f"{combined}-{k}", combined)
        own_regions, own_edges, own_points, report = made
        cell_type = _one_cell_type(k, entities, cell_type)
        new, sample, elements = _copy_in(model, body, x, entities, nodes, elements)
        samples.append(sample)
        name = body.name
        _add_groups(model, name, groups, new, shift)
        regions[name] = [tag + shift for dim, tag, _, _ in groups if dim == 2]
        for names, own in ((regions, own_regions), (edges, own_edges)):
            for label, tags in own.items():
                names[f"{name}{SEPARATOR}{label}"] = [t + shift for t in tags]
        for label, at in own_points.items():
            points[f"{name}{SEPARATOR}{label}"] = body.place(at)
        if report is not None:
            reports[name] = report
        nodes += len(x)
        shift += max([tag for _, tag, _, _ in groups], default=0)
    check_apart(bodies, samples)
    return regions, edges, points, Reports(reports) if reports else None


def bodies_recipe(bodies: Sequence[Placed]) -> Recipe:
    """The :class:`~.gmsh_session.Recipe` of several placed bodies in one mesh."""

    def prepare(gmsh: Any) -> tuple:
        return _prepare_bodies(gmsh, bodies)

    # a body's built-in hinge lines are named edges ("NAME:hinge-left"); the scene
    # gives them as [[hinge]] entries (rftfem.scene.bodies), so none is built in here
    return Recipe(prepare)


def surface_samples(
    x: np.ndarray, cells: Sequence[tuple[np.ndarray, int]]
) -> tuple[np.ndarray, np.ndarray]:
    """Points spread over a body's cells, for telling how close two bodies are: every
    node, and a 4 × 4 grid in each cell (bilinear in a quadrilateral's corners, the
    grid's part inside a triangle), with the spacing they stand for (each cell's
    longest side over 4).  ``cells``: blocks of (nodes per cell as rows, corners)."""
    points, spacing = [x], [np.full(len(x), np.inf)]
    grid = (np.arange(4) + 0.5) / 4.0
    u, v = (a.ravel() for a in np.meshgrid(grid, grid))
    for rows, corners in cells:
        c = x[rows[:, :corners]]  # cells × corners × 3
        sides = np.linalg.norm(c - np.roll(c, -1, axis=1), axis=2).max(axis=1)
        if corners == 4:
            w = np.stack([(1 - u) * (1 - v), u * (1 - v), u * v, (1 - u) * v], axis=1)
        else:  # a triangle
            inside = u + v < 1.0
            w = np.stack([1 - u[inside] - v[inside], u[inside], v[inside]], axis=1)
        points.append(np.einsum("pk,ckd->cpd", w, c).reshape(-1, 3))
        spacing.append(np.repeat(sides / 4.0, len(w)))
    spacing = np.concatenate(spacing)
    points = np.concatenate(points)
    # a node stands for the finest cell around it
    finite = np.isfinite(spacing)
    spacing[~finite] = spacing[finite].min() if finite.any() else 0.0
    return points, spacing


def check_apart(bodies: Sequence[Placed], samples: Sequence[tuple[np.ndarray, np.ndarray]]) -> None:
    """Refuse bodies that overlap where they start: two of their surface samples
    (:func:`surface_samples`) closer than the spacing either stands for, which two
    surfaces that cross or coincide always have; surfaces merely close (two strips
    side by side, a fraction of a cell apart) pass."""
    from scipy.spatial import cKDTree

    trees = [cKDTree(points) for points, _ in samples]
    for j in range(1, len(bodies)):
        for i in range(j):
            gap, nearest = trees[i].query(samples[j][0], k=1)
            reach = np.maximum(samples[j][1], samples[i][1][nearest])
            k = int(np.argmin(gap - reach))
            if gap[k] < reach[k]:
                at = ", ".join(f"{c:.4g}" for c in samples[j][0][k])
                raise SceneError(
                    f"body.{j}.at: body '{bodies[j].name}' overlaps body '{bodies[i].name}' "
                    f"where they start (their surfaces meet near ({at}): {gap[k]:.3g} "
                    f"apart, within a quarter cell {reach[k]:.3g}); move or turn it, or "
                    "refine the cells there"
                )
