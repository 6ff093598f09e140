"""The adjoint of a static run's last step (rftfem/studies/sensitivity.py): the parameters'
derivatives of ``R`` and ``J``, their assembly, the objective and ``λ``."""

from __future__ import annotations

from types import SimpleNamespace
from typing import TYPE_CHECKING

import numpy as np

from rftfem.errors import RunFailed
from rftfem.studies.sensitivity_request import MATERIAL_FIELDS, PROBE_VALUES

if TYPE_CHECKING:
    from rftfem.studies.sensitivity_request import Key, Objective

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
