"""Exact sensitivities of static scenes: the adjoint of the converged residual
(docs/model.md §7.6).

A static run ends with a converged Newton solve of its last load step in the
unknowns ``w = (u, θ)``, θ the rotation increment about the nodal triads ``T`` of
the step before (docs/model.md §4).  With those triads held fixed, the final
state solves

    R(w; p) = 0,            R = F(w) of docs/model.md §5.1 (static: no α_f, no inertia),

and an objective ``J(w; p)`` evaluated there has, with ``K = ∂R/∂w``,

    Kᵀ λ = ∂J/∂w           (λ = 0 on the Dirichlet dofs, whose values do not depend on p),
    dJ/dp = ∂J/∂p − λᵀ ∂R/∂p.

``K`` is the exact tangent: the model's compiled Jacobian assembled with the
mixed-point defects set to zero (``StepSolver.assemble_tangent``, the tangent a
static load step starts from, docs/model.md §7.4), so no extra Jacobian form is
compiled; it is not symmetric with magnetic couples or a follower pressure, and
the transposed system is solved by a fresh LU (MUMPS where PETSc has it).  The
parameter derivatives ``∂R/∂p`` and ``∂J/∂p`` are ``ufl.derivative`` of the
model's own residual and objective forms:

- material keys (``shell.E``, ``shell.nu``, ``shell.thickness``, ``shell.density``
  and the same of ``shell.parts.N``) along the cellwise field they set, in the
  direction of the cells whose value the key decides (a part that inherits a
  value from ``[shell]`` moves with ``shell.E``), found by loading the scene with
  the key at two values and building the fields as the Model does;
- load values (``load.N.value.I``, ``load.N.value`` of a pressure) and the
  rotating field's ``magnetic.field.strength``: the Constants of the forms at
  ``time.end`` are linear in them; their direction is what the components'
  ``set_time`` makes of a unit value (minus that of zero), and the Constant is
  differentiated through a zero DG0 shift ``c + s δc`` (UFL 2022 cannot
  differentiate by a Constant); a point force's nodal vector the same way through
  its own ``add_nodal_forces``;
- ``magnetic.parts.N.magnetization`` (a plain number > 0) along the cellwise
  remanence ``M = m q₀`` in the direction ``q₀`` on the part's cells.

Objectives: a probe's displacement component at the end (a point evaluation,
``∂J/∂w`` the shape functions of its cell at the point on the u dofs), and the
body's ``centroid_x|y|z`` and ``elastic_energy`` at the end (``ufl.derivative`` of
their forms).  They are evaluated on the converged state of the last step,
before its triad update: a probe is the last row of probes.csv; a body integral
may differ from the last row of body.csv, which is taken after the update, by the
update's interpolation error (docs/model.md §4.3).

What "exact" means.  The derivative is exact for the problem of the last step,
its starting triads held.  The triads themselves came from the earlier load steps
and depend on p through them; the equilibrium of the continuous shell does not
depend on the load path, and the discrete one only through the interpolation of
the triad update (§4.3), so the term left out, ``∂J/∂T · dT/dp``, is of the size
of the path dependence, second order in the cell size.  A run of one load step
(``time.dt = time.end``) starts from the reference triads and has no such term.

Overdamped runs (backward Euler) would need an adjoint backwards over every stored
state and the triad updates' linearisation: not here (docs/model.md).

API: ``gradient(sim, last, keys, objective)`` on a Simulation that has run
with ``last = keep_last_step(sim.model)``; ``check_request(scene, keys, objective)``;
``supports(keys, objective[, scene])``.
"""

from __future__ import annotations

from types import SimpleNamespace
from typing import TYPE_CHECKING

import numpy as np

from rftfem.errors import RunFailed

# the request (keys and objective) is checked there; re-exported for callers
from rftfem.studies.sensitivity_request import (  # noqa: F401
    KEYS_SUPPORTED,
    MATERIAL_FIELDS,
    OBJECTIVES_SUPPORTED,
    PROBE_VALUES,
    Key,
    Objective,
    check_request,
    combined_objective,
    parse_key,
    supports,
)

if TYPE_CHECKING:
    from collections.abc import Callable, Sequence

    from rftfem.integration.simulation import Simulation
    from rftfem.model.shell_model import Model
    from rftfem.studies.field_gradients import FieldGradient

# --- the state the last step converged to -------------------------------------------


