"""Static path-following by arc length (``time.scheme = "arc-length"``,
docs/model.md §6.11).

The load factor λ joins the unknowns: the loads' and motions' time functions
are evaluated at t = λ, and each step finds ``(w, λ)`` with ``R(w, λ) = 0`` on a
cylinder of radius Δs about the last converged state (Crisfield):

    ‖Δu‖² = Δs²,

``Δu`` the step's displacement increment (the rotations are left out: their
increments are a few times the displacements' over a length, and the
displacements alone pass every limit point of a shell).  Newton's update on
the bordered system is found by block elimination with the step's one
factorisation of the tangent ``K``:

    K δa = −R,    K δb = q = −∂R/∂λ,    δw = δa + δλ δb,

and δλ from the constraint, a quadratic; of its two roots the one whose new
increment makes the smaller angle with the step's last increment.  Solving for
δa and δb costs one back-substitution more than a load step's update, and ``q``
one residual more (the λ-derivative of the loads' time functions by a forward
difference: they are Python functions of t, not UFL; the derivative with
respect to w is the form's own ``ufl.derivative``).

The predictor ``δλ₀ = ± Δs / ‖δb_u‖`` takes the sign that makes its increment
point along the last converged one (``δb·Δu_prev > 0``): the path's own
direction, which passes load limit points (where λ turns back) and
snap-backs (where the displacement does) alike; the tangent's determinant
changes sign at bifurcations too, and would turn the path back there.  The
first step is a load step of ``Δλ = time.dt``, and its length is the first
Δs.  Δs then follows Newton's effort, ``Δs ← Δs √(N_d / N)`` with ``N_d`` =
``DESIRED_ITERATIONS`` (within ½ and 2 per step, at most ``MAX_GROWTH`` times the
first), and shrinks where a step turned a director further than the static
load steps allow; a failed step is retried with half the arc
(``time.max_cuts`` times in a row at most).  The step that would pass
``time.end`` is replaced by a load-controlled one to λ = end, so the run ends
there exactly (if that Newton solve fails, the arc step is kept).
"""

from __future__ import annotations

import math
import time as _time
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from rftfem.errors import RunFailed
from rftfem.integration.arc_newton import LOAD_DIFFERENCE as LOAD_DIFFERENCE
from rftfem.integration.arc_newton import MOST_ITERATIONS as MOST_ITERATIONS
from rftfem.integration.arc_newton import BorderedNewton, _StepFailed
from rftfem.integration.step_control import STATIC_TURN

if TYPE_CHECKING:
    from mpi4py import MPI

    from rftfem.integration.interrupts import NoStops, StopRequests
    from rftfem.integration.run_state import RunHooks, RunPosition
    from rftfem.integration.schemes import Scheme
    from rftfem.integration.solver import StepSolver
    from rftfem.model.reactions import Reactions
    from rftfem.model.shell_model import Model
    from rftfem.outputs.progress import Progress

#: the Newton iterations an arc step should take; Δs grows or shrinks towards it
DESIRED_ITERATIONS = 5
#: the most the path may turn in one arc step (rad): the angle between a converged
#: step's displacement increment and the last one's.  A step that turned further
#: crossed a bend of the path it did not follow and is retried with half the arc
#: (the pull-out's steps turned 0.07-0.15 rad, and 0.71 rad where one jumped its snap)
PATH_TURN = 0.35
#: the largest arc, as a multiple of the first: the first step's length (its Δλ is
#: time.dt) sets how finely the path is followed (with 8, the pull-out's first arc,
#: taken from its soft start, crossed the snap in one step)
MAX_GROWTH = 2.0


@dataclass
class PathState:
    """Where an arc-length run is on its path (a checkpoint keeps it all)."""

    #: the load factor λ: the time the loads and motions are evaluated at
    load_factor: float = 0.0
    #: the next step's arc (None: the first, from Δλ = ``first_increment``)
    arc: float | None = None
    #: the first step's length, the scale of every later arc
    first_arc: float | None = None
    #: the last step's displacement increment (the path's direction)
    path_direction: np.ndarray | None = None
    #: Δλ of the first step: time.dt, halved while it fails
    first_increment: float = 0.0
    #: the last converged step's residual norm
    last_residual: float = math.nan


