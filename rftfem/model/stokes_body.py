"""The body as the Stokes operators see it: its elements in the global node numbering
(every process holds them all, in rank order), each node's spacing, and the set-up's
checks of the body against its blobs and the wall (docs/stokes.md).

This is the dolfinx side of the Stokes flow (imported inside the functions: the
scene's keys, and `rftfem render`, import the effects without dolfinx);
``stokeslets``, ``stokes_layer`` and ``stokes_fmm`` work on plain arrays.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from rftfem.errors import SceneError

if TYPE_CHECKING:
    from rftfem.model.shell_model import Model
    from rftfem.model.stokeslets import Wall

#: the closest gap between body and wall, in blobs, under which a run is refused, and
#: under which it is warned of (the wall's images are singular, the body's own
#: Stokeslets regularized: the no-slip error on the wall is e^(−(gap/δ)²))
WALL_GAP_REFUSED, WALL_GAP_WARNED = 1.0, 2.5


def point_text(x: np.ndarray) -> str:
    """A node's position as a message gives it."""
    return "(" + ", ".join(f"{v:.4g}" for v in x) + ")"


def check_blob_size(delta: np.ndarray, extent: float) -> None:
    """Refuse blobs of half the body's diagonal ``extent`` or more."""
    largest = float(delta.max())
    if largest >= 0.5 * extent:
        raise SceneError(
            f"fluid.regularization: the blob ({largest:.4g}) is larger than "
            f"the body (its diagonal is {extent:.4g}); give a blob of about "
            "the node spacing, or leave the key out"
        )


def wall_gap(wall: Wall, X: np.ndarray, delta: np.ndarray, scene: dict) -> float:
    """The closest gap between the body at ``X`` and the wall, in blobs ``delta``, with
    the scene's prescribed motions' reach towards the wall taken off; a body on or
    behind the plane, or closer than WALL_GAP_REFUSED blobs, is refused."""
    heights = wall.heights(X)
    behind = int(np.sum(heights <= 0.0))
    if behind:
        raise SceneError(
            f"fluid.wall: the body crosses the wall: {behind} of its "
            f"{len(heights)} nodes are on or behind the plane (lowest at "
            f"{heights.min():.4g} along the normal); the normal points "
            "towards the body's side"
        )
    from rftfem.model.effects import motion

    reach = motion.reach(scene, wall.Q[2])
    gaps = (heights - reach) / delta
    gap = float(np.min(gaps))
    if gap < WALL_GAP_REFUSED:
        i = int(np.argmin(gaps))
        raise SceneError(
            f"fluid.wall: the body comes within {gap:.3g} blobs of the wall "
            f"(at the node {point_text(X[i])}, {heights[i]:.4g} above it"
            + (f", {reach:.4g} of which the motions take" if reach else "")
            + f", blob {delta[i]:.3g}); the wall's images need "
            f"{WALL_GAP_WARNED} blobs: move the wall away or refine the mesh"
        )
    return gap


def global_cells(model: Model) -> tuple[np.ndarray, str]:
    """Every element's displacement nodes in the global (rank-ordered) numbering, the
    reference element's order, gathered on every process; and the cell kind
    ("quadrilateral" or "triangle")."""
    from dolfinx import mesh as dmesh

    from rftfem import compat

    msh = model.mesh
    n_cells = msh.topology.index_map(msh.topology.dim).size_local
    local = compat.cell_dofs(model.Vu)[:n_cells]
    im = model.Vu.dofmap.index_map
    owned = compat.local_to_global(im, local.ravel()).reshape(local.shape)
    cells = np.concatenate(model.comm.allgather(np.ascontiguousarray(owned)))
    quad = msh.topology.cell_type == dmesh.CellType.quadrilateral
    return cells, "quadrilateral" if quad else "triangle"


def node_spacing(model: Model) -> np.ndarray:
    """Each local node's spacing: the mean over the cells around it of the cell's size
    over 2 (√area on quadrilaterals, the equilateral side on triangles), halved on
    the body's free edges."""
    import ufl
    from dolfinx import fem
    from dolfinx import mesh as dmesh

    from rftfem import compat

    msh = model.mesh
    V0 = compat.function_space(msh, "DG", 0)
    area = fem.assemble_vector(model.compile(ufl.TestFunction(V0) * model.dx)).array
    triangle = msh.topology.cell_type == dmesh.CellType.triangle
    size = np.sqrt(area * (4.0 / np.sqrt(3.0) if triangle else 1.0)) / 2.0
    V = compat.function_space(msh, "Lagrange", 2)
    total, count = (fem.Function(V) for _ in range(2))
    cells = compat.cell_dofs(V)
    n_cells = msh.topology.index_map(msh.topology.dim).size_local
    np.add.at(total.x.array, cells[:n_cells], size[:n_cells, None])
    np.add.at(count.x.array, cells[:n_cells], 1.0)
    for f in (total, count):
        compat.scatter_add(f)
    spacing = total.x.array / np.maximum(count.x.array, 1.0)
    fdim = msh.topology.dim - 1
    msh.topology.create_connectivity(fdim, msh.topology.dim)
    edge = fem.locate_dofs_topological(V, fdim, dmesh.exterior_facet_indices(msh.topology))
    spacing[edge] *= 0.5
    return spacing


def free_edge_warnings(cell: str, cells: np.ndarray) -> list[str]:
    """The layer's warning for a body of triangles with free edges (``cells``: the
    elements' nodes, corners first)."""
    if cell != "triangle" or not has_free_edges(cells[:, :3]):
        return []
    return [
        "fluid: the body is meshed with triangles and has free edges, where the layer "
        "carries no edge weight in this version: expect first order there "
        "(docs/stokes.md §Free edges); mesh it with quadrilaterals, or refine towards "
        "the edges"
    ]


def has_free_edges(corners: np.ndarray) -> bool:
    """Whether the triangles ``corners`` (C, 3) have a side that only one of them holds."""
    sides = np.sort(
        np.concatenate([corners[:, [0, 1]], corners[:, [1, 2]], corners[:, [2, 0]]]), axis=1
    )
    _, counts = np.unique(sides, axis=0, return_counts=True)
    return bool((counts == 1).any())


class Crossed:
    """The resistance of a body that has crossed the wall: NaN forces."""

    def __init__(self, x: np.ndarray):
        self.x = np.array(x)

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        return np.full(np.shape(rhs), np.nan)

    def lumped(self) -> np.ndarray:
        return np.zeros((len(self.x), 3, 3))
