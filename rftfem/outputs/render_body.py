"""The body as drawn: its surface and its cells' edges, curved as the fields are.

A run writes its fields on second-order cells (9-node quadrilaterals, 6-node
triangles; see :mod:`rftfem.outputs.field_mesh`).  A renderer that draws each cell as one
flat facet through its corners would show a rolled strip as a polygon, so here

- the surface is the cells cut into ``2**level`` pieces per edge by VTK's
  nonlinear subdivision, points and colours placed by the cells' own quadratic
  shape functions;
- the cells' edges (``show_edges`` would draw the pieces' edges too) and the
  body's outline are polylines through ``EDGE_POINTS`` points per edge, each a
  fixed combination of the edge's two or three nodes: a matrix computed once.

Linear cells (results of an older rftfem) are drawn as they are.

Imports pyvista (never dolfinx; see :mod:`rftfem.outputs.compat_render`).
"""

from __future__ import annotations

import numpy as np

from rftfem.outputs.compat_render import import_pyvista, tessellate

pv = import_pyvista()

#: subdivision level of the surface: 2**LEVEL pieces along each cell edge
LEVEL = 3
#: points per drawn cell edge
EDGE_POINTS = 9

#: VTK cell type -> its edges as (corner, corner[, midside node]) in VTK's node order
_EDGES = {
    9: ((0, 1), (1, 2), (2, 3), (3, 0)),  # quad
    5: ((0, 1), (1, 2), (2, 0)),  # triangle
    28: ((0, 1, 4), (1, 2, 5), (2, 3, 6), (3, 0, 7)),  # biquadratic quad
    23: ((0, 1, 4), (1, 2, 5), (2, 3, 6), (3, 0, 7)),  # quadratic quad
    22: ((0, 1, 3), (1, 2, 4), (2, 0, 5)),  # quadratic triangle
}


def _edge_weights(edges: list[tuple[int, ...]], k: int) -> tuple[np.ndarray, np.ndarray]:
    """Nodes (m, 3) and weights (m, 3) placing ``k`` points along each edge by its
    Lagrange shape functions (linear through two nodes, quadratic through three);
    point i is ``sum_j weights[i, j] * x[nodes[i, j]]``."""
    s = np.linspace(0.0, 1.0, k)
    shapes = {
        2: np.stack([1 - s, s, 0 * s], axis=1),
        3: np.stack([(1 - s) * (1 - 2 * s), s * (2 * s - 1), 4 * s * (1 - s)], axis=1),
    }
    nodes = np.zeros((len(edges) * k, 3), dtype=np.int64)
    weights = np.zeros((len(edges) * k, 3))
    for e, ids in enumerate(edges):
        nodes[e * k : (e + 1) * k] = (list(ids) + [ids[0]])[:3]
        weights[e * k : (e + 1) * k] = shapes[len(ids)]
    return nodes, weights


def _polylines(n_edges: int, k: int) -> pv.PolyData:
    lines = (
        np.hstack([np.r_[k, e * k + np.arange(k)] for e in range(n_edges)])
        if n_edges
        else np.zeros(0, dtype=int)
    )
    return pv.PolyData(np.zeros((n_edges * k, 3)), lines=lines)


class BodyDrawing:
    """Surface, cell edges and outline of the body for given nodal displacements."""

    def __init__(self, reference: pv.UnstructuredGrid):
        self.grid = reference.copy()
        self.grid.clear_data()
        self.reference_points = np.array(reference.points, dtype=float)
        types = np.asarray(reference.celltypes)
        self.level = 0 if set(types.tolist()) <= {5, 9} else LEVEL
        count: dict[tuple[int, int], list] = {}
        for c, t in enumerate(types):
            nodes = reference.get_cell(c).point_ids
            for edge in _EDGES[int(t)]:
                ids = tuple(nodes[i] for i in edge)
                count.setdefault(tuple(sorted(ids[:2])), [ids, 0])[1] += 1
        every = [ids for ids, _ in count.values()]
        boundary = [ids for ids, n in count.values() if n == 1]
        k = EDGE_POINTS if self.level else 2
        self._edges = (*_edge_weights(every, k), _polylines(len(every), k))
        self._outline = (*_edge_weights(boundary, k), _polylines(len(boundary), k))

    def surface(self, displacement: np.ndarray, data: dict | None = None) -> pv.PolyData:
        """The deformed surface, with point ``data`` (arrays at the nodes) carried along."""
        self.grid.points = self.reference_points + displacement
        for name, values in (data or {}).items():
            self.grid.point_data[name] = values
        return tessellate(self.grid, self.level)

    def edges(self, displacement: np.ndarray) -> pv.PolyData:
        """The cells' edges as curved polylines (the same PolyData, moved, at each call)."""
        return self._moved(self._edges, displacement)

    def outline(self, displacement: np.ndarray) -> pv.PolyData:
        """The body's boundary edges."""
        return self._moved(self._outline, displacement)

    def _moved(self, edges, displacement) -> pv.PolyData:
        nodes, weights, lines = edges
        x = self.reference_points + displacement
        lines.points = np.einsum("ij,ijk->ik", weights, x[nodes])
        return lines
