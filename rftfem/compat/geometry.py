"""Points on a mesh: the cells that contain them, the nearest cells."""

from __future__ import annotations

import dolfinx
import dolfinx.geometry
import dolfinx.mesh
import numpy as np

from rftfem.compat.spaces import geometry_cells


def colliding_cells(mesh: dolfinx.mesh.Mesh, points: np.ndarray) -> list[np.ndarray]:
    """For each row of ``points`` (N, 3): the local cells that contain it."""
    tdim = mesh.topology.dim
    geom = dolfinx.geometry
    if hasattr(geom, "bb_tree"):
        tree = geom.bb_tree(mesh, tdim)
        candidates = geom.compute_collisions_points(tree, points)
    else:
        tree = geom.BoundingBoxTree(mesh, tdim)
        candidates = geom.compute_collisions(tree, points)
    cells = geom.compute_colliding_cells(mesh, candidates, points)
    return [np.asarray(cells.links(i)) for i in range(points.shape[0])]


def nearest_cells(
    mesh: dolfinx.mesh.Mesh, points: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For each row of ``points``: the local cell nearest to it (among the cells of its
    nearest geometry node), the distance to that cell and the cell's size (its largest
    node-to-node distance); -1, inf, 0 on a process without cells."""
    x = mesh.geometry.x
    cells, _ = geometry_cells(mesh)
    n = len(points)
    out = (np.full(n, -1, dtype=np.int32), np.full(n, np.inf), np.zeros(n))
    if len(cells) == 0:
        return out
    for i, p in enumerate(points):
        node = int(np.argmin(np.linalg.norm(x - p, axis=1)))
        near = np.flatnonzero((cells == node).any(axis=1)).astype(np.int32)
        d2 = dolfinx.geometry.squared_distance(
            mesh, mesh.topology.dim, near, np.tile(p, (len(near), 1))
        )
        k = int(np.argmin(d2))
        corners = x[cells[near[k]]]
        out[0][i], out[1][i] = near[k], float(np.sqrt(max(d2[k], 0.0)))
        out[2][i] = float(np.max(np.linalg.norm(corners[:, None] - corners[None], axis=2)))
    return out
