"""A step's residual and tangent assembled for SNES (solver.py's ``R``), and linear responses."""

from __future__ import annotations

import time as _time
from typing import TYPE_CHECKING

from petsc4py import PETSc

from rftfem import compat

if TYPE_CHECKING:
    import numpy as np

    from rftfem.integration.coupled import CoupledTangent
    from rftfem.integration.factorization import Factorization
    from rftfem.model.shell_model import Model

_INSERT, _ADD = PETSc.InsertMode.INSERT, PETSc.InsertMode.ADD
_FORWARD, _REVERSE = PETSc.ScatterMode.FORWARD, PETSc.ScatterMode.REVERSE


class StepAssembly:
    """The assembly of :class:`~rftfem.integration.solver.StepSolver`: the residual
    and tangent SNES calls back, the calls of a Newton loop of rftfem's own, the
    exact tangent and the response to moving the Dirichlet dofs; it reads the
    solver's model, vectors, matrix, coupled tangent, factors and SNES."""

    model: Model
    F: PETSc.Vec
    F_n: PETSc.Vec
    b: PETSc.Vec
    work: PETSc.Vec
    A: PETSc.Mat
    coupled: CoupledTangent | None
    factors: Factorization
    snes: PETSc.SNES
    timings: dict[str, float]
    calls: dict[str, int]

    def _sync(self, x):
        """Copy the SNES iterate into the model's mixed function (owned + ghosts).

        The iterate's own ghosts are updated too: the lifting reads ``x`` with them.
        """
        x.ghostUpdate(addv=_INSERT, mode=_FORWARD)
        w = compat.petsc_vec(self.model.w)
        x.copy(w)
        w.ghostUpdate(addv=_INSERT, mode=_FORWARD)

    def _assemble(self, vec, form):
        with vec.localForm() as local:
            local.set(0.0)
        compat.assemble_vector(vec, form)
        if form is self.model.forces_form:  # point forces join F before the ghost sums
            with vec.localForm() as local:
                self.model.add_nodal_forces(local.array)
        vec.ghostUpdate(addv=_ADD, mode=_REVERSE)

    @property
    def assembly_time(self) -> float:
        """Wall seconds in assembly of every kind."""
        return self.timings["residual"] + self.timings["jacobian"] + self.timings["lifting"]

    def _count(self, kind: str, t0: float):
        self.timings[kind] += _time.perf_counter() - t0
        self.calls[kind] += 1

    def assemble_forces(self, out: PETSc.Vec | None = None) -> None:
        """``F(w)`` at the model's current iterate into ``out`` (default: ``self.F``)."""
        t0 = _time.perf_counter()
        self._assemble(self.F if out is None else out, self.model.forces_form)
        self._count("residual", t0)

    def _residual(self, snes, x, b):
        t0 = _time.perf_counter()
        self.evaluations += 1
        m = self.model
        self._sync(x)
        alpha_f = float(m.coef["alpha_f"].value)
        self._assemble(self.F, m.forces_form)
        with b.localForm() as local:
            local.set(0.0)
        b.axpy(1.0 - alpha_f, self.F)
        if alpha_f != 0.0:
            b.axpy(alpha_f, self.F_n)
        if m.inertia_form is not None:
            self._assemble(self.work, m.inertia_form)
            b.axpy(1.0, self.work)
        if m.end_form is not None:
            self._assemble(self.work, m.end_form)
            b.axpy(float(m.coef["end_weight"].value), self.work)
        # Dirichlet rows hold x − g.  Where the iterate does not meet the values
        # (the first residual of a step that starts from the last state, solve),
        # the other rows get the lifting A (g − x): the first Newton update then
        # spreads the prescribed increment through the body.  Newton meets the
        # values exactly in that update, so later residuals skip the assembly.
        if m.has_moving_bcs:
            with self.work.localForm() as local:
                local.set(0.0)
            compat.set_bc(self.work, m.bcs, x, -1.0)
            if self.work.norm(PETSc.NormType.NORM_INFINITY) > 0.0:
                t1 = _time.perf_counter()
                with self.work.localForm() as local:
                    local.set(0.0)
                compat.apply_lifting(self.work, m.jacobian_form, m.bcs, x, -1.0)
                self.work.ghostUpdate(addv=_ADD, mode=_REVERSE)
                if self.coupled is not None:
                    self.coupled.lift(self.work, x, -1.0)
                b.axpy(1.0, self.work)
                self._count("lifting", t1)
                t0 += _time.perf_counter() - t1  # not a residual's time
        compat.set_bc(b, m.bcs, x, -1.0)
        self._x_of_F = x.copy(self._x_of_F)  # F belongs to this iterate (store_forces)
        self._count("residual", t0)

    def _jacobian(self, snes, x, A, P):
        t0 = _time.perf_counter()
        self._sync(x)
        self.model.tangent_at_iterate()
        P.zeroEntries()  # (A: P itself, or the coupled tangent's shell matrix around it)
        compat.assemble_matrix(P, self.model.jacobian_form, self.model.bcs)
        P.assemble()
        if self.coupled is not None:
            self.coupled.update()
        self._count("jacobian", t0)
        self.factors.choose(self.snes.getKSP(), P)

    # the calls of a Newton loop of rftfem's own (arc_newton.py)
    def residual(self, x: PETSc.Vec, b: PETSc.Vec) -> None:
        """The step's residual at the iterate ``x`` into ``b`` (as SNES's callback)."""
        self._residual(None, x, b)

    def jacobian(self, x: PETSc.Vec) -> None:
        """The step's tangent at the iterate ``x`` into ``A`` (as SNES's callback)."""
        self._jacobian(None, x, self.A, self.A)

    def sync(self, x: PETSc.Vec) -> None:
        """The model's iterate set to ``x``."""
        self._sync(x)

    def assemble_tangent(self, diagnostic: bool = False) -> None:
        """The step's tangent at the model's current state into ``A`` (the exact one:
        no Newton update is under way).  A ``diagnostic`` one (a product, never
        factorised: step_control.py's limit-point check) adds its time, not a call."""
        t0 = _time.perf_counter()
        self.model.start_newton()
        self.model.tangent_at_iterate()
        self.A.zeroEntries()
        compat.assemble_matrix(self.A, self.model.jacobian_form, self.model.bcs)
        self.A.assemble()
        if self.coupled is not None:
            self.coupled.update(exact=True)
        if diagnostic:
            self.timings["jacobian"] += _time.perf_counter() - t0
        else:
            self._count("jacobian", t0)

    def dirichlet_response(self) -> np.ndarray:
        """The local array (ghosts included) of ``Δ`` with ``A Δ = 0`` on the free rows
        and ``Δ = g`` on the Dirichlet rows, ``g`` the values the model's conditions
        hold now (``assemble_tangent`` first): the linearised step's answer to moving
        its Dirichlet dofs alone (impulses.py)."""
        t0 = _time.perf_counter()
        bcs = self.model.bcs
        for vec in (self.b, self.work):
            with vec.localForm() as local:
                local.set(0.0)
        compat.apply_lifting(self.b, self.model.jacobian_form, bcs, self.work, 1.0)
        self.b.ghostUpdate(addv=_ADD, mode=_REVERSE)
        if self.coupled is not None:
            self.coupled.lift(self.b, self.work, 1.0)
        compat.set_bc(self.b, bcs)
        ksp = self.snes.getKSP()
        ksp.setOperators(self.coupled.J if self.coupled is not None else self.A, self.A)
        ksp.solve(self.b, self.work)
        self.work.ghostUpdate(addv=_INSERT, mode=_FORWARD)
        with self.work.localForm() as local:
            delta = local.array.copy()
        self.timings["solve"] += _time.perf_counter() - t0
        return delta
