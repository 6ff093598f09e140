"""The state a run starts in (docs/model.md §6.7): equilibrium at t = 0, at rest or moving."""

from __future__ import annotations

from typing import TYPE_CHECKING

from rftfem.errors import RunFailed
from rftfem.integration import impulses
from rftfem.integration.schemes import BackwardEuler, Static

if TYPE_CHECKING:
    from rftfem.integration.run_state import RunPosition
    from rftfem.integration.schemes import Scheme
    from rftfem.integration.solver import StepSolver
    from rftfem.model.reactions import Reactions
    from rftfem.model.shell_model import Model


class InitialState:
    """The start of :class:`~rftfem.integration.step_control.StepController`'s run; it
    reads the controller's model, solver, scheme, ``time`` table, reactions and
    ``free``, and solves with its ``attempt``."""

    model: Model
    solver: StepSolver
    scheme: Scheme
    time_: dict
    reactions: Reactions
    free: bool

    def initial_equilibrium(self, pos: RunPosition) -> None:
        """The state a run starts in (docs/model.md §6.7), at rest: ``v = a = 0``, or
        with inertia the acceleration the t = 0 forces give it.

        A run in time starts in its initial state: the reference, or the shape the
        t = 0 motions impose with the rest of the body in elastic equilibrium.  The
        loads (``[[load]]``, the magnetic field) are off in that solve, so a load
        already on at t = 0 moves the body from the first step on, not before it.
        Static runs, and runs in time with ``time.start = "equilibrium"``, start in
        static equilibrium with the t = 0 loads instead (a pre-loaded body released).

        With drag the body may be free (no Dirichlet condition on its rigid motions),
        and a static solve would be singular.  The t = 0 solve then carries the drag
        of reaching that state from the reference in one step ``dt`` (backward Euler),
        which lets the fluid hold the body; without loads and motions at t = 0 the
        reference meets it exactly and no update is made.  The forces kept for the
        first step (``F_n``) are those of the start with its t = 0 loads on.
        """
        m, dt = self.model, self.time_["dt"]
        in_time = self.scheme.has_velocity
        loaded = not in_time or self.time_.get("start", "rest") == "equilibrium"
        self._solve_start(pos, dt, loaded)
        m.v_n.x.array[:] = 0.0
        m.a_n.x.array[:] = 0.0
        m.increments = []  # reaching t = 0 is no rate to go on at
        # the loads at t = 0 on, the body at rest: the forces of the start
        m.set_coefficients(Static().coefficients(dt))
        m.set_time(0.0)
        self.solver.forget_forces()
        if self.reactions and not loaded:
            self.reactions.compute(self.solver.raw_residual())
        self._start_moving(dt)
        m.set_coefficients(Static().coefficients(dt))
        self.solver.store_forces()

    def _solve_start(self, pos: RunPosition, dt: float, loaded: bool) -> None:
        """The t = 0 solve (with the t = 0 loads if ``loaded``); the run fails without it."""
        m = self.model
        start = BackwardEuler() if m.fluid else Static()
        # no prediction here to correct: a state that meets the tolerance (the
        # reference state without loads) is the answer
        self.solver.force_iteration(False)
        m.loads_on = loaded
        try:
            ok, its, res, reason = self.attempt(pos, 0.0, dt, start, limit_rotation=False)
        finally:
            self.solver.force_iteration()
            m.loads_on = True
        if not ok:
            what = "the t = 0 loads and motions" if loaded else "the t = 0 motions"
            hint = (
                "; nothing holds this body (no [[boundary]], [[motion]] or [fluid]), so "
                "no load may be on at t = 0"
                if self.free and loaded
                else ""
            )
            raise RunFailed(
                f"no static equilibrium with {what} ({reason})"
                + hint
                + (self._ramp_hint() if loaded else ""),
                0.0,
                0,
            )

    def _start_moving(self, dt: float) -> None:
        """With inertia: the acceleration the t = 0 forces give the body at rest, and
        the driven dofs' jump from rest handed to the body."""
        m = self.model
        if self.scheme.has_inertia:
            try:
                impulses.initial_acceleration(m, self.solver)
                if any(c.holds_at_rest() for c in m.components):
                    impulses.frictional_acceleration(m, self.solver, dt)
            except RuntimeError as exc:
                raise RunFailed(f"no initial acceleration: {exc}", 0.0, 0) from None
        if m.drive and self.scheme.has_inertia:
            # the driven dofs move off at the motion's own rate, the body with them
            m.set_coefficients(self.scheme.coefficients(dt))
            impulses.corner(m, self.solver, 0.0, start=True)
