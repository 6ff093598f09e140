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

from rftfem import compat
from rftfem.errors import RunFailed, RunInterrupted
from rftfem.integration.convergence import ROTATION_RANGE
from rftfem.integration.step_control import STATIC_TURN

if TYPE_CHECKING:
    from mpi4py import MPI

    from rftfem.integration.interrupts import NoStops, StopRequests
    from rftfem.integration.run_state import RunHooks, RunPosition
    from rftfem.integration.schemes import Scheme
    from rftfem.integration.solver import StepSolver
    from rftfem.model.reactions import Reactions
    from rftfem.model.shell_model import Model

#: the Newton iterations an arc step should take; Δs grows or shrinks towards it
DESIRED_ITERATIONS = 5
#: an arc step not converged after this many updates (or snes_max_it, if fewer) is
#: cut: a shorter arc is cheaper than more updates far from the path (on the truss's
#: sharp turns, steps that had not converged in 12 updates oscillated to 25)
MOST_ITERATIONS = 12
#: the most the path may turn in one arc step (rad): the angle between a converged
#: step's displacement increment and the last one's.  A step that turned further
#: crossed a bend of the path it did not follow and is retried with half the arc
#: (the pull-out's steps turned 0.07-0.15 rad, and 0.71 rad where one jumped its snap)
PATH_TURN = 0.35
#: the largest arc, as a multiple of the first: the first step's length (its Δλ is
#: time.dt) sets how finely the path is followed (with 8, the pull-out's first arc,
#: taken from its soft start, crossed the snap in one step)
MAX_GROWTH = 2.0
#: the step of the forward difference of the loads in λ, relative to max(|λ|, end)
LOAD_DIFFERENCE = 1e-7


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


