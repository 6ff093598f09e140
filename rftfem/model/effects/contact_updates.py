"""How far a Newton update (or a step's prediction) may go near a contact plane:
the update limits of :class:`~rftfem.model.effects.contact.Contact` (docs/contact.md §3).

The barrier's stiffness changes by orders of magnitude across its reach, and the
smoothed Coulomb force is nearly a step across the band of slip ε_v Δt: a full
Newton update can jump a node through the barrier, or turn a fast slip round and
back again.  :meth:`UpdateLimits.newton_step_fraction` gives the part of an update
that does neither; the solver applies it as SNES's line-search pre-check, the step
prediction before Newton starts.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from rftfem.forms import contact as forms
from rftfem.model.effects.base import LimitsNewtonStep

if TYPE_CHECKING:
    from rftfem.model.shell_model import Model


class UpdateLimits(LimitsNewtonStep):
    """The update limits of a contact component (it has ``planes``, ``u_start``,
    ``dn_start``, ``inv_dt`` and ``model``)."""

    _nodes = None

    def _nodal_data(self):
        """The owned nodes' reference positions, their rows of ``w``'s owned array, and
        the thickest adjacent cell's thickness (for the gaps of ``newton_step_fraction``)."""
        m = self.model
        owned_dofs = m.W.dofmap.index_map.size_local * m.W.dofmap.index_map_bs
        u_dofs = m.u_dofs.reshape(-1, 3)
        keep = np.all(u_dofs < owned_dofs, axis=1)
        X = m.Vu.tabulate_dof_coordinates()
        cells, t_cell = cell_thickness(m)
        t_node = np.zeros(len(X))
        np.maximum.at(t_node, cells.ravel(), np.repeat(t_cell, cells.shape[1]))
        return X[keep], u_dofs[keep], t_node[keep], keep

    def newton_step_fraction(self, x: np.ndarray, y: np.ndarray, keep: float = 0.2) -> float:
        """The longest part of the Newton update ``−y`` from ``x`` (owned arrays of
        ``w``) that keeps every node's barrier argument ``s = g + δ`` above ``keep`` of
        its value, ``s + Δs ≥ keep·s`` (IPC's filtered line search, on the nodal
        displacements with the director of the step's start): a Newton update that
        would jump a node through the barrier into its clamped region is shortened.
        A step's prediction keeps 0.3 (step_state.py): from deep in the barrier Newton
        climbs back only by doubling ``s`` an update.

        Friction alike: where a node within the barrier's reach slips faster than
        ``ε_v`` and the update would turn its slip velocity round (``v·v_new < 0``),
        the update stops where the slip's component along ``v`` is half of ``|v|``.  Across the
        band of width ε_v the smoothed Coulomb force is nearly a step, and a full
        update from one side lands on the other and back again (a two-state cycle,
        docs/contact.md §3).  Global over processes."""
        if self._nodes is None:
            self._nodes = self._nodal_data()
        X, rows, t, owned = self._nodes
        d = self.dn_start[0].x.array.reshape(-1, 3)[owned]
        u, du = x[rows], -y[rows]
        fraction = 1.0
        for plane in self.planes:
            n, reach = plane.normal, plane.reach
            s = (X + u - 0.5 * t[:, None] * d - plane.point) @ n + reach
            ds = du @ n
            # closing in, ending within the barrier's reach, and not already past its
            # logarithmic part (there the Taylor polynomial holds it, and Newton walks out)
            closing = (ds < 0.0) & (s < 2.0 * reach - ds) & (s > forms.CLAMP * 2.0 * reach)
            if np.any(closing):
                fraction = min(fraction, float(np.min((1.0 - keep) * s[closing] / -ds[closing])))
            fraction = min(fraction, self._slip_fraction(plane, s, u, du, owned))
        return self.model.comm.allreduce(min(fraction, 1.0), op=_mpi_min())

    def _slip_fraction(self, plane, s, u, du, owned) -> float:
        """The part of an update ``du`` (nodal displacements) that turns no fast slip
        of a node within reach round (``newton_step_fraction``)."""
        inv_dt = float(self.inv_dt.value)
        # (not in a run's first step: a body starting to slide from rest overshoots,
        # and the band's stiffness at zero slip holds it back by itself)
        if inv_dt == 0.0 or not plane.rubs or not self.model.increments:
            return 1.0
        n, eps2 = plane.normal, plane.slip_velocity**2
        tangential = lambda a: a - np.outer(a @ n, n)  # noqa: E731
        v = tangential((u - self.u_start.x.array.reshape(-1, 3)[owned]) * inv_dt)
        dv = tangential(du * inv_dt)
        along = np.einsum("ij,ij->i", v, dv)
        speed2 = np.einsum("ij,ij->i", v, v)
        turning = (s < 2.0 * plane.reach) & (speed2 > eps2) & (speed2 + along < 0.0)
        if not np.any(turning):
            return 1.0
        # halve the slip along its direction: a stick is then reached in a few
        # halvings, and a slip the update overshot is walked back without a cycle
        return float(np.min(0.5 * speed2[turning] / -along[turning]))


def cell_thickness(model: Model) -> tuple[np.ndarray, np.ndarray]:
    """Each cell's nodes of ``Vu`` (cells × nodes) and its thickness (DG0)."""
    from rftfem import compat

    t = model.material["t"]
    return compat.cell_dofs(model.Vu), t.x.array[compat.cell_dofs(t.function_space)[:, 0]]


def _mpi_min():
    from mpi4py import MPI

    return MPI.MIN
