"""The quadrature rules of the integrated Stokes layer (``rftfem.model.stokes_layer``,
docs/stokes.md §Two discretisations): the reference element and its Gauss,
near and Duffy rules, the points a rule gives, and the force grid of ``fluid.refine``;
the edge weight that carries a free edge's inverse-square-root density is
``rftfem.model.edge_weight``'s.

Everything here is in reference coordinates and made once, when a body is set up.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp

# the edge weight, importable from here as before it had a module of its own
from rftfem.model.edge_weight import EdgeWeight as EdgeWeight
from rftfem.model.edge_weight import _quadratic as _quadratic

if TYPE_CHECKING:
    from collections.abc import Sequence

#: Gauss–Legendre points across (t) and along (s, per piece) a Duffy triangle
SINGULAR_ANGULAR, SINGULAR_RADIAL = 8, 6
#: the rays of a Duffy triangle are cut at ε, 4ε, 16ε, … (in the ray's length) so that
#: a blob's core is resolved; never below this fraction of the ray
SMALLEST_PIECE = 1e-9
#: a node within this many element sizes of an element takes the near rule
NEAR = 1.0
#: the near rule's pieces are this many times smaller than the far rule's
NEAR_FACTOR = 2
#: the degree of the Gauss rule on each piece: 4 × 4 points on quadrilaterals, an even
#: number so that no point falls on a node (the centre of a Q2 element), where the
#: Stokeslet is singular
FAR_DEGREE = 7


class ReferenceElement:
    """The second-order Lagrange element (Q2 or P2) on basix's reference cell."""

    def __init__(self, cell: str):
        import basix

        quad = cell == "quadrilateral"
        kind = basix.CellType.quadrilateral if quad else basix.CellType.triangle
        self._element = basix.create_element(
            basix.ElementFamily.P, kind, 2, basix.LagrangeVariant.equispaced
        )
        self.cell = cell
        #: the nodes' reference coordinates (nd, 2), in the dofmap's order
        self.nodes = np.asarray(self._element.points, dtype=float)
        #: the reference cell's corners, counter-clockwise
        self.corners = np.array(
            [[0, 0], [1, 0], [1, 1], [0, 1]] if quad else [[0, 0], [1, 0], [0, 1]], dtype=float
        )
        points, weights = basix.make_quadrature(kind, FAR_DEGREE)
        self._rule = (np.asarray(points, dtype=float), np.asarray(weights, dtype=float))

    def basis(self, xi: np.ndarray) -> np.ndarray:
        """``ψ_a(ξ)`` (npts, nd)."""
        if len(xi) == 0:  # basix asserts on no points
            return np.zeros((0, len(self.nodes)))
        return self._element.tabulate(0, np.asarray(xi, dtype=float))[0, :, :, 0]

    def gradients(self, xi: np.ndarray) -> np.ndarray:
        """``∂ψ_a/∂ξ_j`` (npts, nd, 2)."""
        if len(xi) == 0:
            return np.zeros((0, len(self.nodes), 2))
        t = self._element.tabulate(1, np.asarray(xi, dtype=float))
        return np.stack([t[1, :, :, 0], t[2, :, :, 0]], axis=-1)

    def pieces(self, m: int) -> list[np.ndarray]:
        """The reference cell cut into ``m × m`` squares or ``m²`` triangles, each as
        its corners (k, 2)."""
        out = []
        if len(self.corners) == 4:
            for i in range(m):
                for j in range(m):
                    out.append(np.array([[i, j], [i + 1, j], [i + 1, j + 1], [i, j + 1]]) / m)
            return out
        for i in range(m):
            for j in range(m - i):
                out.append(np.array([[i, j], [i + 1, j], [i, j + 1]]) / m)
                if i + j < m - 1:
                    out.append(np.array([[i + 1, j], [i + 1, j + 1], [i, j + 1]]) / m)
        return out

    def rule(
        self, m: int, cluster: Sequence[tuple[bool, bool]] | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """Gauss points and weights (on the reference cell) of ``m × m`` pieces; with
        ``cluster`` (an edge weight's ``(low, high)`` ends per direction) mapped by
        :func:`_cluster` so that the weight's inverse square roots are integrated
        as smooth functions."""
        xi, w = self._plain_rule(m)
        if cluster is None:
            return xi, w
        out = np.empty_like(xi)
        for j, (low, high) in enumerate(cluster):
            out[:, j], dj = _cluster(xi[:, j], low, high)
            w = w * dj
        return out, w

    def _plain_rule(self, m: int) -> tuple[np.ndarray, np.ndarray]:
        p, w = self._rule
        xs, ws = [], []
        for c in self.pieces(m):
            if len(c) == 4:
                lo, size = c[0], c[2] - c[0]
                xs.append(lo + p * size)
                ws.append(w * size[0] * size[1])
            else:
                e1, e2 = c[1] - c[0], c[2] - c[0]
                xs.append(c[0] + p[:, :1] * e1 + p[:, 1:] * e2)
                ws.append(w * abs(e1[0] * e2[1] - e1[1] * e2[0]))
        return np.concatenate(xs), np.concatenate(ws)

    def singular_rule(
        self, apex: np.ndarray, scale: float, refine: int = 0, weighted: bool = False
    ) -> tuple[np.ndarray, np.ndarray]:
        """Points and weights of Duffy triangles with their apex at ``apex`` (a node's
        reference coordinates); ``scale`` is ε over the element's size (rays cut
        geometrically from about ``scale`` of their length).  ``weighted``: the
        element carries an edge weight, singular on sides and corners only, which
        the Duffy map puts at the ends of the pieces (s) and of the angle (t): both
        are then mapped by :func:`_cluster`."""
        gs, gws = np.polynomial.legendre.leggauss(SINGULAR_RADIAL + 2 * refine)
        gt, gwt = np.polynomial.legendre.leggauss(SINGULAR_ANGULAR + 2 * refine)
        gs, gws, gt, gwt = (gs + 1) / 2, gws / 2, (gt + 1) / 2, gwt / 2
        xs, ws = [], []
        c = self.corners
        for k in range(len(c)):
            a, b = c[k], c[(k + 1) % len(c)]
            det = (a[0] - apex[0]) * (b[1] - a[1]) - (a[1] - apex[1]) * (b[0] - a[0])
            if abs(det) < 1e-12:  # the apex lies on this side
                continue
            ray = np.linalg.norm(0.5 * (a + b) - apex)
            cuts = [1.0]
            while cuts[-1] / 4 > max(scale / ray, SMALLEST_PIECE) and scale > 0:
                cuts.append(cuts[-1] / 4)
            cuts = np.array([0.0] + cuts[::-1])
            for lo, hi in zip(cuts[:-1], cuts[1:]):
                s, ds = _cluster(gs, True, True) if weighted else (gs, 1.0)
                t, dt = _cluster(gt, True, True) if weighted else (gt, 1.0)
                s = lo + (hi - lo) * s
                S, T = np.meshgrid(s, t, indexing="ij")
                W = np.outer(gws * ds * (hi - lo), gwt * dt)
                point = apex + S[..., None] * ((a - apex) + T[..., None] * (b - a))
                xs.append(point.reshape(-1, 2))
                ws.append((W * S * abs(det)).ravel())
        return np.concatenate(xs), np.concatenate(ws)


def _cluster(eta: np.ndarray, low: bool, high: bool):
    """``ξ(η)`` on [0, 1] with ``ξ′`` vanishing linearly at the clustered ends, and
    ``ξ′``: an inverse square root of the distance to such an end times ``ξ′`` is
    smooth in η (η², 1 − (1 − η)², or 3η² − 2η³ for both ends)."""
    if low and high:
        return 3 * eta**2 - 2 * eta**3, 6 * eta * (1 - eta)
    if low:
        return eta**2, 2 * eta
    if high:
        return 1 - (1 - eta) ** 2, 2 * (1 - eta)
    return eta, np.ones_like(eta)


class RulePoints:
    """Quadrature points of the layer: each an element, reference coordinates, a
    weight (reference area included) and the basis there, and optionally the
    target node it serves (the near and singular rules)."""

    def __init__(
        self,
        cells: np.ndarray,
        element: ReferenceElement,
        elem: np.ndarray,
        xi: np.ndarray,
        weight: np.ndarray,
        target: np.ndarray | None = None,
    ):
        self.elem = np.asarray(elem, dtype=np.int64)
        self.nodes = cells[self.elem]  # (P, nd)
        self.psi = element.basis(xi)  # (P, nd)
        self.weight = np.asarray(weight, dtype=float)
        self.target = None if target is None else np.asarray(target, dtype=np.int64)

    def positions(self, x: np.ndarray) -> np.ndarray:
        """The points' current positions ``y = Σ_a ψ_a x_a`` (P, 3)."""
        return np.einsum("pa,pak->pk", self.psi, x[self.nodes])

    def density(self, f: np.ndarray) -> np.ndarray:
        """The force density at the points, times the weights (P, 3)."""
        return np.einsum("pa,pak->pk", self.psi, f[self.nodes]) * self.weight[:, None]

    def scatter(self, n: int) -> sp.csr_matrix:
        """``P`` (points × nodes): weight × basis, so that ``Σ_q K_q (P f)_q`` is the rule."""
        rows = np.repeat(np.arange(len(self.weight)), self.nodes.shape[1])
        vals = (self.psi * self.weight[:, None]).ravel()
        return sp.csr_matrix((vals, (rows, self.nodes.ravel())), shape=(len(self.weight), n))


def refined(
    X: np.ndarray, cells: np.ndarray, cell: str, level: int
) -> tuple[np.ndarray, np.ndarray, sp.csr_matrix]:
    """The force grid of ``fluid.refine = level``: every element of the shell cut into
    ``2^level × 2^level`` second-order elements (``4^level`` triangles) on the shell's
    own curved surface.  Returns the grid's nodes (reference positions), its
    elements, and the interpolation ``I`` (grid nodes × shell nodes, the shell's
    basis at each grid node): the grid moves as ``I x`` and its loads reach the shell
    as ``Iᵀ F``."""
    X, cells = np.asarray(X, dtype=float), np.asarray(cells, dtype=np.int64)
    el = ReferenceElement(cell)
    if level == 0:
        return X, cells, sp.identity(len(X), format="csr")
    m = 2**level
    quad = cell == "quadrilateral"
    # the sub-elements' nodes on a grid of step 1/(2m) in the reference cell
    sub_cells, grid = [], {}

    def node(i, j):
        return grid.setdefault((i, j), len(grid))

    for piece in el.pieces(m):
        origin = np.rint(piece[0] * 2 * m).astype(int)
        e1 = np.rint((piece[1] - piece[0]) * 2 * m).astype(int)
        e2 = np.rint((piece[-1] - piece[0]) * 2 * m).astype(int)
        if quad:  # corners (0,0), (1,0), (1,1), (0,1): local axes e1 (x) and e2 (y)
            e1, e2 = (
                np.rint((piece[1] - piece[0]) * 2 * m).astype(int),
                np.rint((piece[3] - piece[0]) * 2 * m).astype(int),
            )
        local = np.rint(el.nodes * 2).astype(int)  # (nd, 2) in half-steps
        sub_cells.append([node(*(origin + (a * e1 + b * e2) // 2)) for a, b in local])
    ref = np.array(sorted(grid, key=grid.get), dtype=float) / (2 * m)
    psi = el.basis(ref)  # (G, nd)
    sub_cells = np.array(sub_cells)
    pos = np.einsum("ga,cak->cgk", psi, X[cells])  # (C, G, 3)
    scale = float(np.ptp(X, axis=0).max()) or 1.0
    keys = np.round(pos.reshape(-1, 3) / scale * 1e9).astype(np.int64)
    unique, first, inverse = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    inverse = inverse.ravel()
    G = len(ref)
    fine_cells = inverse.reshape(len(cells), G)[:, sub_cells].reshape(-1, len(el.nodes))
    c, g = np.divmod(first, G)
    rows = np.repeat(np.arange(len(first)), len(el.nodes))
    I = sp.csr_matrix((psi[g].ravel(), (rows, cells[c].ravel())), shape=(len(first), len(X)))
    return pos.reshape(-1, 3)[first], fine_cells, I
