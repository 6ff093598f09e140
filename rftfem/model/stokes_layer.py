"""The regularized single layer integrated over the shell's elements
(``[fluid] method = "layer"``, the default; docs/stokes.md).

The force per reference area the body exerts on the liquid is a field on the
shell's own second-order elements, ``f(ξ) = Σ_k ψ_k(ξ) f_k`` (the displacement's
basis, one value per node), and the liquid's velocity at the node ``x_i`` is the
layer

    u(x_i) = Σ_k [∫ S_ε(x_i − y(ξ)) ψ_k(ξ) dA₀] f_k / (8πμ) = (A f)_i,
    y(ξ) = Σ_k ψ_k(ξ) x_k,

with the Gaussian blob ``S_ε`` of ``rftfem.model.stokeslets`` and ε a length of its
own (not the spacing).  No slip holds at the nodes (collocation), ``A f = v``, and
the shell gets the consistent nodal loads ``F = B f``, ``B_kl = ∫ ψ_k ψ_l dA₀``.

The integral over each element is taken by one of three rules, fixed when the
body is set up (they hold reference coordinates and weights; only the positions
move):

- far: Gauss points on the element cut into ``m × m`` pieces (``m = 2^refine``);
- near, for a node within one element size of the element: the same on pieces
  four times smaller;
- singular, for a node of the element itself: the element cut into triangles
  with their apex at the node, each mapped from the unit square by a Duffy
  transform (which cancels the 1/r of the kernel), Gauss–Legendre across and
  along the rays, the rays cut geometrically near the apex so that the blob's
  core, of size ε, is resolved for any ε.

The near and singular rules replace the far rule for their pairs (its points
are subtracted).  Every rule is a list of points ``(element, ξ, weight)``, so
``A``, its exact position derivative ``∂(A f)/∂x`` at fixed ``f`` and the wall's
images are sums over points of the same shape (``_Points``).
"""

from __future__ import annotations

from math import pi

import numpy as np
import scipy.sparse as sp

from rftfem.model import stokeslets

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
        self._element = basix.create_element(basix.ElementFamily.P, kind, 2,
                                             basix.LagrangeVariant.equispaced)
        self.cell = cell
        #: the nodes' reference coordinates (nd, 2), in the dofmap's order
        self.nodes = np.asarray(self._element.points, dtype=float)
        #: the reference cell's corners, counter-clockwise
        self.corners = np.array([[0, 0], [1, 0], [1, 1], [0, 1]] if quad
                                else [[0, 0], [1, 0], [0, 1]], dtype=float)
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

    def rule(self, m: int, cluster=None) -> tuple[np.ndarray, np.ndarray]:
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

    def singular_rule(self, apex: np.ndarray, scale: float, refine: int = 0,
                      weighted: bool = False):
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
                s, ds = (_cluster(gs, True, True) if weighted else (gs, 1.0))
                t, dt = (_cluster(gt, True, True) if weighted else (gt, 1.0))
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
        return 3 * eta ** 2 - 2 * eta ** 3, 6 * eta * (1 - eta)
    if low:
        return eta ** 2, 2 * eta
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
        ends = [[a for a in idx if np.isclose(nodes[a], nodes[a].round()).all()]
                for idx in on_side]
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
        corner_nodes = [a for a in range(len(nodes))
                        if np.isclose(nodes[a], nodes[a].round()).all()]
        for e in range(n_el):
            on_free_side = {a for k in self.sides[e] for a in ends[k]}
            self.corners[e] = tuple(tuple(nodes[a]) for a in corner_nodes
                                    if cells[e, a] in free_nodes and a not in on_free_side)
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
        s = np.clip(np.einsum("pkj,pkj->pk", y[:, None] - a, ab)
                    / np.maximum(np.einsum("pkj,pkj->pk", ab, ab), 1e-300), 0.0, 1.0)
        t0, step = self._chord_t
        t = t0[near] + s * step
        P = self._curves[self._owner[near]]  # (P, k, 3 nodes, 3)
        for _ in range(4):  # from a chord's projection: converged to round-off
            c, dc, ddc = _quadratic(P, t)
            r = c - y[:, None]
            g = np.einsum("pkj,pkj->pk", r, dc)
            h = np.einsum("pkj,pkj->pk", dc, dc) + np.einsum("pkj,pkj->pk", r, ddc)
            t = np.clip(t - g / np.where(h > 0, h, 1.0), 0.0, 1.0)
        r = _quadratic(P, t)[0] - y[:, None]
        return np.sqrt(np.einsum("pkj,pkj->pk", r, r)).min(axis=1)

    def set_reach(self, y: np.ndarray):
        """ℓ: the largest distance to a free edge among the points ``y`` (the far rule)."""
        if self._tree is not None:
            #: ℓ, the body's half-width
            self.width = float(self.distance(y).max())

    def weighted(self, e: int) -> bool:
        return bool(self.sides[e] or self.corners[e])

    def cluster(self, e: int):
        """Per direction, whether the rule's points gather at its low and high end."""
        out = []
        for d in range(2):
            low = any(self.SIDES[k] == (d, 0.0) for k in self.sides[e]) or \
                any(c[d] == 0.0 for c in self.corners[e])
            high = any(self.SIDES[k] == (d, 1.0) for k in self.sides[e]) or \
                any(c[d] == 1.0 for c in self.corners[e])
            out.append((low, high))
        return tuple(out)

    def __call__(self, elem: np.ndarray, xi: np.ndarray) -> np.ndarray:
        """``ω`` at the reference points ``xi`` of the elements ``elem``."""
        if self._tree is None:
            return np.ones(len(xi))
        y = np.einsum("pa,pak->pk", self.element.basis(xi), self.X[self.cells[elem]])
        d = np.maximum(self.distance(y), 1e-300)
        return np.sqrt(1.0 + self.width / d)