class PathFollowing(BorderedNewton):
    """Steps along the equilibrium path of a static run by arc length, from the
    state in ``state`` (:class:`PathState`) with the run's model and solver (each
    step's Newton solve: arc_newton.py)."""

    def __init__(
        self,
        model: Model,
        solver: StepSolver,
        scheme: Scheme,
        comm: MPI.Comm,
        time_: dict,
        stops: StopRequests | NoStops,
        reactions: Reactions,
    ):
        self.model, self.solver, self.scheme, self.comm = model, solver, scheme, comm
        self.time_, self.stops, self.reactions = time_, stops, reactions
        self.state = PathState(first_increment=time_["dt"])

    def _path_turn(self) -> float:
        """The angle (rad) between the converged step's displacement increment and the
        last step's (0 at the first step)."""
        last = self.state.path_direction
        if last is None:
            return 0.0
        d = self.model.w.x.array - _u_of(self.model)
        norms = math.sqrt(self._dot_u(d, d) * self._dot_u(last, last))
        cos = self._dot_u(d, last) / norms if norms > 0 else 1.0
        return math.acos(max(-1.0, min(1.0, cos)))

    def run(self, pos: RunPosition, hooks: RunHooks) -> None:
        """Steps along the path until λ reaches ``time.end`` or ``time.max_steps``."""
        time_, st, counts = self.time_, self.state, pos.counts
        end, max_steps, max_cuts = time_["end"], time_["max_steps"], time_["max_cuts"]
        self._path_setup()
        try:
            while pos.completed < max_steps and st.load_factor < end * (1 - 1e-12):
                pos.step = pos.completed + 1
                self._advance(pos, hooks, end, max_cuts)
                if pos.step % time_["output_every"] == 0 or st.load_factor >= end * (1 - 1e-12):
                    hooks.output(pos.t)
                hooks.progress.update(
                    st.load_factor, pos.step, counts["newton_iterations"], st.last_residual
                )
                pos.complete(pos.step)
                done = pos.completed >= max_steps or st.load_factor >= end * (1 - 1e-12)
                hooks.checkpoint(last=done)
                if not done:
                    hooks.stop_if_asked()
            if st.load_factor < end * (1 - 1e-12):
                if not hooks.wrote_at(pos.t):
                    hooks.output(pos.t)
                hooks.progress.warn(
                    f"arc-length: time.max_steps = {max_steps} steps reached at load "
                    f"factor {st.load_factor:.6g}, before time.end = {end:g}"
                )
        finally:
            self._path_destroy()

    def _advance(self, pos: RunPosition, hooks: RunHooks, end: float, max_cuts: int) -> None:
        """One converged arc step (cut and retried as needed), accepted."""
        lam, arc, its, res, wall0 = self._resolved_step(pos, hooks.progress, end, max_cuts)
        self._accept(pos, hooks, lam, arc, its, res, wall0)

    def _resolved_step(
        self, pos: RunPosition, progress: Progress, end: float, max_cuts: int
    ) -> tuple[float, float | None, int, float, float]:
        """A converged arc step, its arc halved after a failure or a turn of the path
        (at most ``max_cuts`` times): (λ, arc, Newton iterations, residual, the wall
        time its last try began)."""
        st, counts = self.state, pos.counts
        cuts = 0
        arc = st.arc
        while True:
            wall0 = _time.perf_counter()
            try:
                lam, arc, its, res = self._arc_step(pos, arc)
                lam, its, res, landed = self._land_on_end(pos, arc, lam, its, res, end)
                turn = self._path_turn()
                if not landed and turn > PATH_TURN and cuts < max_cuts:
                    # converged, but across a turn of the path it did not follow
                    counts["newton_iterations"] += its
                    counts["rejected_steps"] += 1
                    self.model.restore()
                    cuts += 1
                    arc *= 0.5
                    progress.log(
                        f"step {pos.step} at load factor {st.load_factor:.6g}: the "
                        f"path turned {turn:.2f} rad > {PATH_TURN} in one step; arc "
                        "halved"
                    )
                    continue
                return lam, arc, its, res, wall0
            except _StepFailed as failed:
                counts["newton_iterations"] += failed.its
                self.model.restore()
                if cuts >= max_cuts:
                    raise RunFailed(
                        f"arc-length step not resolved ({failed.reason}) after "
                        f"{max_cuts} halvings of the arc (time.max_cuts), arc = "
                        f"{(arc or 0.0):.3e}",
                        pos.t,
                        pos.step,
                    ) from None
                cuts += 1
                counts["dt_cuts"] += 1
                if arc is None:  # the first step: halve its Δλ
                    st.first_increment *= 0.5
                else:
                    arc *= 0.5
                progress.log(
                    f"step {pos.step} at load factor {st.load_factor:.6g}: "
                    f"{failed.reason}; arc halved"
                )

    def _land_on_end(
        self,
        pos: RunPosition,
        arc: float | None,
        lam: float,
        its: int,
        res: float,
        end: float,
    ) -> tuple[float, int, float, bool]:
        """A converged arc step to ``lam`` past ``end``: replaced by a load-controlled
        one to ``end`` if that converges, else kept.  Returns (λ, Newton iterations,
        residual, whether it landed on the end)."""
        if not (lam > end * (1 + 1e-12) and self.state.load_factor < end):
            return lam, its, res, False
        # past the end: land on it under load control, else keep the arc step
        kept = self.model.w.x.array.copy()
        self.model.restore()
        try:
            lam_end, _, its2, res_end = self._arc_step(pos, arc, target=end)
        except _StepFailed:
            self.model.w.x.array[:] = kept
            self.model.set_time(lam)
            return lam, its, res, False
        return lam_end, its + its2, res_end, True

    def _accept(
        self,
        pos: RunPosition,
        hooks: RunHooks,
        lam: float,
        arc: float | None,
        its: int,
        res: float,
        wall0: float,
    ) -> None:
        """The converged step kept: counted, the state and path moved on, its row; the
        next arc from its Newton iterations and turn."""
        st, counts = self.state, pos.counts
        counts["newton_iterations"] += its
        counts["steps"] += 1
        m = self.model
        step_length = math.sqrt(self._dot_u(*(2 * [m.w.x.array - _u_of(m)])))
        direction = m.w.x.array - _u_of(m)
        turn = m.largest_rotation_increment()
        if self.reactions:
            self.reactions.compute(self.solver.raw_residual())
        self.solver.store_forces()
        m.accept(self.scheme, max(lam - st.load_factor, 1e-300), lam)
        st.path_direction = direction
        pos.t += step_length
        st.load_factor = lam
        st.last_residual = res
        if st.first_arc is None:  # the first step set the arc: its own length
            if step_length == 0.0:
                raise RunFailed(
                    "arc-length: the first step (time.dt) did not move the body: "
                    "the loads and motions do not depend on the load factor",
                    pos.t,
                    pos.step,
                )
            arc = st.first_arc = step_length
        hooks.step_row([pos.t, step_length, its, res, _time.perf_counter() - wall0], lam)
        hooks.observe()
        # the next arc: towards DESIRED_ITERATIONS, within the growth bounds
        factor = min(2.0, max(0.5, math.sqrt(DESIRED_ITERATIONS / max(its, 1))))
        if turn > STATIC_TURN:
            factor = min(factor, STATIC_TURN / turn)
        st.arc = min(arc * factor, MAX_GROWTH * st.first_arc)


def _u_of(model) -> np.ndarray:
    """The last converged displacement as a local array of ``w`` (θ = 0)."""
    out = np.zeros_like(model.w.x.array)
    out[model.u_dofs] = model.u_n.x.array
    return out
