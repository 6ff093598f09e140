"""PETSc SNES around the model's residual (docs/model.md §6-7).

The residual of a step is

    R = (1 − α_f) F(w) + M a_{n+1−α_m}(w) + α_f F_n

with ``F`` the sum of the non-inertial effects (one compiled form), the inertia
term compiled only when the scene has inertia, and ``F_n`` the force vector kept
from the last converged step.  Rows of Dirichlet dofs hold ``x − g``.  A step
starts on its Dirichlet values when the predicted state meets them closely (it
then needs no lifting); otherwise from the last state, and the lifting of the
Dirichlet increment is assembled while the iterate misses the values.
"""

from __future__ import annotations

import math
import time as _time
from typing import TYPE_CHECKING

from petsc4py import PETSc

from rftfem import compat, petsc_options
from rftfem.errors import SceneError
from rftfem.integration import coupled
from rftfem.integration.assembly import StepAssembly
from rftfem.integration.convergence import NewtonTest
from rftfem.integration.factorization import Factorization
from rftfem.integration.weak_callbacks import weak_method
from rftfem.model.effects.base import LimitsNewtonStep

if TYPE_CHECKING:
    import numpy as np

    from rftfem.model.shell_model import Model

#: a prediction that meets the prescribed values to this share of its own largest
#: displacement increment starts Newton on them (no lifting)
CONSISTENT = 0.25