class _Points:
    """Quadrature points of the layer: each an element, reference coordinates, a
    weight (reference area included) and the basis there, and optionally the
    target node it serves (the near and singular rules)."""

    def __init__(self, cells, element, elem, xi, weight, target=None):
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


def _radial(r: np.ndarray, eps: float):
    """``(a, b, a′/r, b′/r)`` of ``S_ε(r) F = a F + b (r·F) r`` at separations ``r``
    (..., 3); ``eps = 0`` is the Stokeslet itself."""
    dist = np.sqrt(np.einsum("...k,...k->...", r, r))
    if eps == 0.0:
        inv = 1.0 / dist
        inv3 = inv ** 3
        return inv, inv3, -inv3, -3.0 * inv3 * inv * inv
    f0, f1, f2, f3 = stokeslets.radial(dist / eps)
    return f0 / eps, f1 / eps ** 3, f2 / eps ** 3, f3 / eps ** 5


def _kernel_blocks(r, eps):
    """The 3 × 3 blocks ``S_ε(r)`` (..., 3, 3)."""
    a, b, _, _ = _radial(r, eps)
    out = b[..., None, None] * r[..., :, None] * r[..., None, :]
    out += a[..., None, None] * np.eye(3)
    return out


def _kernel_gradient(r, F, eps):
    """``T = ∂(S_ε(r) F)/∂r`` (..., 3, 3) for separations ``r`` and forces ``F`` (..., 3)."""
    _, b, da, db = _radial(r, eps)
    rF = np.einsum("...k,...k->...", r, F)
    T = da[..., None, None] * F[..., :, None] * r[..., None, :]
    T += (db * rF)[..., None, None] * r[..., :, None] * r[..., None, :]
    T += b[..., None, None] * r[..., :, None] * F[..., None, :]
    T += (b * rF)[..., None, None] * np.eye(3)
    return T


