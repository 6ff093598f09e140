"""One step and its control (docs/model.md §6.7-6.8): a Newton solve of a step from
its prediction, the turn limit that rejects a step whose directors turned too far,
the halvings after a failed attempt and the doubling back, the advance over one
nominal step, and the loop over fixed steps.  The start of a run in equilibrium is
initial_state.py's, error-controlled steps are error_control.py's.
"""

from __future__ import annotations

import math
import time as _time
from dataclasses import dataclass
from typing import TYPE_CHECKING

from rftfem.errors import RunFailed, RunInterrupted
from rftfem.integration import impulses
from rftfem.integration.initial_state import InitialState

if TYPE_CHECKING:
    from collections.abc import Callable

    from rftfem.integration.error_control import ErrorControl
    from rftfem.integration.interrupts import NoStops, StopRequests
    from rftfem.integration.run_state import RunHooks, RunPosition
    from rftfem.integration.schemes import Scheme
    from rftfem.integration.solver import StepSolver
    from rftfem.model.reactions import Reactions
    from rftfem.model.shell_model import Model
    from rftfem.outputs.progress import Progress

#: static load steps: the most a sub-step should turn a director (rad).  A converged
#: load step that turned one further is followed by halved sub-steps, and a cut
#: sub-step is doubled again only while the doubled one would stay within it; in time
#: ``time.max_rotation`` plays this part.  (Newton took 5 updates for load steps
#: turning the roll-up's tip 0.4 rad, 6 to 10 for 0.8 rad on a curled strip, 7 or 8
#: for 1.6 rad, and often failed from 1.6 rad on.)
STATIC_TURN = 0.5
#: the most halvings one failed attempt makes at once (docs/model.md §6.8)
MOST_HALVINGS = 3
#: a static run whose steps stall where the tangent's stiffness along the last step
#: (``Δwᵀ K Δw / Δwᵀ Δw``) fell below this share of the first step's has met a limit
#: point (docs/model.md §6.8)
LIMIT_POINT_STIFFNESS = 0.1


@dataclass
class StepState:
    """The step controller's state (a checkpoint keeps ``level`` and ``last_turn``)."""

    #: halvings of the nominal step the next one starts with (``advance``)
    level: int = 0
    #: the largest rotation increment of the last converged step
    last_turn: float = 0.0
    #: how many times too long the last failed attempt was (None where it does not show)
    overreach: float | None = None
    #: whether the last attempt converged but its error check rejected it
    rejected: bool = False
    #: the tangent's stiffness along the first static load step that moved the body
    first_stiffness: float | None = None


