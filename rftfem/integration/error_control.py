"""Error-controlled steps and the time-error indicator (the part of
:class:`~rftfem.integration.simulation.Simulation` that owns them, docs/model.md §6.9, §6.11):
each converged step's local error estimated from its distance to a prediction,
steps chosen by it under ``time.tolerance``, and with fixed steps the same estimate
kept for summary.json without acting on it.
"""

from __future__ import annotations

import math
import time as _time

import numpy as np

from rftfem.errors import RunFailed

#: error-controlled steps: a step that took more Newton iterations than this is not
#: followed by a longer one (docs/model.md §6.9)
NEWTON_GROWTH_LIMIT = 8
#: fixed steps in time: a mean estimated local error (§6.9's estimate, relative to the
#: body's size) above this is reported as a step too long (docs/model.md §6.11)
TIME_ERROR_WARNING = 1e-3


class ErrorControl:
    """Error-control methods of a Simulation."""

    def _local_error(self) -> float | None:
        """The converged step's estimated local error relative to ``time.tolerance``'s
        units: ``f · max(|u − u^P| / size, |θ − θ^P|)`` (docs/model.md §6.9), or None
        without a prediction (the first step)."""
        e = self.model.prediction_error(self.scheme.error_predictor)
        if e is None:
            return None
        eu, eth = e
        return self.scheme.error_fraction * max(eu / self.model.size(), eth)

    def _run_adaptive(self, logs, progress):
        """From t = 0 to the end with steps chosen by the local error: accepted when
        ``err ≤ tol``, the next one ``h (0.9 tol/err)^(1/(p+1))`` within [⅕, 2] h and
        [dt_min, dt_max]; a rejected step is retried at that size (counted in
        ``rejected_steps``), a Newton failure or a too-large turn at half (``dt_cuts``).
        Steps are clipped to land on every output time (``output_every`` × ``dt``)."""
        time_ = self.scene["time"]
        tol, end = time_["tolerance"], time_["end"]
        self.model.keep_predictions = True
        dt_min, dt_max = time_["dt_min"], time_["dt_max"]
        spacing = time_["dt"] * time_["output_every"]
        exponent = 1.0 / (self.scheme.order + 1)
        steps_log = logs.get("steps")
        h, cuts_in_row, n_out = time_["dt"], 0, max(1, math.ceil(end / spacing - 1e-9))
        if self.resume is not None and self.resume[1].get("next_step"):
            h = self.resume[1]["next_step"]
        state = {}

        def check():
            err = self._local_error()
            state["err"] = err
            if err is not None and err > tol:
                return f"local error {err:.3g} > time.tolerance = {tol:g}"
            return None

        for k in range(1, n_out + 1):
            t_out = min(k * spacing, end)
            if t_out <= self.t + 1e-12 * max(1.0, abs(t_out)):
                continue  # written before the restart
            while self.t < t_out - 1e-12 * max(1.0, abs(t_out)):
                # what is left before the output in equal steps no longer than h: no
                # sliver, and no jump in the step (BDF2 weights the ratio of steps)
                left = t_out - self.t
                step = left / math.ceil(left / min(h, dt_max) - 1e-9)
                wall0 = _time.perf_counter()
                state["err"] = None
                ok, its, res, reason = self._attempt(
                    self.t + step, step, self.scheme, error_check=check
                )
                err = state["err"]
                if ok:
                    self.t += step
                    self.step = self.counts["steps"] = self.counts["steps"] + 1
                    self.completed = self.step
                    cuts_in_row = 0
                    if steps_log is not None:
                        steps_log.row([self.t, step, its, res, _time.perf_counter() - wall0])
                    for f in self.observers:
                        f(self)
                    grow = 2.0 if not err else min(2.0, max(0.2, 0.9 * (tol / err) ** exponent))
                    # a step that Newton found hard is not grown: beyond its few iterations
                    # a longer step costs more iterations than it saves steps
                    if its > NEWTON_GROWTH_LIMIT:
                        grow = min(grow, 1.0)
                    # nor one whose directors would turn past time.max_rotation
                    if self.scheme.has_velocity and self.last_turn > 0.0:
                        limit = self._turn_limit(self.scheme)
                        grow = min(grow, max(0.5, 0.9 * limit / self.last_turn))
                    # a step cut short to land on an output says nothing against h
                    clipped = step < h * (1 - 1e-9)
                    h = min(dt_max, max(dt_min, max(h, step * grow) if clipped else step * grow))
                    progress.update(
                        self.t,
                        self.step,
                        self.counts["newton_iterations"],
                        self.solver.snes.getFunctionNorm(),
                    )
                    if self.t < t_out - 1e-12 * max(1.0, abs(t_out)):
                        self._checkpoint_if_due(h)  # else after the output row below
                        self._stop_if_asked(logs)
                    continue
                if self.rejected:
                    self.counts["rejected_steps"] += 1
                    h = step * min(0.9, max(0.2, 0.9 * (tol / err) ** exponent))
                else:
                    cuts_in_row += 1
                    self.counts["dt_cuts"] += 1
                    if cuts_in_row > time_["max_cuts"]:
                        raise RunFailed(
                            f"step not resolved ({reason}, {its} Newton iterations, "
                            f"residual {res:.3e}) after {time_['max_cuts']} step "
                            f"halvings in a row (time.max_cuts), dt = {step:.3e}"
                            + self._unresolved_hint(),
                            self.t + step,
                            self.counts["steps"] + 1,
                        )
                    halvings = self._halvings()
                    h = step / 2**halvings
                    progress.log(
                        f"step {self.counts['steps'] + 1} at t = {self.t:.6g}: {reason} "
                        f"after {its} Newton iterations; dt to {h:.3e}"
                        + (f" ({halvings} halvings)" if halvings > 1 else "")
                    )
                if h < dt_min * (1 - 1e-12):
                    raise RunFailed(
                        f"step not resolved ({reason}) with dt = {step:.3e}: the next "
                        f"try would be below time.dt_min = {dt_min:g}",
                        self.t + step,
                        self.counts["steps"] + 1,
                    )
            self.t = t_out
            self._write_output(logs, self.t)
            self._checkpoint_if_due(h, last=k == n_out)
            if k < n_out:
                self._stop_if_asked(logs)

    def _time_error_summary(self) -> dict | None:
        """Largest and mean estimated local error of the steps, or None (no estimate)."""
        if not self.time_errors:
            return None
        e = np.array(self.time_errors)
        return {
            "max": float(e.max()),
            "mean": float(e.mean()),
            "steps": int(len(e)),
            "warning_above_mean": TIME_ERROR_WARNING,
        }

    def _warn_time_error(self, progress):
        """One line when the fixed steps' mean error estimate says dt is too long."""
        est = self._time_error_summary()
        if (
            est is not None
            and self.scene["time"].get("tolerance") is None
            and est["mean"] > TIME_ERROR_WARNING
        ):
            progress.warn(
                f"warning: time.dt = {self.scene['time']['dt']:g} may be too long: the "
                f"steps' estimated local error is {est['mean']:.2g} on average (max "
                f"{est['max']:.2g}) of the body's size, above {TIME_ERROR_WARNING:g}; "
                "see summary.json time_error"
            )
