"""Newton's method on the bordered system of one arc step (arclength.py's constraint)."""

from __future__ import annotations

import math
import time as _time
from typing import TYPE_CHECKING

import numpy as np

from rftfem import compat
from rftfem.errors import RunFailed, RunInterrupted
from rftfem.integration.convergence import ROTATION_RANGE

if TYPE_CHECKING:
    from mpi4py import MPI

    from rftfem.integration.arclength import PathState
    from rftfem.integration.interrupts import NoStops, StopRequests
    from rftfem.integration.run_state import RunPosition
    from rftfem.integration.solver import StepSolver
    from rftfem.model.shell_model import Model

#: an arc step not converged after this many updates (or snes_max_it, if fewer) is
#: cut: a shorter arc is cheaper than more updates far from the path (on the truss's
#: sharp turns, steps that had not converged in 12 updates oscillated to 25)
MOST_ITERATIONS = 12
#: the step of the forward difference of the loads in λ, relative to max(|λ|, end)
LOAD_DIFFERENCE = 1e-7


class BorderedNewton:
    """The arc step of :class:`~rftfem.integration.arclength.PathFollowing`: a
    predictor along the tangent and Newton's updates of ``(w, λ)`` under the arc's
    constraint, with the run's model, solver and ``state``."""

    model: Model
    solver: StepSolver
    comm: MPI.Comm
    time_: dict
    stops: StopRequests | NoStops
    state: PathState

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

    def _arc_step(
        self, pos: RunPosition, arc: float | None, target: float | None = None
    ) -> tuple[float, float | None, int, float]:
        """One converged step from the last state: along the arc ``arc`` (None: the
        first, ``Δλ = first_increment``), or to the load factor ``target`` under load
        control. Returns (λ, arc, Newton iterations, residual); the model holds the
        converged iterate. Raises _StepFailed with the reason when Newton does not
        converge."""
        lam, start, target = self._predictor(pos, arc, target)
        return self._corrector(lam, arc, target, start)

    def _predictor(
        self, pos: RunPosition, arc: float | None, target: float | None
    ) -> tuple[float, np.ndarray, float | None]:
        """The step's first iterate into ``solver.x``: from the last state along the
        tangent ``δb`` by ``arc`` in the path's direction, or by ``Δλ`` to ``target``
        (the first step's: ``first_increment``).  Returns (λ, the last state's array,
        the load factor a load-controlled step goes to, or None)."""
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
        return lam0 + dlam, start, target

    def _corrector(
        self, lam: float, arc: float | None, target: float | None, start: np.ndarray
    ) -> tuple[float, float | None, int, float]:
        """Newton's updates of ``(w, λ)`` from the first iterate ``solver.x`` at ``lam``
        until SNES's tolerances (or the round-off floor) are met: (λ, arc, Newton
        iterations, residual).  Raises _StepFailed when Newton does not converge."""
        m, s = self.model, self.solver
        x, b = s.x, s.b
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
            lam, update = self._bordered_update(lam, arc, target, start, it)
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

    def _bordered_update(
        self, lam: float, arc: float | None, target: float | None, start: np.ndarray, it: int
    ) -> tuple[float, float]:
        """Update ``it`` of the iterate ``solver.x`` (its residual in ``solver.b``) by
        block elimination, ``δw = δa + δλ δb``, δλ from the constraint (0 under load
        control): (the new λ, the update's length)."""
        s = self.solver
        x, b = s.x, s.b
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
            self._da.norm() ** 2 + 2 * dl * self._da.dot(self._db) + dl**2 * self._db.norm() ** 2
        ) ** 0.5
        return lam, update

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


class _StepFailed(Exception):
    def __init__(self, reason: str, its: int = 0, residual: float = math.nan):
        super().__init__(reason)
        self.reason, self.its, self.residual = reason, its, residual