class StepController(InitialState):
    """Steps of a run over its ``time`` table: each attempt solved, checked and
    accepted or restored; the cuts and doublings of a nominal step; the fixed-step
    loop.  ``free``: nothing holds the body's rigid motions (no support, motion or
    drag).  Each attempt's local error goes to ``errors`` (error_control.py); the state
    a run starts in is initial_state.py's."""

    def __init__(
        self,
        model: Model,
        solver: StepSolver,
        scheme: Scheme,
        time_: dict,
        stops: StopRequests | NoStops,
        reactions: Reactions,
        errors: ErrorControl,
        free: bool,
    ):
        self.model, self.solver, self.scheme, self.time_ = model, solver, scheme, time_
        self.stops, self.reactions, self.errors, self.free = stops, reactions, errors, free
        self.state = StepState()
        #: wall seconds outside the solver: the loads and motions set for a step
        #: (set_time), the state and triad update after it (accept)
        self.wall = {"loads": 0.0, "update": 0.0}

    def attempt(
        self,
        pos: RunPosition,
        t_new: float,
        dt: float,
        scheme: Scheme,
        limit_rotation: bool = True,
        error_check: Callable[[], str | None] | None = None,
    ) -> tuple[bool, int, float, str]:
        """One step to ``t_new`` under ``scheme``: (converged, Newton iterations,
        residual, reason); accepted if it converged and passed the turn limit and
        ``error_check`` (a reason when the step is too long), else restored."""
        self._prepare(scheme, dt, t_new)
        ok, its, res, reason = self._watched_solve(pos, t_new)
        ok, reason = self._judge(ok, res, reason, scheme, limit_rotation, error_check)
        pos.counts["newton_iterations"] += its
        if not ok:
            self.model.restore()
            return False, its, res, reason
        self._accept(scheme, dt, t_new)
        return True, its, res, reason

    def _prepare(self, scheme: Scheme, dt: float, t_new: float) -> None:
        """The step's coefficients, loads and motions at ``t_new`` and its prediction."""
        m = self.model
        t0 = _time.perf_counter()
        m.set_coefficients(scheme.coefficients(dt))
        m.set_time(t_new, scheme)
        # the recent rates carried on (fewer Newton iterations: 3.0 to 2.1 per step on
        # the swimming sheet, 10.4 to 4.6 on the three-link).  In static load steps
        # only with the increments turned (a body of one colour): the roll-up then
        # needs 3.8 instead of 4.6 a step, 6.0 instead of 7.8 at L/t = 1e5 (before the
        # contraction test of solver.py, 5.25 with it); a
        # polynomial in the load parameter (a hinged body's) made its first
        # residuals grow 5000-fold, so there the step starts from the last state
        m.predict(dt, extrapolate=scheme.has_velocity or m.n_colours == 1)
        self.wall["loads"] += _time.perf_counter() - t0

    def _watched_solve(self, pos: RunPosition, t_new: float) -> tuple[bool, int, float, str]:
        """Newton's solve of the step to ``t_new`` under the watch of slow steps: a
        signal in it drops the step (back to the last completed one) or stops the run."""
        watch = self.solver.watch
        if watch is not None:
            watch.start(t_new, pos.completed + 1)
        try:
            ok, its, res, reason = self.solver.solve()
        finally:  # a signal in a slow step (step_watch.py): back to the last completed one
            dropped = watch is not None and watch.dropped is not None
            if dropped:
                self.model.restore()
        if dropped:  # (PETSc gave its callback's exception back, or its own error)
            raise watch.dropped
        if self.stops.immediate:
            # a second signal inside a residual or Jacobian: PETSc turned it into a failed
            # solve (and may have left a vector locked); stop, do not cut
            raise RunInterrupted(self.stops.signum, immediate=True)
        return ok, its, res, reason

    def _judge(
        self,
        ok: bool,
        res: float,
        reason: str,
        scheme: Scheme,
        limit_rotation: bool,
        error_check: Callable[[], str | None] | None,
    ) -> tuple[bool, str]:
        """Whether the solved step is accepted, and why not: a non-finite residual, a
        turn past the limit (its overreach kept for ``halvings``), ``error_check``."""
        m, st = self.model, self.state
        if ok and not math.isfinite(res):
            ok, reason = False, "non-finite residual"
        limit = self.turn_limit(scheme)
        st.overreach = None
        if ok:
            # the solver measured it at every update, the converged iterate's last
            turns = self.solver.turns
            st.last_turn = turns[-1] if turns else m.largest_rotation_increment()
        elif self.solver.divergence is not None and self.solver.turns:
            # the first update's turn is the linearized one: it says how far the
            # step reached beyond what Newton can take
            st.overreach = self.solver.turns[0] / limit
        if ok and limit_rotation and scheme.has_velocity and st.last_turn > limit:
            ok, reason = (
                False,
                (f"a director turned {st.last_turn:.3g} rad > time.max_rotation = {limit:g}"),
            )
            st.overreach = st.last_turn / limit
        st.rejected = False
        if ok and error_check is not None:
            too_big = error_check()
            if too_big:
                ok, reason, st.rejected = False, too_big, True
        return ok, reason

    def _accept(self, scheme: Scheme, dt: float, t_new: float) -> None:
        """The converged step kept: its error estimate, reactions and forces, the state
        and triad updated, a corner of the motions handed on."""
        m = self.model
        if m.keep_predictions:  # the step's error estimate (§6.9), for summary.json
            self.errors.record()
        if self.reactions:
            self.reactions.compute(self.solver.raw_residual())
        self.solver.store_forces()
        t0 = _time.perf_counter()
        m.accept(scheme, dt, t_new)
        if m.drive and scheme.has_inertia:
            impulses.corner(m, self.solver, t_new)
        self.wall["update"] += _time.perf_counter() - t0

    def turn_limit(self, scheme: Scheme) -> float:
        """The turn of a director a step should stay within: ``time.max_rotation`` in
        time, ``STATIC_TURN`` in static load steps."""
        return self.time_["max_rotation"] if scheme.has_velocity else STATIC_TURN

    def halvings(self) -> int:
        """How many times to halve after the failed attempt: once, or as many times as
        its overreach asks (a turn 5 times too large: 3), at most ``MOST_HALVINGS``."""
        overreach = self.state.overreach
        if overreach is None or overreach <= 2.0:
            return 1
        return min(MOST_HALVINGS, math.ceil(math.log2(overreach)))

    def _may_double(self, scheme: Scheme) -> bool:
        """Whether a cut sub-step may be doubled: the doubled one would turn the
        directors by no more than 0.9 of the scheme's turn limit."""
        return 2.0 * self.state.last_turn <= 0.9 * self.turn_limit(scheme)

    def unresolved_hint(self) -> str:
        """What to change when a step is not resolved and nothing holds the body: without
        mass either its stiffness is singular for every step size."""
        if self.free and self.model.inertia_form is None:
            return (
                "; nothing holds this body: without a [[boundary]], a [[motion]], a "
                "[fluid] or mass its rigid motions are free and every step is singular"
            )
        return ""

    def _tangent_along_last_step(self) -> float | None:
        """The tangent's stiffness along the last accepted increment ``Δw`` at the
        current state, ``Δwᵀ K Δw / Δwᵀ Δw`` (None before a step moved the body)."""
        from rftfem import compat

        m, solver = self.model, self.solver
        if not m.increments:
            return None
        du, theta, _ = m.increments[0]
        x = solver.work
        with x.localForm() as local:
            local.set(0.0)
            local.array[m.u_dofs] = du
            local.array[m.theta_dofs] = theta
        compat.set_bc(x, m.bcs, None, 0.0)
        size = x.dot(x)
        if size == 0.0:
            return None
        solver.assemble_tangent(diagnostic=True)
        y = x.duplicate()
        try:
            solver.A.mult(x, y)
            return x.dot(y) / size
        finally:
            y.destroy()

    def _path_stiffness(self) -> None:
        """After the first static load step that moved the body: the tangent's
        stiffness along it, the scale of ``_limit_point_hint``."""
        if self.state.first_stiffness is None:
            self.state.first_stiffness = self._tangent_along_last_step()

    def _limit_point_hint(self, t: float) -> str:
        """For a static run whose steps stall at ``t``: a limit point, if the path's
        stiffness fell below ``LIMIT_POINT_STIFFNESS`` of its start."""
        first = self.state.first_stiffness
        if self.scheme.has_velocity or self.scheme.name == "arc-length" or not first:
            return ""
        along = self._tangent_along_last_step()
        stiffness = along / first if along is not None else None
        if stiffness is None or stiffness >= LIMIT_POINT_STIFFNESS:
            return ""
        return (
            f"; a limit point: the loads stall at t = {t:.6g} and the tangent's "
            f"stiffness along the last step fell to {stiffness:.2g} of the first's, so "
            f"load control cannot go on; follow the path past it with time.scheme = "
            f'"arc-length"'
        )

    def _ramp_hint(self) -> str:
        """For a run that failed in static equilibrium: the loads already on at t = 0,
        to be ramped."""
        keys = self.model.loads_at_start()
        if not keys:
            return ""
        return (
            f"; {', '.join(keys)} {'is' if len(keys) == 1 else 'are'} already on at "
            f"t = 0: ramp {'it' if len(keys) == 1 else 'them'} from 0 with t (ramp = "
            '"linear", or a table or field that starts at 0)'
        )

    def after_step(self, pos: RunPosition, progress: Progress) -> None:
        """Each component's look at the accepted state (``after_step``): a state it
        refuses fails the run here (RunFailed, with this time and step), one it
        doubts is warned of."""
        for comp in self.model.components:
            try:
                lines = comp.after_step(pos.t)
            except RunFailed as exc:
                if exc.time is None:
                    raise RunFailed(exc.reason, pos.t, pos.step) from None
                raise
            for line in lines:
                progress.warn("warning: " + line)

    def advance(self, pos: RunPosition, t_end: float, hooks: RunHooks) -> None:
        """Advance from ``pos.t`` to ``t_end`` (one nominal step), cutting as needed.

        The sub-step starts where the last nominal step left it (``state.level``
        halvings), so a nominal step too long for Newton is not tried whole again
        at every step; after two good sub-steps it is doubled, if the doubled one
        would not turn the directors too far (``_may_double``)."""
        max_cuts, scheme, progress = self.time_["max_cuts"], self.scheme, hooks.progress
        level = min(self.state.level, max_cuts)
        dt = (t_end - pos.t) / 2**level
        good = 0
        while pos.t < t_end - 1e-12 * max(1.0, abs(t_end)):
            dt = min(dt, t_end - pos.t)
            wall0 = _time.perf_counter()
            ok, its, res, reason = self.attempt(pos, pos.t + dt, dt, scheme)
            if ok:
                pos.t += dt
                pos.counts["steps"] += 1
                if not scheme.has_velocity:
                    self._path_stiffness()
                hooks.step_row([pos.t, dt, its, res, _time.perf_counter() - wall0], pos.t)
                hooks.observe()
                self.after_step(pos, progress)
                good += 1
                last_turn = self.state.last_turn
                if not scheme.has_velocity and last_turn > STATIC_TURN and level < max_cuts:
                    # a load step that turned too far: the next ones shorter (no failure)
                    halvings = min(
                        MOST_HALVINGS,
                        max_cuts - level,
                        math.ceil(math.log2(last_turn / STATIC_TURN)),
                    )
                    dt, level, good = dt / 2**halvings, level + halvings, 0
                elif level > 0 and good >= 2 and self._may_double(scheme):
                    dt, level, good = 2 * dt, level - 1, 0
                continue
            if level >= max_cuts:
                raise RunFailed(
                    f"step not resolved ({reason}, {its} Newton iterations, residual "
                    f"{res:.3e}) after {max_cuts} step halvings (time.max_cuts), "
                    f"dt = {dt:.3e}"
                    + self.unresolved_hint()
                    + self._limit_point_hint(pos.t)
                    + ("" if scheme.has_velocity else self._ramp_hint()),
                    pos.t + dt,
                    pos.step,
                )
            halvings = min(self.halvings(), max_cuts - level)
            pos.counts["dt_cuts"] += 1
            level, good = level + halvings, 0
            dt /= 2**halvings
            progress.log(
                f"step {pos.step} at t = {pos.t:.6g}: {reason} after {its} Newton "
                f"iterations; dt to {dt:.3e}" + (f" ({halvings} halvings)" if halvings > 1 else "")
            )
        self.state.level = level
        pos.t = t_end  # exact nominal time, free of round-off from the sub-steps

    def run(self, pos: RunPosition, hooks: RunHooks) -> None:
        """Steps of time.dt to time.end (or to a steady period), a row every
        ``output_every`` steps, checkpoints, and a stop between steps if asked."""
        time_ = self.time_
        n_steps = max(1, math.ceil(time_["end"] / time_["dt"] - 1e-9))
        for pos.step in range(pos.completed + 1, n_steps + 1):
            self.advance(pos, min(pos.step * time_["dt"], time_["end"]), hooks)
            if pos.step % time_["output_every"] == 0 or pos.step == n_steps:
                hooks.output(pos.t)
            hooks.progress.update(
                pos.t,
                pos.step,
                pos.counts["newton_iterations"],
                self.solver.snes.getFunctionNorm(),
            )
            pos.complete(pos.step)
            last = hooks.steady() or pos.step == n_steps
            hooks.checkpoint(last=last)
            if last:
                break
            hooks.stop_if_asked()
