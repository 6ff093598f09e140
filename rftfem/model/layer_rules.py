"""The quadrature rules of the integrated Stokes layer (``rftfem.model.stokes_layer``,
docs/stokes.md §Two discretisations): the reference element and its Gauss,
near and Duffy rules, the edge weight that carries a free edge's inverse-square-root
density, the points a rule gives, and the force grid of ``fluid.refine``.

Everything here is in reference coordinates and made once, when a body is set up.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp

from rftfem.model import stokes_kernels

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


def _quadratic(P, t):
    """A quadratic curve through ``P[..., 0:3, :]`` (start, middle, end) at ``t`` ∈ [0, 1]:
    the point, its first and its second derivative in t."""
    t = np.asarray(t, dtype=float)
    if P.ndim == 2:  # one curve, many t
        P = P[None]
        t = t[:, None]
        squeeze = True
    else:
        squeeze = False
    N = [(1 - t) * (1 - 2 * t), 4 * t * (1 - t), t * (2 * t - 1)]
    dN = [4 * t - 3, 4 - 8 * t, 4 * t - 1]
    ddN = [4.0, -8.0, 4.0]
    c = sum(n[..., None] * P[..., i, :] for i, n in enumerate(N))
    dc = sum(n[..., None] * P[..., i, :] for i, n in enumerate(dN))
    ddc = sum(n * P[..., i, :] for i, n in enumerate(ddN)) + 0 * c
    if squeeze:
        return c[:, 0] if c.ndim == 3 else c, dc, ddc
    return c, dc, ddc


class EdgeWeight:
    """The edge weight of the density on quadrilaterals (docs/stokes.md §Free edges).

    Near a free edge the density of a thin body grows as the inverse square root of
    the distance to it, d.  The density is ``ω Σ ψ_k f_k`` with

        ω(y) = √(1 + ℓ/d(y)),

    d the distance of the reference point y to the nearest free edge and ℓ the
    largest such distance on the body (its half-width): ω carries the singularity
    and the nodal values stay finite and smooth (for a disk or a strip the flat
    plate's density over ω is smooth to the edge).  Elements touching a free edge
    (by a side or a corner) gather their quadrature points there (:func:`_cluster`)
    so that ω is integrated as a smooth function.  Triangles and closed bodies get
    ω = 1."""

    #: the sides (bottom, right, top, left) of the reference square: (direction, end)
    SIDES = ((1, 0.0), (0, 1.0), (1, 1.0), (0, 0.0))
    #: points along each free side on which its curve is sampled (its distance)
    SAMPLES = 24

    def __init__(self, element: ReferenceElement, cells: np.ndarray, X: np.ndarray):
        self.element, self.cells, self.X = element, cells, X
        n_el = len(cells)
        #: per element: its free sides (indices into SIDES) and free corners (ξ)
        self.sides = [() for _ in range(n_el)]
        self.corners = [() for _ in range(n_el)]
        self._tree = None
        if element.cell != "quadrilateral" or n_el == 0:
            return
        nodes = element.nodes
        on_side = [np.flatnonzero(np.isclose(nodes[:, d], end)) for d, end in self.SIDES]
        ends = [[a for a in idx if np.isclose(nodes[a], nodes[a].round()).all()] for idx in on_side]
        keys = {}
        for e in range(n_el):
            for k in range(4):
                key = tuple(sorted(cells[e, ends[k]]))
                keys[key] = keys.get(key, 0) + 1
        free_nodes = set()
        for e in range(n_el):
            free = tuple(k for k in range(4) if keys[tuple(sorted(cells[e, ends[k]]))] == 1)
            self.sides[e] = free
            for k in free:
                free_nodes.update(cells[e, on_side[k]].tolist())
        corner_nodes = [
            a for a in range(len(nodes)) if np.isclose(nodes[a], nodes[a].round()).all()
        ]
        for e in range(n_el):
            on_free_side = {a for k in self.sides[e] for a in ends[k]}
            self.corners[e] = tuple(
                tuple(nodes[a])
                for a in corner_nodes
                if cells[e, a] in free_nodes and a not in on_free_side
            )
        self._edge_segments()

    def _edge_segments(self):
        """The free edges: each side's three nodes (a quadratic curve), and short chords
        of it to find the nearest sides quickly."""
        t = np.linspace(0.0, 1.0, self.SAMPLES + 1)
        nodes = self.element.nodes
        curves, starts, stops, owner = [], [], [], []
        for e, sides in enumerate(self.sides):
            for k in sides:
                d, end = self.SIDES[k]
                on = [a for a in range(len(nodes)) if np.isclose(nodes[a, d], end)]
                on.sort(key=lambda a: nodes[a, 1 - d])  # start, middle, end along the side
                P = self.X[self.cells[e, on]]
                y = _quadratic(P, t)[0]
                curves.append(P)
                starts.append(y[:-1])
                stops.append(y[1:])
                owner.append(np.full(len(t) - 1, len(curves) - 1))
        if not curves:
            return
        from scipy.spatial import cKDTree

        self._curves = np.array(curves)  # (sides, 3, 3)
        a, b = np.concatenate(starts), np.concatenate(stops)
        self._owner = np.concatenate(owner)
        self._chord_t = np.tile(t[:-1], len(curves)), 1.0 / self.SAMPLES
        self._a, self._b = a, b
        self._tree = cKDTree(0.5 * (a + b))

    def distance(self, y: np.ndarray) -> np.ndarray:
        """The distance of the points ``y`` to the nearest free edge: the nearest chords
        found, then the point projected on their sides' curves by Newton's method."""
        k = min(4, len(self._a))
        _, near = self._tree.query(y, k=k)
        near = near.reshape(len(y), k)
        a, b = self._a[near], self._b[near]  # (P, k, 3)
        ab = b - a
        s = np.clip(
            np.einsum("pkj,pkj->pk", y[:, None] - a, ab)
            / np.maximum(np.einsum("pkj,pkj->pk", ab, ab), 1e-300),
            0.0,
            1.0,
        )
        t0, step = self._chord_t
        t = t0[near] + s * step
        return stokes_kernels.edge_distance(
            np.ascontiguousarray(y, dtype=float), self._curves[self._owner[near]], t
        )

    def set_reach(self, y: np.ndarray) -> None:
        """ℓ: the largest distance to a free edge among the points ``y`` (the far rule)."""
        if self._tree is not None:
            #: ℓ, the body's half-width
            self.width = float(self.distance(y).max())

    def weighted(self, e: int) -> bool:
        return bool(self.sides[e] or self.corners[e])

    def cluster(self, e: int) -> tuple[tuple[bool, bool], ...]:
        """Per direction, whether the rule's points gather at its low and high end."""
        out = []
        for d in range(2):
            low = any(self.SIDES[k] == (d, 0.0) for k in self.sides[e]) or any(
                c[d] == 0.0 for c in self.corners[e]
            )
            high = any(self.SIDES[k] == (d, 1.0) for k in self.sides[e]) or any(
                c[d] == 1.0 for c in self.corners[e]
            )
            out.append((low, high))
        return tuple(out)

    def __call__(self, elem: np.ndarray, xi: np.ndarray) -> np.ndarray:
        """``ω`` at the reference points ``xi`` of the elements ``elem``."""
        if self._tree is None:
            return np.ones(len(xi))
        y = np.einsum("pa,pak->pk", self.element.basis(xi), self.X[self.cells[elem]])
        d = np.maximum(self.distance(y), 1e-300)
        return np.sqrt(1.0 + self.width / d)


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
