"""Checks of a surface mesh as it is read (docs/scenes.md, "Meshes from gmsh").

Pure numpy on the file's cells, before dolfinx sees them:

- cells of zero or nearly zero area, and cells turned inside out (the normal of the
  geometry map changes side within the cell), are refused;
- nodes that coincide but are not merged (two cells that look joined and are not)
  are refused;
- cells that face the other way from their neighbours are turned to face as the
  majority of their piece does; a surface that cannot be oriented (a Möbius band)
  is refused;
- the pieces (cells joined through shared nodes), the free edges and what was turned
  are reported, for ``rftfem check`` and the run's log.

The shell's reference normal is the cell's ``G₁ × G₂``, so every cell of a piece must
face the same side for its director field to be continuous; which side is the
file's choice, kept where the cells agree.  Refusals raise ``ValueError`` with one
line naming the cell or node and where it is; the reader turns it into the scene's
``mesh.file`` error.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

#: corners of each gmsh surface element type, and the node order of the same cell
#: facing the other way (corners reversed, edge nodes along the reversed edges)
CORNERS = {2: 3, 3: 4, 9: 3, 10: 4}
REVERSED = {2: [0, 2, 1], 3: [0, 3, 2, 1], 9: [0, 2, 1, 5, 4, 3], 10: [0, 3, 2, 1, 7, 6, 5, 4, 8]}
NAMES = {
    2: "3-node triangles",
    3: "4-node quadrilaterals",
    9: "6-node triangles",
    10: "9-node quadrilaterals",
}

#: a cell whose area at a quadrature point is below this fraction of the square of
#: its longest corner-to-corner distance is degenerate
AREA_FLOOR = 1e-8
#: nodes closer than this fraction of the shortest cell edge coincide
COINCIDENT = 1e-6


@dataclass
class SurfaceReport:
    """What the checks found, in the file's terms."""

    cells: dict[str, int] = field(default_factory=dict)  # type name -> count
    turned: int = 0  # cells turned to face as their neighbours
    free_edges: int = 0  # edges with one cell (0: a closed surface)
    pieces: list[int] = field(default_factory=list)  # cells of each piece, largest first
    non_manifold_edges: int = 0  # edges shared by three or more cells

    def lines(self) -> list[str]:
        """The report as ``rftfem check`` prints it."""
        cells = ", ".join(f"{n} {name}" for name, n in self.cells.items())
        orientation = (
            "consistent"
            if not self.turned
            else f"{self.turned} cell(s) turned to face as their neighbours"
        )
        closed = (
            "closed (no free edge)"
            if not self.free_edges
            else f"open ({self.free_edges} free edges)"
        )
        pieces = (
            f"{len(self.pieces)} piece"
            if len(self.pieces) == 1
            else f"{len(self.pieces)} pieces of " + ", ".join(map(str, self.pieces)) + " cells"
        )
        out = [f"mesh: {cells}", f"mesh: orientation {orientation}", f"mesh: {closed}, {pieces}"]
        if self.non_manifold_edges:
            out.append(f"mesh: {self.non_manifold_edges} edges shared by three or more cells")
        return out


def _where(x) -> str:
    return "(" + ", ".join(f"{v:.6g}" for v in x) + ")"


def check_surface(
    cell_type: int,
    cells: np.ndarray,
    x: np.ndarray,
    grads: np.ndarray,
    tags: np.ndarray | None = None,
) -> tuple[np.ndarray, SurfaceReport]:
    """Check the cells and orient them consistently.

    ``cells``: (n, k) node indices into ``x`` (m, 3), in gmsh's node order for
    ``cell_type``; ``grads``: (q, k, 2) gradients of the element's shape functions at
    q points of the reference cell; ``tags``: the cells' element tags, for messages.
    Returns ``(turn, report)``: ``turn`` is a boolean mask of the cells to turn
    (their nodes to reorder by ``REVERSED[cell_type]``).  Raises ``ValueError``.
    """
    cells = np.asarray(cells, dtype=np.int64)
    n = len(cells)
    tags = np.arange(1, n + 1) if tags is None else np.asarray(tags)
    report = SurfaceReport(cells={NAMES[cell_type]: n})
    if n == 0:
        return np.zeros(0, dtype=bool), report
    c = CORNERS[cell_type]
    corners = cells[:, :c]

    # edges of the corners, each once per cell with its direction
    a, b = corners, np.roll(corners, -1, axis=1)
    lo, hi = np.minimum(a, b).ravel(), np.maximum(a, b).ravel()
    forward = (a < b).ravel()
    owner = np.repeat(np.arange(n), c)
    lengths = np.linalg.norm(x[a] - x[b], axis=2)
    size = lengths.max(axis=1)

    _check_cells(cell_type, cells, x, grads, size, tags)
    used = np.unique(cells)
    _check_coincident(x, used, lengths[lengths > 0].min() if np.any(lengths > 0) else 1.0)

    key = lo * (int(x.shape[0]) + 1) + hi
    order = np.argsort(key, kind="stable")
    key_sorted = key[order]
    starts = np.flatnonzero(np.r_[True, key_sorted[1:] != key_sorted[:-1]])
    counts = np.diff(np.r_[starts, len(key_sorted)])
    report.free_edges = int(np.sum(counts == 1))
    report.non_manifold_edges = int(np.sum(counts > 2))
    pairs = starts[counts == 2]
    first, second = order[pairs], order[pairs + 1]
    cell1, cell2 = owner[first], owner[second]
    # two cells facing the same way run along their shared edge in opposite directions
    same = forward[first] != forward[second]

    turn = _orient(n, cell1, cell2, same, tags, x, corners)
    report.turned = int(turn.sum())
    report.pieces = _pieces(n, cells)
    return turn, report


