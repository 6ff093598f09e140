"""Reactions: the force and moment each named ``[[boundary]]`` and ``[[motion]]``
entry exerts on the body (docs/model.md §5.7), written to body.csv as
``NAME_Fx, NAME_Fy, NAME_Fz, NAME_Mx, NAME_My, NAME_Mz``.

A held degree of freedom's row is the one equation a step does not solve: the
residual there is what the condition must supply.  With ``R`` the residual of
the converged step *before* its Dirichlet rows are replaced (internal minus
external forces, the scheme's blend with the last step's forces, inertia),

    force   F = Σ_i R_i e_i                     over the entry's held u dofs,
    moment  M = Σ_i x_i × R_i e_i + Σ_k m_k     about the origin,

``x_i`` the dof's node in the converged state and ``m_k`` the couple of the
held rotation dofs of node ``k``: a held ``θ^α`` row is the virtual work of a
couple ``m`` on the turn ``T(φ) a_α`` the dof makes (``φ`` the step's rotation
at the node, ``T`` the tangent of the rotation map), and ``m`` is taken in the
plane those turns span (the director carries no drilling couple).  At a
clamped node ``φ = 0`` and ``m = Σ_α R_α a_α``.

So the reaction is the load the condition carries, the sign that of a load on
the body: a cantilever's clamp under a tip force P carries −P, and a
``[[motion]]`` that drives a point reads back the force it takes to drive it.
Summed with the applied loads, inertia and drag over the body it balances to
the solver's residual on the free rows.  A dof held by two named entries (the
corner where two clamped edges meet) counts in the first of them, in the
scene's order, so the named reactions add up to what all of them carry.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from rftfem.model.shell_model import Model

COMPONENTS = ("Fx", "Fy", "Fz", "Mx", "My", "Mz")


def tangent_map(phi: np.ndarray) -> np.ndarray:
    """``T(φ)`` per row of ``phi`` (n, 3): the spatial angular velocity of the rotation
    ``exp(φ)`` is ``T(φ) φ̇``; ``T = I + (1 − cos p)/p² Φ + (p − sin p)/p³ Φ²``."""
    p = np.linalg.norm(phi, axis=1)
    small = p < 1e-6
    ps = np.where(small, 1.0, p)
    c1 = np.where(small, 0.5 - p**2 / 24, (1 - np.cos(ps)) / ps**2)
    c2 = np.where(small, 1 / 6 - p**2 / 120, (ps - np.sin(ps)) / ps**3)
    skew = np.zeros((len(phi), 3, 3))
    skew[:, 0, 1], skew[:, 0, 2], skew[:, 1, 2] = -phi[:, 2], phi[:, 1], -phi[:, 0]
    skew[:, 1, 0], skew[:, 2, 0], skew[:, 2, 1] = phi[:, 2], -phi[:, 1], phi[:, 0]
    return np.eye(3)[None] + c1[:, None, None] * skew + c2[:, None, None] * (skew @ skew)


class Reactions:
    """The named entries' held dofs, sorted once into displacement and rotation dofs."""

    def __init__(self, model: Model):
        self.model = model
        named = [item for comp in model.components for item in comp.reaction_dofs()]
        self.names = [name for name, _ in named]
        self.columns = [f"{name}_{c}" for name in self.names for c in COMPONENTS]
        n_owned = model.W.dofmap.index_map.size_local * model.W.dofmap.index_map_bs
        size = len(model.w.x.array)
        # a mixed dof -> (u node, component), or (colour, θ pair, α)
        u_node = np.full(size, -1, dtype=np.int64)
        u_node[model.u_dofs] = np.arange(len(model.u_dofs))
        theta_of = np.full((size, 3), -1, dtype=np.int64)
        for c, dofs in enumerate(model.theta_dofs_of):
            k = np.arange(len(dofs))
            theta_of[dofs] = np.stack([np.full_like(k, c), k // 2, k % 2], axis=1)
        self.X = model.Vu.tabulate_dof_coordinates()
        self.entries = []
        claimed = np.zeros(size, dtype=bool)
        for _, dofs in named:
            dofs = np.unique(np.asarray(dofs, dtype=np.int64))
            dofs = dofs[(dofs < n_owned) & ~claimed[dofs]]  # counted once, by its owner
            claimed[dofs] = True
            on_u = u_node[dofs] >= 0
            self.entries.append(
                (dofs[on_u], u_node[dofs[on_u]], dofs[~on_u], theta_of[dofs[~on_u]])
            )
        #: the last values computed (one row of 6 per entry), written by the outputs
        self.last = np.zeros((len(self.names), 6))

    def __bool__(self):
        return bool(self.names)

    def compute(self, residual: np.ndarray) -> np.ndarray:
        """Force and moment per entry (n_entries, 6) from the local array of the raw
        residual at the converged iterate (``model.w``); global, on every rank."""
        m = self.model
        w = m.w.x.array
        u = w[m.u_dofs]
        out = np.zeros((len(self.entries), 6))
        for e, (udofs, ui, tdofs, tinfo) in enumerate(self.entries):
            node, comp = ui // 3, ui % 3
            f = np.zeros((len(udofs), 3))
            f[np.arange(len(udofs)), comp] = residual[udofs]
            x = self.X[node] + u.reshape(-1, 3)[node]
            out[e, :3] = f.sum(axis=0)
            out[e, 3:] = np.cross(x, f).sum(axis=0)
            for c in np.unique(tinfo[:, 0]) if len(tdofs) else []:
                mine = tinfo[:, 0] == c
                out[e, 3:] += self._couples(
                    c, tinfo[mine, 1], tinfo[mine, 2], residual[tdofs[mine]]
                )
        out = m.comm.allreduce(out)
        self.last = out
        return out

    def _couples(self, colour, pairs, alphas, values):
        """The summed couple of held rotation rows (see the module's docstring)."""
        m = self.model
        a1, a2, _ = (f.x.array.reshape(-1, 3) for f in m.triads[colour])
        theta = m.w.x.array[m.theta_dofs_of[colour]].reshape(-1, 2)
        total = np.zeros(3)
        for p in np.unique(pairs):
            node = m.triad.node_maps[colour][p]
            phi = theta[p, 0] * a1[node] + theta[p, 1] * a2[node]
            T = tangent_map(phi[None])[0]
            turns = np.stack([T @ a1[node], T @ a2[node]])  # the turns of θ¹, θ²
            rows = np.zeros(2)
            held = np.zeros(2, dtype=bool)
            for a, v in zip(alphas[pairs == p], values[pairs == p]):
                rows[a] += v
                held[a] = True
            # m in the plane of the turns with m·turn_α = row_α for the held α
            # (a held θ¹ alone: m along turn₁'s dual direction in that plane)
            gram = turns @ turns.T
            coef = (
                np.linalg.solve(gram, rows)
                if held.all()
                else np.where(held, rows / np.diag(gram), 0.0)
            )
            total += coef @ turns
        return total
