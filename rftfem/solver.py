"""PETSc SNES around the model's residual (docs/model.md §6-7).

The residual of a step is

    R = (1 − α_f) F(w) + M a_{n+1−α_m}(w) + α_f F_n

with ``F`` the sum of the non-inertial effects (one compiled form), the inertia
term compiled only when the scene has inertia, and ``F_n`` the force vector kept
from the last converged step.  Rows of Dirichlet dofs hold ``x − g``; the lifting
of the Dirichlet increment is assembled only while the iterate misses the values.
"""

from __future__ import annotations

import math
import time as _time

from petsc4py import PETSc

from . import compat, petsc_options
from .errors import SceneError

_INSERT, _ADD = PETSc.InsertMode.INSERT, PETSc.InsertMode.ADD
_FORWARD, _REVERSE = PETSc.ScatterMode.FORWARD, PETSc.ScatterMode.REVERSE


class StepSolver:
    """Newton solve of one step's residual with PETSc SNES."""

    def __init__(self, model, options: dict):
        self.model = model
        self.options = options
        W = model.W
        self.F = compat.create_vector(model.forces_form, W)    # F(w), assembled
        self.F_n = compat.create_vector(model.forces_form, W)  # F of the last step
        self.b = compat.create_vector(model.forces_form, W)    # the residual
        self.work = compat.create_vector(model.forces_form, W)
        self.x = compat.create_vector(model.forces_form, W)
        self.A = compat.create_matrix(model.jacobian_form)
        self.timings = {"assembly": 0.0, "solve": 0.0}
        self.evaluations = 0

        petsc_options.apply(options)
        self.snes = PETSc.SNES().create(model.comm)
        self.snes.setOptionsPrefix(petsc_options.PREFIX)
        self.snes.setFunction(self._residual, self.b)
        self.snes.setJacobian(self._jacobian, self.A)
        try:
            self.snes.setFromOptions()
            self.snes.getKSP().setFromOptions()
        except PETSc.Error as exc:
            raise SceneError(f"solver: PETSc rejected an option of [solver] or the command "
                             f"line: {petsc_message(exc)}") from None

    def destroy(self):
        petsc_options.clear(self.options)
        for obj in (self.snes, self.F, self.F_n, self.b, self.work, self.x, self.A):
            obj.destroy()

    # --- assembly -------------------------------------------------------------

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

    def assemble_forces(self, out=None):
        """``F(w)`` at the model's current iterate into ``out`` (default: ``self.F``)."""
        t0 = _time.perf_counter()
        self._assemble(self.F if out is None else out, self.model.forces_form)
        self.timings["assembly"] += _time.perf_counter() - t0

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
        # Dirichlet rows hold x − g.  Where the iterate does not meet the values
        # yet (the first residual of a step with moving Dirichlet values), the
        # other rows get the lifting A (g − x): the first Newton update then
        # spreads the prescribed increment through the body.  Newton meets the
        # values exactly in that update, so later residuals skip the assembly.
        # Fixed conditions (zero values) are always met: the iterate starts from the
        # last state and Newton updates are zero there; only motions can be missed.
        if m.has_moving_bcs:
            with self.work.localForm() as local:
                local.set(0.0)
            compat.set_bc(self.work, m.bcs, x, -1.0)
            if self.work.norm(PETSc.NormType.NORM_INFINITY) > 0.0:
                with self.work.localForm() as local:
                    local.set(0.0)
                compat.apply_lifting(self.work, m.jacobian_form, m.bcs, x, -1.0)
                self.work.ghostUpdate(addv=_ADD, mode=_REVERSE)
                b.axpy(1.0, self.work)
        compat.set_bc(b, m.bcs, x, -1.0)
        self.timings["assembly"] += _time.perf_counter() - t0

    def _jacobian(self, snes, x, A, P):
        t0 = _time.perf_counter()
        self._sync(x)
        A.zeroEntries()
        compat.assemble_matrix(A, self.model.jacobian_form, self.model.bcs)
        A.assemble()
        self.timings["assembly"] += _time.perf_counter() - t0

    # --- solve ----------------------------------------------------------------

    def solve(self):
        """Newton from the model's current iterate; returns (converged, its, residual, reason)."""
        t0 = _time.perf_counter()
        a0 = self.timings["assembly"]
        w = compat.petsc_vec(self.model.w)
        w.copy(self.x)
        try:
            self.snes.solve(None, self.x)
        except PETSc.Error as exc:  # e.g. an option PETSc reads only when solving
            self._sync(self.x)
            return False, self.snes.getIterationNumber(), math.nan, petsc_message(exc)
        self._sync(self.x)
        reason = self.snes.getConvergedReason()
        its = self.snes.getIterationNumber()
        norm = self.snes.getFunctionNorm()
        self.timings["solve"] += (_time.perf_counter() - t0) - (self.timings["assembly"] - a0)
        return reason > 0, its, norm, _reason_name(reason)

    def store_forces(self):
        """Keep ``F`` at the converged state as ``F_n`` for the next step."""
        self.assemble_forces(self.F_n)


def _reason_name(reason: int) -> str:
    names = {v: k for k, v in vars(PETSc.SNES.ConvergedReason).items() if isinstance(v, int)}
    return names.get(reason, str(reason))


def petsc_message(exc) -> str:
    """The last line of PETSc's own error text (what went wrong), else the error code."""
    lines = [ln.strip() for ln in str(exc).splitlines() if ln.strip()]
    text = lines[-1] if lines else ""
    return text[4:] if text.startswith("[0] ") else (text or repr(exc))
