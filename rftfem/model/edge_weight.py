"""The edge weight of the integrated layer's density near a free edge
(``rftfem.model.layer_rules``, docs/stokes.md §Free edges): the free sides and
corners of each element, and the distance of a point to the nearest free edge.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from rftfem.model import stokes_kernels

if TYPE_CHECKING:
    from rftfem.model.layer_rules import ReferenceElement


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
    (by a side or a corner) gather their quadrature points there
    (:func:`layer_rules._cluster`) so that ω is integrated as a smooth function.
    Triangles and closed bodies get ω = 1."""

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