def keep_last_step(model: Model) -> dict:
    """Make ``model`` keep, at every triad update, the converged iterate and the triads
    it is measured in (the update then turns them); returns the dict that holds the
    last ones (``w``, ``triads``)."""
    last = {}
    update = model.update_triad

    def update_triad():
        last["w"] = model.w.x.array.copy()
        last["triads"] = [[f.x.array.copy() for f in frame] for frame in model.triads]
        update()

    model.update_triad = update_triad
    return last


def _restore(model, last: dict) -> None:
    model.w.x.array[:] = last["w"]
    for frame, arrays in zip(model.triads, last["triads"]):
        for f, a in zip(frame, arrays):
            f.x.array[:] = a


# --- the derivatives ------------------------------------------------------------------


class _Adjoint:
    """The converged last step of a Simulation and the derivatives of ``R`` and ``J``."""

    def __init__(self, sim):
        from dolfinx import fem
        from petsc4py import PETSc

        from rftfem import compat

        self.sim, self.model = sim, sim.model
        m = self.model
        self.V0 = compat.function_space(m.mesh, "DG", 0)
        #: the zero shift s of a Constant (c + s δc) and the direction 1 it is moved in
        self.shift = fem.Function(self.V0, name="parameter_shift")
        self.one = fem.Function(self.V0, name="one")
        self.one.x.array[:] = 1.0
        self.PETSc = PETSc

    def vec(self):
        """A new vector of ``W`` (ghosted), not zeroed."""
        from rftfem import compat

        return compat.create_vector(self.model.forces_form, self.model.W)

    # the forms' parameters ---------------------------------------------------------

    def directions(self, key: Key) -> tuple[list, np.ndarray | None]:
        """``[(coefficient, its derivative by the key)]`` (a Function and a DG0 Function,
        or a Constant and a Constant), and the derivative of the nodal forces (local
        array, or None)."""
        if key.kind == "material":
            return self._material_directions(key), None
        if key.kind == "magnetization":
            return self._magnetization_directions(key), None
        return self._constant_directions(key)

    def _material_directions(self, key: Key) -> list:
        """The cells whose value the key decides, from the fields the Model would build
        with the key at two values (inheritance by shell.parts included)."""
        from rftfem.model.shell_model import Model
        from rftfem.scene.reading import with_overrides

        scene, m = self.model.scene, self.model
        fields = []
        for value in PROBE_VALUES:
            probe = SimpleNamespace(
                scene=with_overrides(scene, [f"{key.text}={value!r}"]),
                mesh=m.mesh,
                body=m.body,
                comm=m.comm,
            )
            Model._init_materials(probe)
            fields.append(probe.material[MATERIAL_FIELDS[key.name]])
        high, low = fields
        high.x.array[:] = (high.x.array - low.x.array) / (PROBE_VALUES[0] - PROBE_VALUES[1])
        return [(m.material[MATERIAL_FIELDS[key.name]], high)]

    def _magnetization_directions(self, key: Key) -> list:
        """M = m q₀ on the part's cells: its derivative by m is q₀ there."""
        from dolfinx import fem

        from rftfem import compat

        mag = self.model["magnetic"]
        M = mag.remanence
        direction = fem.Function(M.function_space, name="dM")
        dofs = compat.cell_dofs(M.function_space)[:, 0]
        cells = dofs[mag.part_cells[key.index]]
        m = float(self.model.scene["magnetic"]["parts"][key.index]["magnetization"])
        direction.x.array.reshape(-1, 3)[cells] = M.x.array.reshape(-1, 3)[cells] / m
        direction.x.scatter_forward()
        return [(M, direction)]

    def _scene_value(self, key: Key):
        """(the dict holding the key's value, its key, the value)."""
        scene = self.model.scene
        if key.kind == "load":
            holder = scene["load"][key.index]
        else:
            holder = scene["magnetic"]["field"]
        return holder, key.name, holder[key.name]

    def _constant_directions(self, key: Key):
        """The forms' Constants at time.end, and the nodal forces, are linear in a load
        value or the field strength: their derivative is what the components make of a
        unit value less what they make of zero (their own set_time)."""
        from dolfinx import fem

        m, end = self.model, self.model.scene["time"]["end"]
        constants = m.forces_ufl.constants()
        holder, name, value = self._scene_value(key)

        def made_of(v):
            holder[name] = v
            m.set_time(end)
            nodal = np.zeros(len(m.w.x.array))
            m.add_nodal_forces(nodal)
            return [np.array(c.value, dtype=float, copy=True) for c in constants], nodal

        def unit(x):
            if key.component is None:
                return x
            out = [0.0, 0.0, 0.0]
            out[key.component] = x
            return out

        try:
            (on, nodal_on), (off, nodal_off) = made_of(unit(1.0)), made_of(unit(0.0))
        finally:
            holder[name] = value
            m.set_time(end)
        pairs = []
        for c, a, b in zip(constants, on, off):
            if np.any(a != b):
                pairs.append((c, fem.Constant(m.mesh, (a - b).astype(self.PETSc.ScalarType))))
        nodal = nodal_on - nodal_off  # on the process that holds a point force only
        return pairs, (nodal if m.comm.allreduce(int(np.any(nodal != 0.0))) else None)

    def derivative(self, form, pairs):
        """``Σ ∂form/∂c [δc]`` by ``ufl.derivative``: directly for a Function, through the
        zero shift ``c + s δc`` for a Constant; None if the form has none of them."""
        import ufl
        from dolfinx import fem

        terms = []
        shifted = {}
        present = set(form.coefficients()) | set(form.constants())
        for c, dc in pairs:
            if c not in present:
                continue
            if isinstance(c, fem.Function):
                terms.append(ufl.derivative(form, c, dc))
            else:
                shifted[c] = c + self.shift * dc
        if shifted:
            terms.append(ufl.derivative(ufl.replace(form, shifted), self.shift, self.one))
        return sum(terms[1:], terms[0]) if terms else None

    # assembly --------------------------------------------------------------------------

    def assemble(self, form):
        """A 1-form on ``z`` assembled as one of ``W`` into a new (ghost-summed) vector."""
        from rftfem import compat

        b = self.vec()
        with b.localForm() as local:
            local.set(0.0)
        compat.assemble_vector(b, self.model.mapped(form))
        b.ghostUpdate(addv=self.PETSc.InsertMode.ADD, mode=self.PETSc.ScatterMode.REVERSE)
        return b

    def add_local(self, b, values: np.ndarray):
        """Add a local array (ghosts included) to ``b``, ghosts summed into their owners."""
        work = self.vec()
        with work.localForm() as local:
            local.array[:] = values
        work.ghostUpdate(addv=self.PETSc.InsertMode.ADD, mode=self.PETSc.ScatterMode.REVERSE)
        b.axpy(1.0, work)
        work.destroy()

    # the objective ---------------------------------------------------------------------

    def objective(self, objective: Objective):
        """``(J, ∂J/∂w as a vector, the UFL form of J or None)`` at the model's iterate."""
        import ufl

        m = self.model
        if objective.probe is None:
            k = m.kinematics()
            if objective.column == "elastic_energy":
                form = m.energy
            else:
                i = "xyz".index(objective.column[-1])
                form = (ufl.SpatialCoordinate(m.mesh)[i] + k.u[i]) / m.area() * m.dx
            J = m.assemble_scalar(m.compile(form))
            return J, self.assemble(ufl.derivative(form, m.z, k.w_test)), form
        J, weights = self._probe(objective)
        g = self.vec()
        with g.localForm() as local:
            local.set(0.0)
        self.add_local(g, weights)
        return J, g, None

    def _probe(self, objective: Objective):
        """A probe's displacement component ``Σ_k φ_k(X) u_k`` and its weights ``φ_k(X)``
        on the u dofs of the cell that holds X (on the process that owns it)."""
        from dolfinx import fem

        from rftfem import compat
        from rftfem.scene.selectors import owned_cells

        m = self.model
        X = np.array(m.scene["output"]["probes"][objective.probe]["at"], dtype=float)
        (cell,), _ = owned_cells(m.mesh, X[None, :])
        weights = np.zeros(len(m.w.x.array))
        value = 0.0
        unit, u = fem.Function(m.Vu), fem.Function(m.Vu)  # on every process (collective)
        if cell is not None:
            nodes = compat.cell_dofs(m.Vu)[cell]
            at = np.array([cell], dtype=np.int32)
            dofs = m.u_dofs[3 * nodes + objective.component]
            for node, dof in zip(nodes, dofs):  # φ_k(X): the field that is 1 at node k
                unit.x.array[:] = 0.0
                unit.x.array[3 * node + objective.component] = 1.0
                weights[dof] = unit.eval(X, at)[objective.component]
            u.x.array[:] = m.w.x.array[m.u_dofs]
            value = float(u.eval(X, at)[objective.component])
        return m.comm.allreduce(value), weights

    # the adjoint -------------------------------------------------------------------------

    def multiplier(self, dJdw):
        """λ of ``Kᵀ λ = ∂J/∂w`` with λ = 0 on the Dirichlet dofs, K the exact tangent
        at the iterate (identity rows and columns on the Dirichlet dofs)."""
        from rftfem import compat

        PETSc, m, solver = self.PETSc, self.model, self.sim.solver
        # static: no converged-resultant start (first_tangent_converged is False), so the
        # mixed-point defects are zero and this is the exact ∂R/∂w (docs/model.md §7.4)
        assert not m.first_tangent_converged
        solver.assemble_tangent()
        for bc in m.bcs:
            dofs, _ = bc.dof_indices()  # local indices of ``W``, ghosts too
            with dJdw.localForm() as local:
                local.array[np.asarray(dofs)] = 0.0
        ksp = PETSc.KSP().create(m.comm)
        ksp.setOperators(solver.A)
        ksp.setType("preonly")
        pc = ksp.getPC()
        pc.setType("lu")
        if compat.has_mumps():
            pc.setFactorSolverType("mumps")
        lam = self.vec()
        try:
            ksp.solveTranspose(dJdw, lam)
            if ksp.getConvergedReason() < 0:
                raise RunFailed(f"the adjoint solve failed (KSP reason {ksp.getConvergedReason()})")
        finally:
            ksp.destroy()
        lam.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        return lam


