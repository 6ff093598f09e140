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
images are sums over points of the same shape (``RulePoints``).  The resistance of
one configuration, ``LayerResistance``, is ``rftfem.model.layer_resistance``'s.
"""

from __future__ import annotations

from math import pi
from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp

from rftfem.model import stokes_kernels as kernels
from rftfem.model import stokeslets
from rftfem.model.edge_weight import EdgeWeight
from rftfem.model.layer_resistance import KEPT_MOST as KEPT_MOST
from rftfem.model.layer_resistance import KEPT_RTOL as KEPT_RTOL
from rftfem.model.layer_resistance import LayerResistance as LayerResistance
from rftfem.model.layer_rules import NEAR, NEAR_FACTOR, ReferenceElement, RulePoints

if TYPE_CHECKING:
    from scipy.sparse.linalg import SuperLU


class Layer:
    """The layer's rules for one body (set up once, from the reference positions ``X``).

    ``cells`` (C, nd) are the elements' node indices into ``X`` in the reference
    element's order; ``rows`` the target nodes this process evaluates (a slice,
    default all)."""

    def __init__(
        self,
        X: np.ndarray,
        cells: np.ndarray,
        cell: str,
        epsilon: float,
        refine: int = 0,
        rows: slice | None = None,
        edge_weight: bool = True,
    ):
        self.X = np.asarray(X, dtype=float)
        self.cells = np.asarray(cells, dtype=np.int64)
        self.element = ReferenceElement(cell)
        self.epsilon, self.refine = float(epsilon), int(refine)
        n = len(self.X)
        self.rows = slice(0, n) if rows is None else rows
        #: the density's edge weight (``ω = 1`` everywhere without ``edge_weight``)
        self.weight = self._edge_weight(edge_weight)
        self._m = 2**self.refine
        self._set_far_rule()
        #: each element's size: √ of its reference area
        self.size = self._element_sizes()
        self.special = self._special_points()
        self._order_by_target()

    def _edge_weight(self, edge_weight: bool) -> EdgeWeight:
        """The density's edge weight on the reference positions, its reach ℓ set (none
        without ``edge_weight``)."""
        weight = EdgeWeight(self.element, self.cells if edge_weight else self.cells[:0], self.X)
        if not edge_weight:
            weight.sides = weight.corners = [()] * len(self.cells)
        else:  # ℓ from the plain far rule's points
            xi1, _ = self.element.rule(1)
            weight.set_reach(
                np.concatenate([self.element.basis(xi1) @ self.X[c] for c in self.cells])
            )
        return weight

    def _set_far_rule(self) -> None:
        """The far rule (every element's ``m × m`` Gauss pieces) and its scatter."""
        C = len(self.cells)
        rules = [self.rule(e, self._m) for e in range(C)]
        q = len(rules[0][1])
        elem = np.repeat(np.arange(C), q)
        #: the far rule: every element's Gauss points
        self._far_xi = np.concatenate([r[0] for r in rules])
        self.far = RulePoints(
            self.cells,
            self.element,
            elem,
            self._far_xi,
            self._weights(elem, self._far_xi, np.concatenate([r[1] for r in rules])),
        )
        self._P = self.far.scatter(len(self.X))
        #: the far rule's weight × basis (points × nodes of an element)
        self._far_wpsi = self.far.psi * self.far.weight[:, None]

    def _element_sizes(self) -> np.ndarray:
        """Each element's size: √ of its reference area (the plain rule's)."""
        C = len(self.cells)
        plain_xi, plain_w = self.element.rule(1)
        elem1 = np.repeat(np.arange(C), len(plain_w))
        area = np.bincount(
            elem1,
            weights=np.tile(plain_w, C)
            * self._reference_jacobian(elem1, np.tile(plain_xi, (C, 1))),
            minlength=C,
        )
        return np.sqrt(area)

    def _order_by_target(self) -> None:
        """The special points ordered by target: row t's are ``_starts[t]:_starts[t + 1]``."""
        order = np.argsort(self.special.target, kind="stable")
        for name in ("elem", "nodes", "psi", "weight", "target"):
            setattr(self.special, name, np.ascontiguousarray(getattr(self.special, name)[order]))
        self._starts = np.searchsorted(
            self.special.target, np.arange(self.rows.start, self.rows.stop + 1)
        )

    def _reference_jacobian(self, elem, xi) -> np.ndarray:
        """``|∂X/∂ξ₁ × ∂X/∂ξ₂|`` at the points ``xi`` of the elements ``elem``."""
        dpsi = self.element.gradients(xi)  # (P, nd, 2)
        J = np.einsum("paj,pak->pkj", dpsi, self.X[self.cells[elem]])  # (P, 3, 2)
        return np.linalg.norm(np.cross(J[:, :, 0], J[:, :, 1]), axis=1)

    def _weights(self, elem, xi, w) -> np.ndarray:
        """A reference rule's weights times the reference area and the edge weight."""
        return w * self._reference_jacobian(elem, xi) * self.weight(elem, xi)

    def rule(
        self, e: int, m: int, apex: np.ndarray | None = None, scale: float = 1.0
    ) -> tuple[np.ndarray, np.ndarray]:
        """Element ``e``'s reference points and weights (on the reference cell):
        ``m × m`` Gauss pieces, or the singular rule about the node at ``apex``."""
        weighted = self.weight.weighted(e)
        if apex is None:
            return self.element.rule(m, self.weight.cluster(e) if weighted else None)
        return self.element.singular_rule(apex, scale, self.refine, weighted)

    def _special_points(self) -> RulePoints:
        """The near and singular rules of this process's targets, with the far
        rule's points of the same pairs at negative weight."""
        cells, el, far = self.cells, self.element, self.far
        q = len(far.weight) // len(cells)
        # distances from every target to every element's far points (reference state)
        y = far.positions(self.X).reshape(len(cells), q, 3)
        targets = np.arange(self.rows.start, self.rows.stop)
        # (elem, ξ, weight, target) lists: reference weights (the singular rules, each
        # its own points) and weights made already (the near rule an element shares
        # between its targets, the far points taken off)
        raw, ready = ([], [], [], []), ([], [], [], [])

        def add(group, e, xi, w, t):
            for lst, v in zip(group, (np.full(len(w), e), xi, w, np.full(len(w), t))):
                lst.append(v)

        singular = {}  # the Duffy rules by node, edge weight and ε (in element sizes)
        # every element's near rule, weighted in one call
        rules = [self.rule(e, self._m * NEAR_FACTOR) for e in range(len(cells))]
        counts = [len(w) for _, w in rules]
        weights = np.split(
            self._weights(
                np.repeat(np.arange(len(cells)), counts),
                np.concatenate([xi for xi, _ in rules]),
                np.concatenate([w for _, w in rules]),
            ),
            np.cumsum(counts)[:-1],
        )
        for e in range(len(cells)):
            d = np.linalg.norm(self.X[targets, None, :] - y[e][None], axis=-1).min(axis=1)
            near = targets[d < NEAR * self.size[e]]
            members = list(cells[e])
            far_xi, far_w = self._far_of(e)
            for t in near:
                if t in members:
                    a = members.index(t)
                    scale = self.epsilon / self.size[e]
                    key = (a, self.weight.weighted(e), round(np.log(scale) * 16) if scale else 0)
                    if key not in singular:
                        singular[key] = self.rule(e, 0, apex=el.nodes[a], scale=scale)
                    add(raw, e, *singular[key], t)
                else:
                    add(ready, e, rules[e][0], weights[e], t)
                add(ready, e, far_xi, -far_w, t)
        if not ready[0]:
            return RulePoints(
                cells, el, np.zeros(0, int), np.zeros((0, 2)), np.zeros(0), np.zeros(0, int)
            )
        if raw[0]:
            elem, xi, w, t = (np.concatenate(v) for v in raw)
            ready[0].append(elem), ready[1].append(xi), ready[3].append(t)
            ready[2].append(self._weights(elem, xi, w))
        return RulePoints(cells, el, *(np.concatenate(v) for v in ready))

    def _far_of(self, e: int):
        """Element ``e``'s far points (reference coordinates) and weights."""
        q = len(self.far.weight) // len(self.cells)
        return self._far_xi[e * q : (e + 1) * q], self.far.weight[e * q : (e + 1) * q]

    # --- the operator ---------------------------------------------------------

    def matrix(
        self, x: np.ndarray, viscosity: float, wall: stokeslets.Wall | None = None
    ) -> np.ndarray:
        """The rows of ``A`` (3 n_rows × 3N) at the positions ``x``: ``u = A f`` (with a
        wall, summed in its frame and turned back: ``stokes_kernels.from_frame``)."""
        x = np.ascontiguousarray(x, dtype=float)
        if wall is not None:
            x = kernels.to_frame(wall.Q, wall.point, x)
        n = len(x)
        lo, hi = self.rows.start, self.rows.stop
        A = np.zeros((hi - lo, 3, n, 3))
        far, s = self.far, self.special
        kernels.far_matrix(
            x[lo:hi],
            far.positions(x),
            self._far_wpsi,
            far.nodes,
            self.epsilon,
            True,
            wall is not None,
            A,
        )
        kernels.pairs_matrix(x, lo, self._starts, s.psi, s.weight, s.nodes, self.epsilon, A)
        if wall is not None:
            A = kernels.from_frame(wall.Q, A)
        return A.reshape(3 * (hi - lo), 3 * n) / (8 * pi * viscosity)

    def position_derivative(
        self, x: np.ndarray, f: np.ndarray, viscosity: float, wall: stokeslets.Wall | None = None
    ) -> np.ndarray:
        """The rows of ``G = ∂(A f)/∂x`` at fixed ``f`` (3 n_rows × 3N)."""
        x = np.ascontiguousarray(x, dtype=float)
        f = np.ascontiguousarray(f, dtype=float).reshape(-1, 3)
        if wall is not None:
            x, f = kernels.to_frame(wall.Q, wall.point, x), kernels.to_frame(wall.Q, None, f)
        n = len(x)
        lo, hi = self.rows.start, self.rows.stop
        G = np.zeros((hi - lo, 3, n, 3))
        far, s = self.far, self.special
        kernels.far_derivative(
            x[lo:hi],
            np.arange(lo, hi),
            far.positions(x),
            far.psi,
            far.nodes,
            far.density(f),
            self.epsilon,
            True,
            wall is not None,
            G,
        )
        kernels.pairs_derivative(x, f, lo, self._starts, s.psi, s.weight, s.nodes, self.epsilon, G)
        if wall is not None:
            G = kernels.from_frame(wall.Q, G)
        return G.reshape(3 * (hi - lo), 3 * n) / (8 * pi * viscosity)

    # --- the nodal loads --------------------------------------------------------

    def mass(self) -> sp.csr_matrix:
        """``B_kl = ∫ ψ_k ψ_l dA₀`` (N × N): nodal loads from the density."""
        return (self._basis_matrix().T @ self._P).tocsr()

    def _basis_matrix(self) -> sp.csr_matrix:
        n = len(self.X)
        rows = np.repeat(np.arange(len(self.far.weight)), self.far.nodes.shape[1])
        return sp.csr_matrix(
            (self.far.psi.ravel(), (rows, self.far.nodes.ravel())), shape=(len(self.far.weight), n)
        )

    def mass_factors(self) -> tuple[sp.csr_matrix, SuperLU]:
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