class PathFollowing:
    """Steps along the equilibrium path of a static run by arc length, from the
    state in ``state`` (:class:`PathState`) with the run's model and solver."""

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

    def _path_setup(self):
        """Work vectors and the mask of owned displacement dofs."""
        s, m = self.solver, self.model
        self._da, self._db, self._q, self._r2 = (s.x.duplicate() for _ in range(4))
        n = m.W.dofmap.index_map.size_local * m.W.dofmap.index_map_bs
        self._u_owned = np.asarray(m.u_dofs)[np.asarray(m.u_dofs) < n]

    def _path_destroy(self):
        for v in (getattr(self, name, None) for name in ("_da", "_db", "_q", "_r2")):
            if v is not None:
                v.destroy()

    def _dot_u(self, a: np.ndarray, b: np.ndarray) -> float:
        i = self._u_owned
        return self.comm.allreduce(float(np.dot(a[i], b[i])))

    def _solve(self, rhs, out):
        t0 = _time.perf_counter()
        ksp = self.solver.snes.getKSP()
        ksp.setOperators(self.solver.A, self.solver.A)
        ksp.solve(rhs, out)
        self.solver.timings["solve"] += _time.perf_counter() - t0
        reason = ksp.getConvergedReason()
        if reason < 0:
            raise _StepFailed(f"the linear solve failed ({reason})")

    def _load_derivative(self, x, lam: float):
        """``q = −∂R/∂λ`` at ``x`` into ``self._q`` (forward difference; ``self.solver.b``
        must hold ``R(x, λ)``)."""
        m, s = self.model, self.solver
        h = LOAD_DIFFERENCE * max(abs(lam), self.time_["end"])
        m.set_time(lam + h)
        s.residual(x, self._r2)
        m.set_time(lam)
        self._r2.axpy(-1.0, s.b)
        self._r2.copy(self._q)
        self._q.scale(-1.0 / h)

    def _arc_step(self, pos: RunPosition, arc: float | None, target: float | None = None):
        """One converged step from the last state: along the arc ``arc`` (None: the
        first, ``Δλ = first_increment``), or to the load factor ``target`` under load
        control. Returns (λ, arc, Newton iterations, residual); the model holds the
        converged iterate. Raises _StepFailed with the reason when Newton does not
        converge."""
        m, s, st = self.model, self.solver, self.state
        x, b = s.x, s.b
        lam0 = st.load_factor
        compat.petsc_vec(m.w).copy(x)
        start = x.array.copy()
        m.start_newton()
        m.set_time(lam0)
        s.residual(x, b)
        s.jacobian(x)
        self._load_derivative(x, lam0)
        self._solve(self._q, self._db)
        db = self._db.array
        size = math.sqrt(self._dot_u(db, db))
        if arc is None and target is None:  # the first step: a load step of time.dt
            target = lam0 + st.first_increment
        if target is not None:
            dlam = target - lam0
        else:
            if size == 0.0:
                raise RunFailed(
                    "arc-length: the loads and motions do not move the body "
                    "(their derivative in the load factor is zero)",
                    pos.t,
                    pos.step,
                )
            sign = 1.0
            if st.path_direction is not None and self._dot_u(db, st.path_direction) < 0:
                sign = -1.0
            dlam = sign * arc / size
        x.axpy(dlam, self._db)
        lam = lam0 + dlam
        rtol, atol, stol, max_it = s.snes.getTolerances()
        max_it = min(max_it, MOST_ITERATIONS)
        first = None
        update = xnorm = last = 0.0  # the last update's length, the iterate's, its residual
        for it in range(1, max_it + 1):
            m.set_time(lam)
            s.residual(x, b)
            fnorm = b.norm()
            if not math.isfinite(fnorm):
                raise _StepFailed("the residual is not finite", it - 1, fnorm)
            first = fnorm if first is None else first
            if it > 1 and (
                fnorm < atol
                or fnorm <= rtol * first
                or update < stol * xnorm
                or (fnorm <= s.floor() and fnorm > 0.5 * last)
            ):
                return lam, arc, it - 1, fnorm
            last = fnorm
            s.jacobian(x)
            b.scale(-1.0)
            self._solve(b, self._da)
            b.scale(-1.0)
            self._load_derivative(x, lam)
            self._solve(self._q, self._db)
            da, db = self._da.array, self._db.array
            if target is not None:
                dl = 0.0
            else:
                dl = self._constraint_root(x.array - start, da, db, arc, it)
            x.axpy(1.0, self._da)
            x.axpy(dl, self._db)
            lam += dl
            update = (
                self._da.norm() ** 2
                + 2 * dl * self._da.dot(self._db)
                + dl**2 * self._db.norm() ** 2
            ) ** 0.5
            xnorm = x.norm()
            s.sync(x)
            turn = m.largest_rotation_increment()
            if turn >= ROTATION_RANGE:
                raise _StepFailed(
                    f"Newton diverged: a rotation increment reached {turn:.3g} "
                    f"rad >= pi at update {it}",
                    it,
                    fnorm,
                )
            if self.stops.immediate:
                raise RunInterrupted(self.stops.signum, immediate=True)
        raise _StepFailed(f"no convergence in {max_it} Newton iterations", max_it, fnorm)

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

    def _constraint_root(self, D, da, db, arc, it):
        """δλ with ‖D + δa + δλ δb‖_u = arc, the root turning the increment least."""
        e = D + da
        a1 = self._dot_u(db, db)
        a2 = 2.0 * self._dot_u(db, e)
        a3 = self._dot_u(e, e) - arc**2
        disc = a2 * a2 - 4.0 * a1 * a3
        if a1 == 0.0 or disc < 0.0:
            raise _StepFailed(
                "the arc-length constraint has no real root (the arc is too "
                "long for the path's curvature here)",
                it,
                math.nan,
            )
        roots = [(-a2 + sgn * math.sqrt(disc)) / (2.0 * a1) for sgn in (1.0, -1.0)]
        return max(roots, key=lambda r: self._dot_u(e + r * db, D))

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
        st, counts, progress = self.state, pos.counts, hooks.progress
        cuts = 0
        arc = st.arc
        while True:
            wall0 = _time.perf_counter()
            try:
                lam, arc, its, res = self._arc_step(pos, arc)
                landed = False
                if lam > end * (1 + 1e-12) and st.load_factor < end:
                    # past the end: land on it under load control, else keep the arc step
                    kept = self.model.w.x.array.copy()
                    self.model.restore()
                    try:
                        lam, _, its2, res = self._arc_step(pos, arc, target=end)
                        its += its2
                        landed = True
                    except _StepFailed:
                        self.model.w.x.array[:] = kept
                        self.model.set_time(lam)
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
                break
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


class _StepFailed(Exception):
    def __init__(self, reason: str, its: int = 0, residual: float = math.nan):
        super().__init__(reason)
        self.reason, self.its, self.residual = reason, its, residual