class Layer:
    """The layer's rules for one body (set up once, from the reference positions ``X``).

    ``cells`` (C, nd) are the elements' node indices into ``X`` in the reference
    element's order; ``rows`` the target nodes this process evaluates (a slice,
    default all)."""

    def __init__(self, X, cells, cell: str, epsilon: float, refine: int = 0,
                 rows: slice | None = None, edge_weight: bool = True):
        self.X = np.asarray(X, dtype=float)
        self.cells = np.asarray(cells, dtype=np.int64)
        self.element = ReferenceElement(cell)
        self.epsilon, self.refine = float(epsilon), int(refine)
        n = len(self.X)
        self.rows = slice(0, n) if rows is None else rows
        #: the density's edge weight (``ω = 1`` everywhere without ``edge_weight``)
        self.weight = EdgeWeight(self.element, self.cells if edge_weight else self.cells[:0],
                                 self.X)
        if not edge_weight:
            self.weight.sides = self.weight.corners = [()] * len(self.cells)
        else:  # ℓ from the plain far rule's points
            xi1, _ = self.element.rule(1)
            self.weight.set_reach(np.concatenate(
                [self.element.basis(xi1) @ self.X[c] for c in self.cells]))
        self._m = 2 ** self.refine
        C = len(self.cells)
        rules = [self.rule(e, self._m) for e in range(C)]
        q = len(rules[0][1])
        elem = np.repeat(np.arange(C), q)
        #: the far rule: every element's Gauss points
        self._far_xi = np.concatenate([r[0] for r in rules])
        self.far = _Points(self.cells, self.element, elem, self._far_xi,
                           self._weights(elem, self._far_xi, np.concatenate([r[1] for r in rules])))
        self._P = self.far.scatter(n)
        #: each element's size: √ of its reference area
        plain_xi, plain_w = self.element.rule(1)
        elem1 = np.repeat(np.arange(C), len(plain_w))
        area = np.bincount(elem1, weights=np.tile(plain_w, C) * self._reference_jacobian(
            elem1, np.tile(plain_xi, (C, 1))), minlength=C)
        self.size = np.sqrt(area)
        self.special = self._special_points()

    def _reference_jacobian(self, elem, xi) -> np.ndarray:
        """``|∂X/∂ξ₁ × ∂X/∂ξ₂|`` at the points ``xi`` of the elements ``elem``."""
        dpsi = self.element.gradients(xi)  # (P, nd, 2)
        J = np.einsum("paj,pak->pkj", dpsi, self.X[self.cells[elem]])  # (P, 3, 2)
        return np.linalg.norm(np.cross(J[:, :, 0], J[:, :, 1]), axis=1)

    def _weights(self, elem, xi, w) -> np.ndarray:
        """A reference rule's weights times the reference area and the edge weight."""
        return w * self._reference_jacobian(elem, xi) * self.weight(elem, xi)

    def rule(self, e: int, m: int, apex=None, scale: float = 1.0):
        """Element ``e``'s reference points and weights (on the reference cell):
        ``m × m`` Gauss pieces, or the singular rule about the node at ``apex``."""
        weighted = self.weight.weighted(e)
        if apex is None:
            return self.element.rule(m, self.weight.cluster(e) if weighted else None)
        return self.element.singular_rule(apex, scale, self.refine, weighted)

    def _special_points(self) -> _Points:
        """The near and singular rules of this process's targets, with the far
        rule's points of the same pairs at negative weight."""
        cells, el, far = self.cells, self.element, self.far
        q = len(far.weight) // len(cells)
        # distances from every target to every element's far points (reference state)
        y = far.positions(self.X).reshape(len(cells), q, 3)
        targets = np.arange(self.rows.start, self.rows.stop)
        new, old = ([], [], [], []), ([], [], [], [])  # (elem, ξ, weight, target) lists

        def add(group, e, xi, w, t):
            for lst, v in zip(group, (np.full(len(w), e), xi, w, np.full(len(w), t))):
                lst.append(v)

        singular = {}  # the Duffy rules by node, edge weight and ε (in element sizes)
        for e in range(len(cells)):
            d = np.linalg.norm(self.X[targets, None, :] - y[e][None], axis=-1).min(axis=1)
            near = targets[d < NEAR * self.size[e]]
            if not len(near):
                continue
            members = list(cells[e])
            near_rule = self.rule(e, self._m * NEAR_FACTOR)
            far_xi, far_w = self._far_of(e)
            for t in near:
                if t in members:
                    a = members.index(t)
                    scale = self.epsilon / self.size[e]
                    key = (a, self.weight.weighted(e), round(np.log(scale) * 16) if scale else 0)
                    if key not in singular:
                        singular[key] = self.rule(e, 0, apex=el.nodes[a], scale=scale)
                    xi, w = singular[key]
                else:
                    xi, w = near_rule
                add(new, e, xi, w, t)
                add(old, e, far_xi, -far_w, t)
        if not new[0]:
            return _Points(cells, el, np.zeros(0, int), np.zeros((0, 2)), np.zeros(0),
                           np.zeros(0, int))
        elem, xi, w, t = (np.concatenate(v) for v in new)
        w = self._weights(elem, xi, w)
        elem, xi, w, t = (np.concatenate([a, np.concatenate(b)])
                          for a, b in zip((elem, xi, w, t), old))
        return _Points(cells, el, elem, xi, w, t)

    def _far_of(self, e: int):
        """Element ``e``'s far points (reference coordinates) and weights."""
        q = len(self.far.weight) // len(self.cells)
        return self._far_xi[e * q:(e + 1) * q], self.far.weight[e * q:(e + 1) * q]

    # --- the operator ---------------------------------------------------------

    def matrix(self, x: np.ndarray, viscosity: float, wall=None) -> np.ndarray:
        """The rows of ``A`` (3 n_rows × 3N) at the positions ``x``: ``u = A f``."""
        x = np.asarray(x, dtype=float)
        n = len(x)
        lo, hi = self.rows.start, self.rows.stop
        A = np.zeros((hi - lo, 3, n, 3))
        y = self.far.positions(x)
        PT = self._P.T.tocsr()
        for chunk in _chunks(hi - lo, len(y)):
            K = _kernel_blocks(x[lo + chunk.start:lo + chunk.stop, None, :] - y[None], self.epsilon)
            if wall is not None:
                K += wall.image_blocks(x[lo + chunk.start:lo + chunk.stop], y)
            k = chunk.stop - chunk.start
            K2 = K.transpose(0, 2, 3, 1).reshape(k * 9, len(y))  # (t a b, q)
            A[chunk] = (PT @ K2.T).T.reshape(k, 3, 3, n).transpose(0, 1, 3, 2)
        self._add_special(A, x, lambda r, p: _kernel_blocks(r, self.epsilon), None)
        return A.reshape(3 * (hi - lo), 3 * n) / (8 * pi * viscosity)

    def position_derivative(self, x, f, viscosity: float, wall=None) -> np.ndarray:
        """The rows of ``G = ∂(A f)/∂x`` at fixed ``f`` (3 n_rows × 3N)."""
        x = np.asarray(x, dtype=float)
        f = np.asarray(f, dtype=float).reshape(-1, 3)
        n = len(x)
        lo, hi = self.rows.start, self.rows.stop
        G = np.zeros((hi - lo, 3, n, 3))
        y = self.far.positions(x)
        fq = self.far.density(f)  # weighted
        unweighted = sp.csr_matrix((self.far.psi.ravel(), (
            np.repeat(np.arange(len(y)), self.far.nodes.shape[1]), self.far.nodes.ravel())),
            shape=(len(y), n)).T.tocsr()
        for chunk in _chunks(hi - lo, len(y)):
            t = np.arange(lo + chunk.start, lo + chunk.stop)
            T = _kernel_gradient(x[t, None, :] - y[None], fq[None], self.epsilon)
            k = len(t)
            rows = np.arange(chunk.start, chunk.stop)
            G[rows, :, t, :] += T.sum(axis=1)
            T2 = T.transpose(0, 2, 3, 1).reshape(k * 9, len(y))
            G[chunk] -= (unweighted @ T2.T).T.reshape(k, 3, 3, n).transpose(0, 1, 3, 2)
            if wall is not None:
                wall.image_derivative(G, rows, x[t], t, y, fq, unweighted)
        self._add_special(G, x, lambda r, p: _kernel_gradient(r, p, self.epsilon), f,
                          derivative=True)
        return G.reshape(3 * (hi - lo), 3 * n) / (8 * pi * viscosity)

    def _special_sums(self):
        """Sparse sums over the special points, made once: ``(entries, S_w, S_ψ, S_1)``
        with ``entries`` the distinct (target row, node) pairs they touch, ``S_w`` and
        ``S_ψ`` (entries × points) weight × basis and basis, ``S_1`` (rows × points)
        the target's own sum."""
        if getattr(self, "_sums", None) is None:
            s, n = self.special, len(self.X)
            nd = s.nodes.shape[1]
            t = s.target - self.rows.start
            keys = (np.repeat(t, nd) * n + s.nodes.ravel())
            entries, inverse = np.unique(keys, return_inverse=True)
            cols = np.repeat(np.arange(len(t)), nd)
            shape = (len(entries), len(t))
            S_w = sp.csr_matrix(((s.psi * s.weight[:, None]).ravel(), (inverse, cols)), shape)
            S_psi = sp.csr_matrix((s.psi.ravel(), (inverse, cols)), shape)
            S_1 = sp.csr_matrix((np.ones(len(t)), (t, np.arange(len(t)))),
                                (self.rows.stop - self.rows.start, len(t)))
            # separations r = x_target − Σ ψ x and weighted densities, as sparse products
            p = np.arange(len(t))
            D = sp.csr_matrix((np.concatenate([np.ones(len(t)), -s.psi.ravel()]),
                               (np.concatenate([p, cols]),
                                np.concatenate([s.target, s.nodes.ravel()]))), (len(t), n))
            Pw = sp.csr_matrix(((s.psi * s.weight[:, None]).ravel(), (cols, s.nodes.ravel())),
                               (len(t), n))
            self._sums = (np.divmod(entries, n), S_w, S_psi, S_1, D, Pw)
        return self._sums

    def _add_special(self, out, x, blocks, f, derivative=False, chunk=200_000):
        """Add the near and singular rules (minus the far rule's) of this process's
        pairs to ``out`` (n_rows, 3, N, 3)."""
        s = self.special
        if not len(s.weight):
            return
        (rows, nodes), S_w, S_psi, S_1, D, Pw = self._special_sums()
        lo = self.rows.start
        values = np.empty((len(s.weight), 9))
        r_all = D @ x
        fp_all = Pw @ f if derivative else None
        for start in range(0, len(s.weight), chunk):
            sl = slice(start, start + chunk)
            r = r_all[sl]
            if derivative:
                values[sl] = blocks(r, fp_all[sl]).reshape(-1, 9)
            else:
                values[sl] = blocks(r, None).reshape(-1, 9)
        if derivative:
            own = (S_1 @ values).reshape(-1, 3, 3)
            idx = np.arange(len(own))
            out[idx, :, idx + lo, :] += own
            out[rows, :, nodes, :] -= (S_psi @ values).reshape(-1, 3, 3)
        else:
            out[rows, :, nodes, :] += (S_w @ values).reshape(-1, 3, 3)

    # --- the nodal loads --------------------------------------------------------

    def mass(self) -> sp.csr_matrix:
        """``B_kl = ∫ ψ_k ψ_l dA₀`` (N × N): nodal loads from the density."""
        return (self._basis_matrix().T @ self._P).tocsr()

    def _basis_matrix(self) -> sp.csr_matrix:
        n = len(self.X)
        rows = np.repeat(np.arange(len(self.far.weight)), self.far.nodes.shape[1])
        return sp.csr_matrix((self.far.psi.ravel(), (rows, self.far.nodes.ravel())),
                             shape=(len(self.far.weight), n))

    def mass_factors(self):
        """``B`` and its sparse LU (kept: ``B`` does not move)."""
        if not hasattr(self, "_mass"):
            from scipy.sparse.linalg import splu

            self._mass = self.mass()
            self._mass_lu = splu(self._mass.tocsc())
        return self._mass, self._mass_lu

    @property
    def quadrature_points(self) -> int:
        """Far points plus this process's near and singular points."""
        return len(self.far.weight) + int(np.sum(self.special.weight > 0))


