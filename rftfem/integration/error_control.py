"""Error-controlled steps and the time-error indicator (docs/model.md §6.9, §6.11):
each converged step's local error estimated from its distance to a prediction,
steps chosen by it under ``time.tolerance``, and with fixed steps the same estimate
kept for summary.json without acting on it.
"""

from __future__ import annotations

import math
import time as _time
from typing import TYPE_CHECKING

import numpy as np

from rftfem.errors import RunFailed

if TYPE_CHECKING:
    from rftfem.integration.run_state import RunHooks, RunPosition
    from rftfem.integration.schemes import Scheme
    from rftfem.integration.step_control import StepController
    from rftfem.model.shell_model import Model
    from rftfem.outputs.progress import Progress

#: error-controlled steps: a step that took more Newton iterations than this is not
#: followed by a longer one (docs/model.md §6.9)
NEWTON_GROWTH_LIMIT = 8
#: fixed steps in time: a mean estimated local error (§6.9's estimate, relative to the
#: body's size) above this is reported as a step too long (docs/model.md §6.11)
TIME_ERROR_WARNING = 1e-3


class ErrorControl:
    """The local error of each converged step (``time_errors``, for summary.json) and
    the steps chosen by it under ``time.tolerance`` (``run``)."""

    def __init__(self, model: Model, scheme: Scheme, time_: dict):
        self.model, self.scheme, self.time_ = model, scheme, time_
        #: each step's estimated local error (§6.9)
        self.time_errors: list[float] = []

    def local_error(self) -> float | None:
        """The converged step's estimated local error relative to ``time.tolerance``'s
        units: ``f · max(|u − u^P| / size, |θ − θ^P|)`` (docs/model.md §6.9), or None
        without a prediction (the first step)."""
        e = self.model.prediction_error(self.scheme.error_predictor)
        if e is None:
            return None
        eu, eth = e
        return self.scheme.error_fraction * max(eu / self.model.size(), eth)

    def record(self) -> None:
        """Keep the converged step's estimated local error, if it has one."""
        err = self.local_error()
        if err is not None:
            self.time_errors.append(err)

    def run(
        self, pos: RunPosition, steps: StepController, hooks: RunHooks, first_step: float
    ) -> None:
        """From ``pos.t`` to the end with steps chosen by the local error, the first
        ``first_step`` long: accepted when ``err ≤ tol``, the next one ``h (0.9
        tol/err)^(1/(p+1))`` within [⅕, 2] h and [dt_min, dt_max]; a rejected step is
        retried at that size (counted in ``rejected_steps``), a Newton failure or a
        too-large turn at half (``dt_cuts``).  Steps are clipped to land on every
        output time (``output_every`` × ``dt``)."""
        time_, end = self.time_, self.time_["end"]
        self.model.keep_predictions = True
        spacing = time_["dt"] * time_["output_every"]
        h, n_out = first_step, max(1, math.ceil(end / spacing - 1e-9))
        for k in range(1, n_out + 1):
            t_out = min(k * spacing, end)
            if t_out <= pos.t + 1e-12 * max(1.0, abs(t_out)):
                continue  # written before the restart
            h = self._steps_to(t_out, h, pos, steps, hooks)
            pos.t = t_out
            hooks.output(pos.t)
            hooks.checkpoint(h, last=k == n_out)
            if k < n_out:
                hooks.stop_if_asked()

    def _steps_to(
        self, t_out: float, h: float, pos: RunPosition, steps: StepController, hooks: RunHooks
    ) -> float:
        """Steps from ``pos.t`` to the output time ``t_out``, the first no longer than
        ``h``; returns the next step's length.  Cuts in a row are counted from 0: every
        interval starts after an accepted step."""
        time_, counts, progress = self.time_, pos.counts, hooks.progress
        tol, dt_min, dt_max = time_["tolerance"], time_["dt_min"], time_["dt_max"]
        exponent = 1.0 / (self.scheme.order + 1)
        cuts_in_row = 0
        while pos.t < t_out - 1e-12 * max(1.0, abs(t_out)):
            # what is left before the output in equal steps no longer than h: no
            # sliver, and no jump in the step (BDF2 weights the ratio of steps)
            left = t_out - pos.t
            step = left / math.ceil(left / min(h, dt_max) - 1e-9)
            wall0 = _time.perf_counter()
            ok, its, res, reason, err = self._attempt(pos, steps, step)
            if ok:
                cuts_in_row = 0
                h = self._accepted(pos, steps, hooks, step, h, its, res, err, wall0)
                if pos.t < t_out - 1e-12 * max(1.0, abs(t_out)):
                    hooks.checkpoint(h)  # else after the output time's row (run)
                    hooks.stop_if_asked()
                continue
            if steps.state.rejected:
                counts["rejected_steps"] += 1
                h = step * min(0.9, max(0.2, 0.9 * (tol / err) ** exponent))
            else:
                cuts_in_row += 1
                h = self._cut(pos, steps, progress, step, cuts_in_row, its, res, reason)
            if h < dt_min * (1 - 1e-12):
                raise RunFailed(
                    f"step not resolved ({reason}) with dt = {step:.3e}: the next "
                    f"try would be below time.dt_min = {dt_min:g}",
                    pos.t + step,
                    counts["steps"] + 1,
                )
        return h

    def _attempt(
        self, pos: RunPosition, steps: StepController, step: float
    ) -> tuple[bool, int, float, str, float | None]:
        """One attempt of ``step`` from ``pos.t``, rejected when its local error is over
        ``time.tolerance``: (converged, Newton iterations, residual, reason, local error
        or None)."""
        tol = self.time_["tolerance"]
        state: dict[str, float | None] = {"err": None}

        def check() -> str | None:
            err = self.local_error()
            state["err"] = err
            if err is not None and err > tol:
                return f"local error {err:.3g} > time.tolerance = {tol:g}"
            return None

        ok, its, res, reason = steps.attempt(
            pos, pos.t + step, step, self.scheme, error_check=check
        )
        return ok, its, res, reason, state["err"]

    def _accepted(
        self,
        pos: RunPosition,
        steps: StepController,
        hooks: RunHooks,
        step: float,
        h: float,
        its: int,
        res: float,
        err: float | None,
        wall0: float,
    ) -> float:
        """The accepted ``step`` (begun at wall time ``wall0``) counted, its row, the
        observers' and the components' look; returns the next step's length."""
        counts, progress = pos.counts, hooks.progress
        pos.t += step
        pos.step = counts["steps"] = counts["steps"] + 1
        pos.complete(pos.step)
        hooks.step_row([pos.t, step, its, res, _time.perf_counter() - wall0], pos.t)
        hooks.observe()
        steps.after_step(pos, progress)  # the components' look at the state
        h = self._next_length(steps, step, h, its, err)
        progress.update(
            pos.t,
            pos.step,
            counts["newton_iterations"],
            steps.solver.snes.getFunctionNorm(),
        )
        return h

    def _next_length(
        self, steps: StepController, step: float, h: float, its: int, err: float | None
    ) -> float:
        """The step after an accepted ``step`` of ``its`` Newton iterations and local
        error ``err``, ``h`` the length it was allowed."""
        time_, tol = self.time_, self.time_["tolerance"]
        exponent = 1.0 / (self.scheme.order + 1)
        grow = 2.0 if not err else min(2.0, max(0.2, 0.9 * (tol / err) ** exponent))
        # a step that Newton found hard is not grown: beyond its few iterations
        # a longer step costs more iterations than it saves steps
        if its > NEWTON_GROWTH_LIMIT:
            grow = min(grow, 1.0)
        # nor one whose directors would turn past time.max_rotation
        last_turn = steps.state.last_turn
        if self.scheme.has_velocity and last_turn > 0.0:
            limit = steps.turn_limit(self.scheme)
            grow = min(grow, max(0.5, 0.9 * limit / last_turn))
        # a step cut short to land on an output says nothing against h
        clipped = step < h * (1 - 1e-9)
        return min(
            time_["dt_max"],
            max(time_["dt_min"], max(h, step * grow) if clipped else step * grow),
        )

    def _cut(
        self,
        pos: RunPosition,
        steps: StepController,
        progress: Progress,
        step: float,
        cuts_in_row: int,
        its: int,
        res: float,
        reason: str,
    ) -> float:
        """After a failed attempt of ``step`` (the ``cuts_in_row``-th in a row): the
        cut counted and logged, or the run failed past ``time.max_cuts``; returns the
        shorter step."""
        time_, counts = self.time_, pos.counts
        counts["dt_cuts"] += 1
        if cuts_in_row > time_["max_cuts"]:
            raise RunFailed(
                f"step not resolved ({reason}, {its} Newton iterations, "
                f"residual {res:.3e}) after {time_['max_cuts']} step "
                f"halvings in a row (time.max_cuts), dt = {step:.3e}" + steps.unresolved_hint(),
                pos.t + step,
                counts["steps"] + 1,
            )
        halvings = steps.halvings()
        h = step / 2**halvings
        progress.log(
            f"step {counts['steps'] + 1} at t = {pos.t:.6g}: {reason} "
            f"after {its} Newton iterations; dt to {h:.3e}"
            + (f" ({halvings} halvings)" if halvings > 1 else "")
        )
        return h

    def summary(self) -> dict | None:
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

    def warn_if_too_long(self, progress: Progress) -> None:
        """One line when the fixed steps' mean error estimate says dt is too long."""
        est = self.summary()
        if (
            est is not None
            and self.time_.get("tolerance") is None
            and est["mean"] > TIME_ERROR_WARNING
        ):
            progress.warn(
                f"warning: time.dt = {self.time_['dt']:g} may be too long: the "
                f"steps' estimated local error is {est['mean']:.2g} on average (max "
                f"{est['max']:.2g}) of the body's size, above {TIME_ERROR_WARNING:g}; "
                "see summary.json time_error"
            )