def gradient(
    sim: Simulation,
    last: dict,
    keys: list[Key],
    objective: Objective
    | tuple[Sequence[Objective], Callable[[list[float]], tuple[float, Sequence[float]]]],
    fields: Sequence[str] = (),
) -> tuple[float, list[float]] | tuple[float, list[float], list[FieldGradient]]:
    """``(J, [dJ/dkey])`` at the state ``last`` that the run's last step converged to
    (``keep_last_step``), for a finished static Simulation whose solver and model are
    still alive (before ``sim.close()``).  With ``fields`` (field keys, e.g.
    ``shell.thickness``): ``(J, [dJ/dkey], [FieldGradient])``
    (rftfem/studies/field_gradients.py).  ``objective`` may be ``(objectives,
    combine)``: J = f(J₁, J₂, ...) with ``combine([J_i]) -> (J, [∂f/∂J_i])``, whose
    ∂J/∂w is Σ ∂f/∂J_i ∂J_i/∂w (one adjoint solve)."""
    m = sim.model
    _restore(m, last)
    m.set_time(sim.scene["time"]["end"])
    adj = _Adjoint(sim)
    if isinstance(objective, tuple):
        J, dJdw, J_form = combined_objective(adj, *objective)
    else:
        J, dJdw, J_form = adj.objective(objective)
    if not keys and not fields:
        dJdw.destroy()
        return float(J), []
    lam = adj.multiplier(dJdw)
    out = []
    for key in keys:
        pairs, nodal = adj.directions(key)
        dRdp_form = adj.derivative(m.forces_ufl, pairs)
        dRdp = adj.assemble(dRdp_form) if dRdp_form is not None else adj.vec()
        if dRdp_form is None:
            with dRdp.localForm() as local:
                local.set(0.0)
        if nodal is not None:
            adj.add_local(dRdp, nodal)
        dJdp = 0.0
        if J_form is not None:
            partial = adj.derivative(J_form, pairs)
            if partial is not None:
                dJdp = m.assemble_scalar(m.compile(partial))
        out.append(float(dJdp - lam.dot(dRdp)))
        dRdp.destroy()
    by_field = []
    if fields:
        from rftfem.studies.field_gradients import field_gradients

        by_field = field_gradients(adj, lam, J_form, list(fields))
    for v in (dJdw, lam):
        v.destroy()
    return (float(J), out, by_field) if fields else (float(J), out)


__all__ = [
    "gradient",
    "keep_last_step",
    "check_request",
    "supports",
    "parse_key",
    "KEYS_SUPPORTED",
    "OBJECTIVES_SUPPORTED",
]