class StepSolver(StepAssembly, NewtonTest):
    """Newton solve of one step's residual with PETSc SNES (its assembly:
    :class:`~rftfem.integration.assembly.StepAssembly`; its convergence test:
    :class:`~rftfem.integration.convergence.NewtonTest`)."""

    def __init__(
        self,
        model: Model,
        options: dict,
        factorization: str = "every-iteration",
        lu_fallback: str | None = None,
    ):
        self.model = model
        self.options = options
        #: the LU package a failed solve is made again with (then kept), or None
        self.lu_fallback = lu_fallback
        #: when the tangent is factorised (factorization.py)
        self.factors = Factorization(factorization)
        self._create_operators(model, options)
        #: wall seconds and calls: residuals (F, inertia, Dirichlet rows), Jacobians,
        #: liftings of a missed Dirichlet increment, and the linear solves (SNES's
        #: solve less the assembly within it: factorisation, substitution, updates)
        self.timings = {"residual": 0.0, "jacobian": 0.0, "lifting": 0.0, "solve": 0.0}
        self.calls = {"residual": 0, "jacobian": 0, "lifting": 0}
        self._x_of_F = None  # the iterate of the last residual's F
        self._start = None  # a solve's first iterate (a retry starts there again)
        self.evaluations = 0
        self._create_snes(model, options)
        #: effects that shorten a Newton update (contact: keeps the lower face off the
        #: far side of its barrier, docs/contact.md §3)
        self._step_limits = [c for c in model.components if isinstance(c, LimitsNewtonStep)]
        #: a residual this small that Newton no longer reduces is round-off: the
        #: elastic forces' own floor (petsc_options.ROUNDOFF_FACTOR of their scale)
        self.roundoff = petsc_options.ROUNDOFF_FACTOR * model.elastic_force()
        #: the same for the membrane forces (MEMBRANE_ROUNDOFF_FACTOR of E t W)
        self.noise = petsc_options.MEMBRANE_ROUNDOFF_FACTOR * model.membrane_force()
        self._forced = False
        self._fnorms = []
        self._snorms = []
        #: the largest rotation increment of each iterate of the last solve (after each
        #: update), and why the last solve was stopped as diverging (None if it was not)
        self.turns: list[float] = []
        self.divergence: str | None = None
        self.shortened = False
        self._set_snes_options()
        self.watch = None  # a slow step's reports and stops (step_watch.StepWatch.attach)
        self.force_iteration()

    def _create_operators(self, model: Model, options: dict) -> None:
        """The step's vectors (``F``, ``F_n``, the residual ``b``, ``work``, the iterate
        ``x``), its tangent ``A`` and, with a nonlocal effect, the coupled tangent."""
        W = model.W
        self.F = compat.create_vector(model.forces_form, W)  # F(w), assembled
        self.F_n = compat.create_vector(model.forces_form, W)  # F of the last step
        self.b = compat.create_vector(model.forces_form, W)  # the residual
        self.work = compat.create_vector(model.forces_form, W)
        self.x = compat.create_vector(model.forces_form, W)
        self.A = compat.create_matrix(model.jacobian_form, petsc_options.matrix_type(options))
        #: with a nonlocal effect (Stokes flow): the exact tangent as a shell matrix,
        #: ``A`` (plus the effect's lumped blocks) its preconditioner (coupled.py)
        self.coupled = coupled.tangent_for(model, self.A)

    def _create_snes(self, model: Model, options: dict) -> None:
        """rftfem's PETSc options set, and the SNES with its residual, Jacobian and
        convergence test."""
        petsc_options.apply(options)
        self.snes = PETSc.SNES().create(model.comm)
        self.snes.setOptionsPrefix(petsc_options.PREFIX)
        # (weak: the SNES would otherwise keep this solver and its model alive)
        self.snes.setFunction(weak_method(self._residual), self.b)
        J = self.coupled.J if self.coupled else self.A
        self.snes.setJacobian(weak_method(self._jacobian), J, self.A)
        self.snes.setConvergenceTest(weak_method(self._converged))

    def _set_snes_options(self) -> None:
        """The SNES and its KSP read the options (a SceneError for one PETSc rejects);
        then the effects' limit on the update."""
        try:
            self.snes.setFromOptions()
            self.snes.getKSP().setFromOptions()
        except PETSc.Error as exc:
            raise SceneError(
                f"solver: PETSc rejected an option of [solver] or the command "
                f"line: {petsc_options.petsc_message(exc)}"
            ) from None
        if self._step_limits:  # after setFromOptions, which makes the line search anew
            self.snes.setLineSearchPreCheck(weak_method(self._limit_update))

    def destroy(self) -> None:
        petsc_options.clear(self.options)
        for obj in (
            self.snes,
            self.F,
            self.F_n,
            self.b,
            self.work,
            self.x,
            self.A,
            self.coupled.J if self.coupled is not None else None,
            self._x_of_F,
            self._start,
        ):
            if obj is not None:
                obj.destroy()

    def _limit_update(self, x, y):
        """Scale the Newton update ``−y`` at ``x`` by the smallest fraction the effects
        allow (SNES's line-search pre-check)."""
        fraction = min(c.newton_step_fraction(x.array_r, y.array_r) for c in self._step_limits)
        #: whether the last update was shortened (then its length says nothing of the
        #: distance to the solution: convergence.py's step tests skip it)
        self.shortened = fraction < 1.0
        if self.shortened:
            y.scale(fraction)

    # --- solve ----------------------------------------------------------------

    def solve(self) -> tuple[bool, int, float, str]:
        """Newton from the model's current iterate; returns (converged, its, residual, reason)."""
        t0 = _time.perf_counter()
        a0 = self.assembly_time
        w = compat.petsc_vec(self.model.w)
        w.copy(self.x)
        if self.model.has_moving_bcs:
            self._start_on_motions(w)
        self.model.start_newton()
        self._start = self.x.copy(self._start)
        retry = False
        while True:
            self.turns, self.divergence = [], None
            self.factors.start_solve(retry)
            try:
                self.snes.solve(None, self.x)
            except PETSc.Error as exc:  # e.g. an option PETSc reads only when solving
                self._sync(self.x)
                message = petsc_options.petsc_message(exc)
                return False, self.snes.getIterationNumber(), math.nan, message
            reason = self.snes.getConvergedReason()
            self.factors.end_solve(reason > 0)
            retry = self._again(reason)
            if retry is None:
                break
            self._start.copy(self.x)
            self._sync(self.x)
            self.model.start_newton()
        self._sync(self.x)
        its = self.snes.getIterationNumber()
        norm = self.snes.getFunctionNorm()
        self.timings["solve"] += (_time.perf_counter() - t0) - (self.assembly_time - a0)
        name = petsc_options.reason_name(reason)
        if self.divergence is not None:
            return False, its, norm, self.divergence
        if name in compat.SNES_NOT_FINITE:
            # PETSc keeps the last finite norm (0 before the first): say what it was
            return (
                False,
                its,
                math.nan,
                (
                    f"the residual is not finite ({name}): a load, motion "
                    "or coefficient too large for double precision, or "
                    "a state that left the physical range"
                ),
            )
        return reason > 0, its, norm, name

    def _again(self, reason: int) -> bool | None:
        """Whether a solve that ended with ``reason`` is made again from its start:
        True with new factors for every tangent (GMRES gave up on old ones), False
        with more MUMPS workspace (it ran out) or with MUMPS instead of PETSc's own LU
        (any failure of a solve with rftfem's choice of PETSc's LU, which does not
        pivot); None if not."""
        name = petsc_options.reason_name(reason)
        ksp = self.snes.getKSP()
        if name == "DIVERGED_LINEAR_SOLVE":
            if self.factors.stale:
                return True
            if petsc_options.grow_factor_workspace(ksp, self.options):
                return False
        pc = ksp.getPC()
        if (
            (reason <= 0 or self.divergence is not None)
            and self.lu_fallback
            and pc.getType() == "lu"
        ):
            pc.reset()  # (the package cannot change under existing factors)
            pc.setFactorSolverType(self.lu_fallback)
            self.options["pc_factor_mat_solver_type"] = self.lu_fallback
            petsc_options.apply({"pc_factor_mat_solver_type": self.lu_fallback})
            self.lu_fallback = None
            return False
        return None

    @property
    def lu(self) -> str | None:
        """The LU package in use (None if the preconditioner is not an LU)."""
        pc = self.snes.getKSP().getPC()
        return (pc.getFactorSolverType() or "petsc") if pc.getType() == "lu" else None

    def _start_on_motions(self, w):
        """Put the iterate on the step's Dirichlet values if the prediction came
        within ``CONSISTENT`` of them (relative to the predicted step); else start
        from the last state (the lifting then spreads the increment).  Set on the
        boundary alone, values far from a prediction leave a kink at the body's
        edge from which Newton may not converge quadratically (the three-link's
        edges from rest: 18 iterations against 3 with the lifting)."""
        m = self.model
        with self.work.localForm() as local:
            local.set(0.0)
        compat.set_bc(self.work, m.bcs, self.x, 1.0)  # g − x on the Dirichlet rows
        miss = self.work.norm(PETSc.NormType.NORM_INFINITY)
        if miss == 0.0:
            return
        if miss <= CONSISTENT * m.predicted_step:
            compat.set_bc(self.x, m.bcs)
        elif m.predicted_step > 0.0:
            m.restore()
            w.copy(self.x)

    def raw_residual(self) -> np.ndarray:
        """The local array (owned entries complete) of the converged step's residual
        before its Dirichlet rows are replaced: ``(1 − α_f) F + α_f F_n`` plus inertia and
        the step-end forces,
        at the model's current iterate (reactions.py)."""
        m = self.model
        if self._x_of_F is not None:
            self.work.waxpy(-1.0, self._x_of_F, compat.petsc_vec(m.w))
            fresh = self.work.norm(PETSc.NormType.NORM_INFINITY) == 0.0
        else:
            fresh = False
        if not fresh:
            self.assemble_forces()
            self._x_of_F = compat.petsc_vec(m.w).copy(self._x_of_F)
        alpha_f = float(m.coef["alpha_f"].value)
        out = (1.0 - alpha_f) * self.F.array
        if alpha_f != 0.0:
            out += alpha_f * self.F_n.array
        if m.inertia_form is not None:
            self._assemble(self.work, m.inertia_form)
            out += self.work.array
        if m.end_form is not None:
            self._assemble(self.work, m.end_form)
            out += float(m.coef["end_weight"].value) * self.work.array
        return out

    def forget_forces(self) -> None:
        """The last assembled ``F`` no longer belongs to its iterate (the loads or the
        time changed at the same state): the next ``store_forces`` assembles anew."""
        if self._x_of_F is not None:
            self._x_of_F.destroy()
            self._x_of_F = None

    def store_forces(self) -> None:
        """Keep ``F`` at the converged state as ``F_n`` for the next step: the last
        residual's F when SNES evaluated it there (its own convergence test, as
        newtonls with full steps does), else a new assembly."""
        if self._x_of_F is not None:
            self.work.waxpy(-1.0, self._x_of_F, self.x)
            if self.work.norm(PETSc.NormType.NORM_INFINITY) == 0.0:
                self.F.copy(self.F_n)
                return
        self.assemble_forces(self.F_n)
