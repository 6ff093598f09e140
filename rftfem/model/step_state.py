"""What a step starts from (a part of :class:`~rftfem.model.shell_model.Model`, docs/model.md
§6.9, §7.1, §7.4): the prediction carried on from the last steps' increments, how
far a converged step lies from it (the error estimate's data), the data of Newton's
mixed-point tangent from the first iterate on, and the state a checkpoint keeps.
"""

from __future__ import annotations

import numpy as np
from mpi4py import MPI

from rftfem.model.effects.base import LimitsNewtonStep
from rftfem.model.triad import rotate as triad_rotate


class StepStart:
    """Prediction, Newton start and saved state of a Model."""

    def predict(self, dt: float, extrapolate: bool = True) -> None:
        """Start a step of ``dt`` from the last state carried on at the recent rates.

        The rate of the last step, ``q₁ = Δ_n/Δt_n`` (Δ = Δu, or θ), belongs to the
        middle of that step, the one before, ``q₀``, to the middle of its own: the
        rate taken linear in time through the two and integrated over the new step
        gives ``Δ = Δt (q₁ + (q₁ − q₀) s/h)``, with ``h`` the time between the two
        middles and ``s`` from the last middle to the new one; with one step known
        ``Δ = Δt q₁``. ``θ`` is a rotation increment whose components belong to
        the triad of its step, which the update has turned since by ``θ`` itself:
        second order in it, as is a predictor's error. Without a step known, or
        not ``extrapolate``, the step starts from the last state (``θ = 0``)."""
        self.restore()
        self.predicted_step = 0.0
        self.prediction = None
        if not self.increments or not extrapolate:
            return
        u_n = self.w.x.array[self.u_dofs].copy()
        qu, qt = self._extrapolated_rates(dt)
        if self.keep_predictions:
            # the error control (time.tolerance) measures against polynomial
            # extrapolations, whose error constants its estimate assumes (§6.9)
            du, theta, dt_1 = self.increments[0]
            polynomial = self._extrapolated_rates(dt, turn=False)
            self.prediction = {
                1: (u_n + dt * du / dt_1, dt * theta / dt_1),
                len(self.increments): (u_n + dt * polynomial[0], dt * qt),
            }
        fraction = self._prediction_fraction(u_n, dt * qu)
        self.w.x.array[self.u_dofs] = u_n + fraction * dt * qu
        self.w.x.array[self.theta_dofs] = fraction * dt * qt
        local = float(np.abs(qu).max()) * dt if len(qu) else 0.0
        self.predicted_step = self.comm.allreduce(local, op=MPI.MAX)

    def _prediction_fraction(self, u_n, du) -> float:
        """The part of a predicted increment ``du`` the effects allow (contact: the
        prediction may not carry the lower face through its barrier, as a Newton update
        may not; solver.py), 1 without such effects."""
        limits = [c for c in self.components if isinstance(c, LimitsNewtonStep)]
        if not limits:
            return 1.0
        start = np.zeros_like(self.w.x.array)
        start[self.u_dofs] = u_n
        step = np.zeros_like(start)
        step[self.u_dofs] = -du
        return min(c.newton_step_fraction(start, step, keep=0.3) for c in limits)

    def _extrapolated_rates(self, dt: float, turn: bool = True):
        """The rates ``(q_u, q_θ)`` of ``predict`` for a step of ``dt``.  With ``turn``,
        on a body of one colour, each node's displacement increments are first turned
        by its own rotation increment (the last step's θ, scaled to ``dt``; the one
        before turned once more): a body turning at a steady rate then moves each
        node along its circle, where a polynomial in time cuts the chord and
        stretches the body (a plate spinning 1/16 turn a step: 7.0 Newton iterations
        a step from the polynomial, 4.3 from the turned increments)."""
        du, theta, dt_1 = self.increments[0]
        rot = None
        if turn and self.n_colours == 1:
            idx = self.triad.node_maps[0]
            a1, a2, _ = (f.x.array.reshape(-1, 3) for f in self.triads[0])
            th = theta.reshape(-1, 2)
            rot = th[:, 0:1] * a1[idx] + th[:, 1:2] * a2[idx]

        def turned(v, scale):
            """``v`` with each node's vector turned by ``scale`` × its rotation increment."""
            if rot is None:
                return v
            v3 = v.reshape(-1, 3).copy()
            v3[idx] = triad_rotate(v3[idx], scale * rot)
            return v3.ravel()

        du = turned(du, dt / dt_1)
        qu, qt = du / dt_1, theta / dt_1
        if len(self.increments) == 2:
            du_0, theta_0, dt_0 = self.increments[1]
            du_0 = turned(turned(du_0, 1.0), dt / dt_1)
            weight = (0.5 * (dt_1 + dt)) / (0.5 * (dt_1 + dt_0))
            qu = qu + weight * (qu - du_0 / dt_0)
            qt = qt + weight * (qt - theta_0 / dt_0)
        return qu, qt

    def prediction_error(self, past_steps: int = 2) -> tuple[float, float] | None:
        """How far the converged iterate lies from a prediction made from the last
        ``past_steps`` steps (1: the last rate carried on, 2: the last two rates
        extrapolated): the largest nodal ``|u − u^P|`` and ``|θ − θ^P|`` over all
        processes; None if the step started from the last state (no step known,
        docs/model.md §6.9).  With one step known the linear prediction
        stands in for the quadratic one (an over-estimate: the safe side)."""
        if self.prediction is None:
            return None
        u_p, theta_p = self.prediction[min(past_steps, max(self.prediction))]
        du = self.w.x.array[self.u_dofs] - u_p
        dth = (self.w.x.array[self.theta_dofs] - theta_p).reshape(-1, 2)
        local = (
            float(np.abs(du).max()) if len(du) else 0.0,
            float(np.sqrt((dth**2).sum(axis=1)).max()) if len(dth) else 0.0,
        )
        both = np.array(local)
        self.comm.Allreduce(MPI.IN_PLACE, both, op=MPI.MAX)
        return float(both[0]), float(both[1])

    def start_newton(self) -> None:
        """A Newton solve begins: its first tangent is that of ``first_tangent_converged``,
        the next ones the mixed-point tangents of the updates Newton makes (docs/model.md
        §7.4)."""
        self._newton_last = None

    def tangent_at_iterate(self) -> None:
        """Before a tangent at the iterate ``w``: the data of its correction (the last
        iterate, this one, their difference); this one is the next one's last.

        At a solve's first iterate there is no last one.  With
        ``first_tangent_converged`` the "last" is the last converged state and the
        difference is taken as zero: the defect ``ε(w) − ε(w_n)`` then replaces the
        start's membrane and shear resultants by the converged ones (the stress
        predictor of the mixed-integration-point method).  Without it the defect is
        zero: the exact tangent at the start."""
        if not self.mixed_point:
            return
        current = self.w.x.array
        if self._newton_last is None and self.first_tangent_converged:
            converged = current.copy()
            converged[self.u_dofs] = self.u_n.x.array
            converged[self.theta_dofs] = 0.0
            self._set_newton_data(converged, current)
            self.newton_update.x.array[:] = 0.0
            self._newton_last = current.copy()
            return
        if self._newton_last is None:
            self._newton_last = current.copy()
        self._set_newton_data(self._newton_last, current)
        self._newton_last = current.copy()

    def _set_newton_data(self, previous, current):
        """The mixed-point tangent's data from two iterates of ``w``, as ``z``: the
        iterates mapped, and the update as its first-order change of ``z`` at the
        previous one, ``P(w_prev) Δw`` (the strains' linearization along the Newton
        update itself; the chord of the nodal directors made Newton diverge on a
        link turning 0.06 rad a step)."""
        self.directors.map(previous, out=self.newton_previous.x.array)
        self.directors.map(current, out=self.newton_current.x.array)
        self.directors.direction(previous, current - previous, self.newton_update.x.array)

    def state(self) -> tuple[dict, list]:
        """What a checkpoint keeps of the model (checkpoint.py): this process's arrays
        of the iterate, the last state, every colour's triad and the last increments,
        and the increments' steps."""
        arrays = {
            "w": self.w.x.array,
            "u_n": self.u_n.x.array,
            "v_n": self.v_n.x.array,
            "a_n": self.a_n.x.array,
        }
        for c, frame in enumerate(self.triads):
            for k, f in enumerate(frame):
                arrays[f"triad_{c}_{k}"] = f.x.array
        for i, (du, theta, _) in enumerate(self.increments):
            arrays[f"increment_{i}_u"], arrays[f"increment_{i}_theta"] = du, theta
        return {k: v.copy() for k, v in arrays.items()}, [dt for *_, dt in self.increments]

    def set_state(self, arrays: dict, increment_steps: list) -> None:
        """The model as ``state`` returned it (a restart)."""
        for name, f in (("w", self.w), ("u_n", self.u_n), ("v_n", self.v_n), ("a_n", self.a_n)):
            f.x.array[:] = arrays[name]
        for c, frame in enumerate(self.triads):
            for k, f in enumerate(frame):
                f.x.array[:] = arrays[f"triad_{c}_{k}"]
        self.increments = [
            (arrays[f"increment_{i}_u"], arrays[f"increment_{i}_theta"], dt)
            for i, dt in enumerate(increment_steps)
        ]