def refined(X, cells, cell: str, level: int):
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
    m = 2 ** level
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
            e1, e2 = np.rint((piece[1] - piece[0]) * 2 * m).astype(int), \
                np.rint((piece[3] - piece[0]) * 2 * m).astype(int)
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


class LayerResistance:
    """The factorised layer of one configuration: nodal loads from velocities,
    ``F = Iᵀ B A⁻¹ I v`` (the same contract as ``stokeslets.Resistance``, plus
    :meth:`tangent`), ``I`` the force grid's interpolation (:func:`refined`).

    ``A`` is not symmetric (collocation), so it is LU-factorised.  Under MPI each
    process evaluates its ``layer.rows``; the rows are gathered and every process
    factorises the same matrix; the position derivative stays distributed."""

    def __init__(self, layer: Layer, x, viscosity: float, wall=None, comm=None,
                 interpolation=None):
        import scipy.linalg as sl

        self.x = np.array(x, dtype=float)
        self.layer, self.viscosity, self.wall = layer, viscosity, wall
        self.I = interpolation if interpolation is not None else \
            sp.identity(len(self.x), format="csr")
        #: the force grid's positions
        self.grid = self.I @ self.x
        self.comm = comm if comm is not None and comm.size > 1 else None
        A = stokeslets.gather_rows(layer.matrix(self.grid, viscosity, wall), self.comm)
        self._lu = sl.lu_factor(A, overwrite_a=True, check_finite=False)
        self._mass = layer.mass_factors()[0]
        self._solved = []  # (loads, densities) of the last solves, for the derivative

    def _to_grid(self, v: np.ndarray) -> np.ndarray:
        n = len(self.x)
        return (self.I @ v.reshape(n, -1)).reshape((-1,) + v.shape[1:])

    def _to_shell(self, F: np.ndarray) -> np.ndarray:
        g = len(self.grid)
        return (self.I.T @ F.reshape(g, -1)).reshape((-1,) + F.shape[1:])

    def densities(self, rhs: np.ndarray) -> np.ndarray:
        """``A⁻¹ rhs`` for grid velocities: the density's values at the grid nodes."""
        import scipy.linalg as sl

        return sl.lu_solve(self._lu, rhs, check_finite=False)

    def _loads(self, f: np.ndarray) -> np.ndarray:
        g = len(self.grid)
        return (self._mass @ f.reshape(g, -1)).reshape(f.shape)

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """``Iᵀ B A⁻¹ I rhs``: the shell's nodal loads for nodal velocities (3N, or 3N × k)."""
        f = self.densities(self._to_grid(np.asarray(rhs, dtype=float)))
        F = self._to_shell(self._loads(f))
        if F.ndim == 1:
            self._solved = [(F, f)] + self._solved[:3]
        return F

    def lumped(self) -> np.ndarray:
        """The nodal blocks ``Σ_j R_ij`` of the resistance (N × 3 × 3, symmetrised,
        clipped at 0)."""
        n = len(self.x)
        ones = np.tile(np.eye(3), (n, 1))
        return stokeslets.lumped_blocks(self.solve(ones).reshape(n, 3, 3))

    def position_operator(self, forces):
        """``G = ∂(A f)/∂x_grid`` at the density ``f`` whose loads are ``forces`` (the
        result of a :meth:`solve`)."""
        forces = np.asarray(forces, dtype=float).ravel()
        for F, f in self._solved:
            if F.shape == forces.shape and np.array_equal(F, forces):
                break
        else:
            raise RuntimeError("the layer's derivative is taken at loads it did not solve for")
        G = self.layer.position_derivative(self.grid, f.reshape(-1, 3), self.viscosity,
                                           self.wall)
        return G if self.comm is None else stokeslets.RowBlocks(G, self.comm)

    def tangent(self, du: np.ndarray, cv: float, G) -> np.ndarray:
        """``dF = Iᵀ B A⁻¹ (c_v I du − G I du)``: the loads' change for a displacement
        change ``du`` (velocities ``c_v du``), ``G`` from :meth:`position_operator`."""
        dg = self._to_grid(np.asarray(du, dtype=float))
        return self._to_shell(self._loads(self.densities(cv * dg - G @ dg)))


def _chunks(n: int, total: int, pairs: int = 200_000):
    step = max(1, pairs // max(total, 1))
    return [slice(i, min(i + step, n)) for i in range(0, n, step)]