def _check_cells(cell_type, cells, x, grads, size, tags):
    """Degenerate and inverted cells, from the normal at every point of ``grads``."""
    xc = x[cells]  # (n, k, 3)
    g = np.einsum("nkd,qka->nqad", xc, grads)  # tangents (n, q, 2, 3)
    normal = np.cross(g[:, :, 0], g[:, :, 1])  # (n, q, 3)
    area = np.linalg.norm(normal, axis=2)
    floor = AREA_FLOOR * size[:, None] ** 2
    # the side of the cell: its normal where its area is largest
    largest = normal[np.arange(len(normal)), np.argmax(area, axis=1)]
    side = (
        np.einsum("nqd,nd->nq", normal, largest)
        / np.maximum(np.linalg.norm(largest, axis=1), np.finfo(float).tiny)[:, None]
    )
    inverted = (side < -floor).any(axis=1)
    if inverted.any():
        i = int(np.flatnonzero(inverted)[0])
        raise ValueError(
            f"cell {tags[i]} is turned inside out near "
            f"{_where(xc[i, : CORNERS[cell_type]].mean(axis=0))}: the "
            f"normal of its map changes side within the cell (a node "
            f"moved across an edge, or its nodes in the wrong order)"
        )
    small = (area < floor).any(axis=1)
    if small.any():
        i = int(np.flatnonzero(small)[0])
        raise ValueError(
            f"cell {tags[i]} has (nearly) zero area near "
            f"{_where(xc[i, : CORNERS[cell_type]].mean(axis=0))}: its "
            f"nodes are collinear or coincide"
        )


def _check_coincident(x, used, shortest):
    """Distinct nodes of the cells at one place: the cells there are not joined."""
    from scipy.spatial import cKDTree

    pts = x[used]
    pairs = cKDTree(pts).query_pairs(COINCIDENT * shortest, output_type="ndarray")
    if len(pairs):
        i, j = used[pairs[0]]
        raise ValueError(
            f"{len(pairs)} pair(s) of nodes coincide but are not merged, "
            f"the first at {_where(x[i])}: the cells on either side are "
            f"not joined (merge them, e.g. gmsh's Coherence Mesh)"
        )


def _orient(n, cell1, cell2, same, tags, x, corners) -> np.ndarray:
    """Which cells to turn so that every pair across an edge faces one way: a
    breadth-first walk over the edge graph; in each piece the side most cells
    already face is kept."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import breadth_first_order, connected_components

    graph = coo_matrix((np.ones(len(cell1)), (cell1, cell2)), shape=(n, n)).tocsr()
    count, label = connected_components(graph, directed=False)
    # whether the two cells of each shared edge face opposite sides, by (cell, cell)
    keys = np.r_[cell1 * n + cell2, cell2 * n + cell1]
    opposite = np.r_[~same, ~same]
    by_key = np.argsort(keys)
    keys, opposite = keys[by_key], opposite[by_key]
    turn = np.zeros(n, dtype=bool)
    for piece in range(count):
        start = int(np.flatnonzero(label == piece)[0])
        order, parent = breadth_first_order(graph, start, directed=False)
        child = order[1:]
        across = opposite[np.searchsorted(keys, parent[child] * n + child)].tolist()
        flags = turn.tolist()
        for cell, p, opp in zip(child.tolist(), parent[child].tolist(), across):
            flags[cell] = flags[p] ^ opp
        turn = np.array(flags, dtype=bool)
        if 2 * turn[order].sum() > len(order):
            turn[order] = ~turn[order]
    # every pair must now face one way, or the surface cannot be oriented
    bad = (turn[cell1] ^ turn[cell2]) != ~same
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        i, j = cell1[k], cell2[k]
        raise ValueError(
            f"the surface cannot be oriented (a Möbius band?): cells "
            f"{tags[i]} and {tags[j]} near "
            f"{_where(x[corners[i]].mean(axis=0))} cannot both face the "
            f"side of the rest of their piece"
        )
    return turn


def _pieces(n, cells) -> list[int]:
    """Cells of each piece (cells joined through shared nodes), largest first."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    k = cells.shape[1]
    rows = np.repeat(np.arange(n), k)
    incidence = coo_matrix(
        (np.ones(rows.size), (rows, cells.ravel())), shape=(n, int(cells.max()) + 1)
    ).tocsr()
    count, label = connected_components(incidence @ incidence.T, directed=False)
    return sorted(np.bincount(label, minlength=count).tolist(), reverse=True)
