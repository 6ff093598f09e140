"""Nodal directors: what the forms see of the rotation unknowns (docs/model.md §4.3).

Newton's unknowns are ``w = (u, θ¹, θ², ...)``: at every node the two components
of its director's rotation increment in the node's own tangent basis ``(a₁, a₂)``.
The forms are written on ``z = (u, d, ...)``, with ``d`` the nodal directors

    d_I = cos|θ_I| dₙ_I + (sin|θ_I|/|θ_I|) θ_I × dₙ_I,    θ_I = θ¹_I a₁_I + θ²_I a₂_I,

interpolated between the nodes (and normalised where used).  What is interpolated
is a unit vector per node, whatever tangent basis that node's θ is given in, so a
rigid motion of any surface, closed or open, is a rigid motion of the interpolated
director too and costs no strain.

The map ``w → z`` is node by node: ``Φ`` (:func:`nodal_directors`), its first
derivative ``B_I = ∂d_I/∂θ_I`` (3×2) and the second, contracted with the forms'
residual at the node, ``G_I`` (2×2, :func:`director_curvature`).  The residual
and the tangent in ``w`` are then

    R_w = Pᵀ R_z,        K_w = Pᵀ K_z P + G,

with ``P`` the block-diagonal matrix of the ``B_I`` (and the identity on ``u``).
:class:`DirectorMap` holds the map, and ``P`` and ``G`` as PETSc matrices;
rftfem/model/mapped_forms.py assembles the forms on ``z`` into ``w``'s vectors and
matrices, so that the solver is written as if the forms were on ``w``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from rftfem.model.shell_model import Model

#: below this ``|θ|²`` the coefficients below take their Taylor series
SERIES_BELOW = 1e-2


#: the Taylor coefficients of c(s) = cos√s = Σ (−s)^k/(2k)! and f(s) = sin√s/√s =
#: Σ (−s)^k/(2k+1)!, and of f's first two derivatives, k = 0..8 (the first term left
#: out is below 1e-2⁹/19! ~ 1e-35)
_K = np.arange(9)
_C_SERIES = (-1.0) ** _K / np.array([float(np.prod(np.arange(1, 2 * k + 1))) for k in _K])
_F_SERIES = (-1.0) ** _K / np.array([float(np.prod(np.arange(1, 2 * k + 2))) for k in _K])
_F1_SERIES = (_K * _F_SERIES)[1:]
_F2_SERIES = (_K * (_K - 1) * _F_SERIES)[2:]


def _coefficients(s: np.ndarray):
    """``c = cos√s``, ``f = sin√s/√s``, ``f' = df/ds``, ``f'' = d²f/ds²`` (and
    ``c' = −f/2``, ``c'' = −f'/2``), by their series below ``SERIES_BELOW``."""
    small = s < SERIES_BELOW
    sb = np.where(small, 1.0, s)
    r = np.sqrt(sb)
    c, f = np.cos(r), np.sin(r) / r
    f1 = (c - f) / (2 * sb)
    f2 = (-f / 2 - f1) / (2 * sb) - (c - f) / (2 * sb**2)
    if small.any():
        x = s[small]
        c[small], f[small] = (np.polyval(_C_SERIES[::-1], x), np.polyval(_F_SERIES[::-1], x))
        f1[small] = np.polyval(_F1_SERIES[::-1], x)
        f2[small] = np.polyval(_F2_SERIES[::-1], x)
    return c, f, f1, f2


def nodal_directors(
    q: np.ndarray, a1: np.ndarray, a2: np.ndarray, dn: np.ndarray, derivatives: bool = False
) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    """The directors ``d_I`` (rows) of the rotation components ``q`` (n, 2) in the
    nodal bases ``a1, a2`` about the last directors ``dn`` (each (n, 3)); with
    ``derivatives``, also ``B = ∂d/∂q`` (n, 3, 2)."""
    theta = q[:, 0:1] * a1 + q[:, 1:2] * a2
    s = np.sum(theta * theta, axis=1)
    c, f, f1, _ = _coefficients(s)
    cross = np.cross(theta, dn)
    d = c[:, None] * dn + f[:, None] * cross
    if not derivatives:
        return d
    B = np.empty((len(q), 3, 2))
    for alpha, a in enumerate((a1, a2)):
        t_a = np.sum(theta * a, axis=1)  # ∂s/∂q_α = 2 θ·a_α
        B[:, :, alpha] = (
            (2 * t_a * (-f / 2))[:, None] * dn
            + (2 * t_a * f1)[:, None] * cross
            + f[:, None] * np.cross(a, dn)
        )
    return d, B


def director_curvature(
    q: np.ndarray, a1: np.ndarray, a2: np.ndarray, dn: np.ndarray, r: np.ndarray
) -> np.ndarray:
    """``G_αβ = r · ∂²d/∂q_α∂q_β`` (n, 2, 2): the second derivative of each node's
    director, contracted with the residual ``r`` (n, 3) at its director."""
    theta = q[:, 0:1] * a1 + q[:, 1:2] * a2
    s = np.sum(theta * theta, axis=1)
    c, f, f1, f2 = _coefficients(s)
    r_dn = np.sum(r * dn, axis=1)
    r_x = np.sum(r * np.cross(theta, dn), axis=1)
    basis = (a1, a2)
    t = [np.sum(theta * a, axis=1) for a in basis]
    r_ax = [np.sum(r * np.cross(a, dn), axis=1) for a in basis]
    G = np.empty((len(q), 2, 2))
    for al in range(2):
        for be in range(2):
            ab = np.sum(basis[al] * basis[be], axis=1)
            # d = c(s) dn + f(s) θ×dn, s = θ·θ, ∂s/∂q_α = 2 t_α, ∂²s = 2 (a_α·a_β)
            G[:, al, be] = (
                r_dn * (-f1 / 2 * 4 * t[al] * t[be] + (-f / 2) * 2 * ab)
                + r_x * (f2 * 4 * t[al] * t[be] + f1 * 2 * ab)
                + 2 * f1 * (t[be] * r_ax[al] + t[al] * r_ax[be])
            )
    return G


class DirectorMap:
    """The map ``w → z`` of a Model, its derivative ``P`` and its curvature ``G``.

    ``Z`` is [P2]^(3+3c) on the nodes of ``W`` = [P2]^(3+2c), numbered alike: node
    ``n`` holds ``(u, θ_0, θ_1, ...)`` at ``w[n bw : (n+1) bw]`` and ``(u, d_0,
    d_1, ...)`` at ``z[n bz : (n+1) bz]``.  Node by node, on owned and ghost nodes
    alike from ghost-updated values, so every copy of a node maps the same.
    """

    def __init__(self, model: Model):
        from dolfinx import fem

        from rftfem import compat

        self.model = m = model
        c = m.n_colours
        self.bw, self.bz = m.block, 3 + 3 * c
        self.Z = compat.function_space(m.mesh, "Lagrange", 2, (self.bz,))
        self.z = fem.Function(self.Z, name="z")
        im = m.W.dofmap.index_map
        if (
            self.Z.dofmap.index_map.size_local != im.size_local
            or self.Z.dofmap.index_map.num_ghosts != im.num_ghosts
        ):
            raise RuntimeError("the directors' nodes are not numbered as the unknowns'")
        self.nodes, self.owned = im.size_local + im.num_ghosts, im.size_local
        n = np.arange(self.nodes)
        self.u_z = (self.bz * n[:, None] + np.arange(3)[None, :]).ravel()
        self.d_z = [self.bz * n[:, None] + 3 + 3 * k + np.arange(3)[None, :] for k in range(c)]
        self.q_w = [dofs.reshape(-1, 2) for dofs in m.theta_dofs_of]

        # P (rows: owned z dofs, columns: w dofs) and G's pattern, in CSR of global indices
        g = im.local_range[0] + np.arange(self.owned)
        self._init_P(g, c)
        self._init_G(g, c)
        self._B = None  # the last map's derivatives, per colour (nodes, 3, 2)
        self._last = None  # (w, triads, with B) of the last sync

    def _init_P(self, g: np.ndarray, c: int) -> None:
        """``P``'s pattern (per node: u rows on u, each colour's d rows on its θ pair),
        with its u rows' values 1; ``g`` the owned nodes' global numbers."""
        from petsc4py import PETSc

        pattern = [[i] for i in range(3)]  # each z row's w columns, within a node
        for k in range(c):
            pattern += [[3 + 2 * k, 4 + 2 * k]] * 3
        counts = np.array([len(p) for p in pattern])
        local_cols = np.concatenate(pattern)
        self._P_indptr = np.concatenate([[0], np.cumsum(np.tile(counts, self.owned))]).astype(
            PETSc.IntType
        )
        self._P_cols = (self.bw * g[:, None] + local_cols[None, :]).ravel().astype(PETSc.IntType)
        size_z = (self.owned * self.bz, PETSc.DETERMINE)
        size_w = (self.owned * self.bw, PETSc.DETERMINE)
        self.P = PETSc.Mat().createAIJ(
            (size_z, size_w),
            bsize=(self.bz, self.bw),
            comm=self.model.comm,
            csr=(self._P_indptr, self._P_cols, np.zeros(len(self._P_cols))),
        )
        self.P.assemble()
        self._P_values = np.zeros(len(self._P_cols))
        # the u rows: value 1, always
        per_node = len(local_cols)
        self._P_values.reshape(self.owned, per_node)[:, :3] = 1.0

    def _init_G(self, g: np.ndarray, c: int) -> None:
        """``G``'s pattern: per colour, 2x2 on each owned node's θ pair."""
        from petsc4py import PETSc

        # G: per colour, 2x2 on the node's θ pair; every w row present (empty rows too)
        g_counts = np.zeros(self.bw, dtype=np.int64)
        g_counts[3:] = 2
        self._G_indptr = np.concatenate([[0], np.cumsum(np.tile(g_counts, self.owned))]).astype(
            PETSc.IntType
        )
        pair_cols = np.concatenate([[3 + 2 * k, 4 + 2 * k] * 2 for k in range(c)])
        self._G_cols = (self.bw * g[:, None] + pair_cols[None, :]).ravel().astype(PETSc.IntType)
        size_w = (self.owned * self.bw, PETSc.DETERMINE)
        self.G = PETSc.Mat().createAIJ(
            (size_w, size_w),
            comm=self.model.comm,
            csr=(self._G_indptr, self._G_cols, np.zeros(len(self._G_cols))),
        )
        self.G.assemble()

    def frames(self, colour: int) -> tuple[np.ndarray, ...]:
        """``(a₁, a₂, dₙ)`` of a colour, as (nodes, 3) arrays."""
        return tuple(f.x.array.reshape(-1, 3) for f in self.model.triads[colour])

    def map(
        self, w: np.ndarray, out: np.ndarray | None = None, derivatives: bool = False
    ) -> np.ndarray:
        """``z = Φ(w)`` (local arrays, ghosts included); with ``derivatives`` keeps ``B``."""
        z = self.z.x.array if out is None else out
        z[self.u_z] = w[self.model.u_dofs]
        B = []
        for k, (d_dofs, q_dofs) in enumerate(zip(self.d_z, self.q_w)):
            a1, a2, dn = self.frames(k)
            res = nodal_directors(w[q_dofs], a1, a2, dn, derivatives)
            d = res[0] if derivatives else res
            z[d_dofs] = d
            B.append(res[1] if derivatives else None)
        if derivatives:
            self._B = B
        return z

    def direction(self, w: np.ndarray, dw: np.ndarray, out: np.ndarray) -> np.ndarray:
        """``P(w) dw`` into the local z array ``out``: the change of ``z`` to first order
        when ``w`` moves by ``dw`` (the map's own ``B`` is left as it was)."""
        out[self.u_z] = dw[self.model.u_dofs]
        for k, (d_dofs, q_dofs) in enumerate(zip(self.d_z, self.q_w)):
            _, B = nodal_directors(w[q_dofs], *self.frames(k), derivatives=True)
            out[d_dofs] = np.einsum("nka,na->nk", B, dw[q_dofs])
        return out

    def sync(self, derivatives: bool = False) -> None:
        """The model's ``z`` from its iterate ``w`` (again only if ``w`` or a triad has
        changed since the last time, or ``B`` is asked for and was not made)."""
        w = self.model.w.x.array
        frames = [f.x.array for frame in self.model.triads for f in frame]
        last = self._last
        if (
            last is not None
            and (last[2] or not derivatives)
            and np.array_equal(last[0], w)
            and all(np.array_equal(a, b) for a, b in zip(last[1], frames))
        ):
            return
        self.map(w, derivatives=derivatives)
        self._last = (w.copy(), [f.copy() for f in frames], derivatives)

    def add_transposed(self, z_local: np.ndarray, w_local: np.ndarray) -> None:
        """``w += Pᵀ z`` on local arrays (unsummed: ghost rows are summed by the caller),
        with the ``B`` of the last ``sync(derivatives=True)``."""
        w_local[self.model.u_dofs] += z_local[self.u_z]
        for B, d_dofs, q_dofs in zip(self._B, self.d_z, self.q_w):
            w_local[q_dofs] += np.einsum("nka,nk->na", B, z_local[d_dofs])

    def apply(self, w_local: np.ndarray) -> np.ndarray:
        """``P w`` as a local z array (a direction of ``w`` as one of ``z``)."""
        z = np.zeros(self.nodes * self.bz)
        z[self.u_z] = w_local[self.model.u_dofs]
        for B, d_dofs, q_dofs in zip(self._B, self.d_z, self.q_w):
            z[d_dofs] = np.einsum("nka,na->nk", B, w_local[q_dofs])
        return z

    def update_P(self) -> None:
        """``P``'s values from the last ``B``."""
        values = self._P_values.reshape(self.owned, -1)
        for k, B in enumerate(self._B):
            values[:, 3 + 6 * k : 9 + 6 * k] = B[: self.owned].reshape(self.owned, 6)
        self.P.setValuesCSR(self._P_indptr, self._P_cols, self._P_values)
        self.P.assemble()

    def update_G(self, r_z_local: np.ndarray, scale: float = 1.0) -> None:
        """``G`` from the summed z residual ``r_z`` (owned rows valid), times ``scale``."""
        w = self.model.w.x.array
        values = np.zeros((self.owned, len(self._G_cols) // self.owned))
        for k, (d_dofs, q_dofs) in enumerate(zip(self.d_z, self.q_w)):
            a1, a2, dn = (f[: self.owned] for f in self.frames(k))
            own = slice(0, self.owned)
            Gk = director_curvature(w[q_dofs[own]], a1, a2, dn, r_z_local[d_dofs[own]])
            values[:, 4 * k : 4 * k + 4] = scale * Gk.reshape(self.owned, 4)
        self.G.setValuesCSR(self._G_indptr, self._G_cols, values.ravel())
        self.G.assemble()

    def node_matrices(self) -> np.ndarray:
        """``P`` node by node, (nodes, bz, bw), from the last ``B`` (ghosts included)."""
        P = np.zeros((self.nodes, self.bz, self.bw))
        P[:, 0, 0] = P[:, 1, 1] = P[:, 2, 2] = 1.0
        for k, B in enumerate(self._B):
            P[:, 3 + 3 * k : 6 + 3 * k, 3 + 2 * k : 5 + 2 * k] = B
        return P

    def node_curvatures(self, r_z_local: np.ndarray) -> np.ndarray:
        """``G`` node by node on the owned nodes, (owned, bw, bw), from the summed z
        residual ``r_z`` (owned rows valid)."""
        w = self.model.w.x.array
        G = np.zeros((self.owned, self.bw, self.bw))
        own = slice(0, self.owned)
        for k, (d_dofs, q_dofs) in enumerate(zip(self.d_z, self.q_w)):
            a1, a2, dn = (f[own] for f in self.frames(k))
            G[:, 3 + 2 * k : 5 + 2 * k, 3 + 2 * k : 5 + 2 * k] = director_curvature(
                w[q_dofs[own]], a1, a2, dn, r_z_local[d_dofs[own]]
            )
        return G

    def destroy(self) -> None:
        for obj in (self.P, self.G):
            obj.destroy()
