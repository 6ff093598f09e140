"""Running a scene: the time loop of docs/model.md §6 with its outputs.

The run starts at rest in static equilibrium with the loads and motions at
t = 0 (for the usual ramps that start at zero this is the reference state), so
the consistent initial acceleration is zero.  Each nominal step ``dt`` is then
advanced by Newton solves; when SNES fails, the step is restored, halved and
retried (at most ``time.max_cuts`` halvings), and after two good sub-steps the
sub-step is doubled again until the nominal step is complete.  In time (not in
static load steps) a converged step that turns some director by more than
``time.max_rotation`` is cut the same way: it has not resolved the motion.  A
magnetized end that flips over does so within ~1e-4 s, far faster than the
field turns, and steps that jump across such a flip left the strip in states
from which no step size converged.  Every cut is
logged and counted.  Outputs are rows per nominal step (every
``time.output_every`` steps), so they do not depend on cuts.
"""

from __future__ import annotations

import logging
import math
import time as _time
from pathlib import Path

import numpy as np
from mpi4py import MPI

from . import __version__, checkpoint, compat, impulses, petsc_options
from .errors import RunFailed, RunInterrupted, SceneError
from .interrupts import NoStops, StopRequests
from .model import Model
from .output import (BodyLog, CsvLog, FieldWriter, Probes, Progress, field_segments,
                     keep_fields_until, keep_rows_until, merge_field_segment, render_in_child,
                     write_json)
from .solver import StepSolver
from .timeint import BackwardEuler, Static, make_scheme


#: error-controlled steps: a step that took more Newton iterations than this is not
#: followed by a longer one (docs/model.md §6.9)
NEWTON_GROWTH_LIMIT = 8
#: static load steps: the most a sub-step should turn a director (rad).  A converged
#: load step that turned one further is followed by halved sub-steps, and a cut
#: sub-step is doubled again only while the doubled one would stay within it; in time
#: ``time.max_rotation`` plays this part.  (Newton took 5 updates for load steps
#: turning the roll-up's tip 0.4 rad, 6 to 10 for 0.8 rad on a curled strip, 7 or 8
#: for 1.6 rad, and often failed from 1.6 rad on.)
STATIC_TURN = 0.5
#: the most halvings one failed attempt makes at once (docs/model.md §6.8)
MOST_HALVINGS = 3
#: fixed steps in time: a mean estimated local error (§6.9's estimate, relative to the
#: body's size) above this is reported as a step too long (docs/model.md §6.11)
TIME_ERROR_WARNING = 1e-3


def build_model(scene: dict, comm, compile_forms: bool = True,
                tangent: str | None = None) -> Model:
    """The scene's body (its hinge lines cut into strip meshes) and its Model, with
    the Newton tangent ``tangent`` (default: the scene's ``solver.tangent``)."""
    from rftfem.meshes import build_body

    scene_dir = Path(scene.get("_path", ".")).parent
    lines = [h["where"] for h in scene.get("hinge") or []]
    body = build_body(comm, scene["mesh"], scene_dir, hinges=lines)
    if tangent is None:
        tangent = petsc_options.tangent(scene.get("solver"))
    return Model(scene, body, compile_forms=compile_forms, tangent=tangent)


def check(scene: dict, comm=None) -> list[str]:
    """Validate what needs the mesh (selectors, regions, probes); return the active effects."""
    comm = comm or MPI.COMM_WORLD
    model = build_model(scene, comm, compile_forms=False)
    Probes(model, scene.get("output", {}).get("probes", []))
    return model.active_effects()


def _make_out_dir(out: Path | None, comm):
    """Make the output folder on rank 0; a path that cannot be one is a usage error
    on every rank."""
    if out is None:
        return
    error = None
    if comm.rank == 0:
        try:
            out.mkdir(parents=True, exist_ok=True)
        except FileExistsError:
            error = f"--out {out}: expected a folder (or a path where one can be made), found a file"
        except OSError as exc:
            error = f"--out {out}: cannot make this folder ({exc.strerror or exc})"
    error = comm.bcast(error, root=0)
    if error:
        raise SceneError(error)


class Simulation:
    """One run of a scene; ``observers`` are called as ``f(sim)`` after every step.
    With ``signals``, SIGINT and SIGTERM stop the run after its step (interrupts.py);
    with ``restart`` (a results folder), the run goes on from its last checkpoint
    and appends to its outputs (checkpoint.py)."""

    def __init__(self, scene: dict, out_dir: Path | None = None, quiet: bool = False,
                 petsc_args: list[str] | None = None, comm=None, observers=(),
                 signals: bool = False, restart: Path | None = None):
        self.scene = scene
        self.comm = comm or MPI.COMM_WORLD
        self.stops = StopRequests(self.comm) if signals else NoStops()
        if restart is not None and out_dir is not None and Path(out_dir) != Path(restart):
            raise SceneError(f"--out {out_dir}: a restart appends to the folder it continues "
                             f"({restart}); leave --out out or give that folder")
        self.out_dir = Path(restart if restart is not None else out_dir) \
            if (restart or out_dir) is not None else None
        #: (checkpoint folder, its meta) a restart goes on from, checked before the set-up
        self.resume = self._checked_checkpoint(restart) if restart is not None else None
        _make_out_dir(self.out_dir, self.comm)  # before the costly set-up: fail early
        self.quiet = quiet
        self.observers = list(observers)
        _quiet_compilers()
        t0 = _time.perf_counter()
        self.model = build_model(scene, self.comm,
                                 tangent=petsc_options.tangent(scene.get("solver"), petsc_args))
        self.probes = Probes(self.model, scene.get("output", {}).get("probes", []))
        self.scheme = make_scheme(scene["time"])
        # time steps start Newton's tangent on the converged stress resultants; static
        # load steps on their start's own (docs/model.md §7.4)
        self.model.first_tangent_converged = self.scheme.has_velocity
        self.options = petsc_options.merged(self.model.reference_force(), scene.get("solver"),
                                            petsc_args)
        self.solver = StepSolver(self.model, self.options)
        self.setup_time = _time.perf_counter() - t0
        self.t = 0.0
        self.step = 0
        self.completed = 0  # steps done (self.step may be the one under way)
        self.counts = {"steps": 0, "newton_iterations": 0, "dt_cuts": 0, "rejected_steps": 0}
        #: halvings of the nominal step the next one starts with (_advance)
        self.level = 0
        #: the largest rotation increment of the last converged step, and how many times
        #: too long the last failed attempt was (None where it does not show)
        self.last_turn, self.overreach = 0.0, None
        #: wall seconds outside the solver: outputs, loads and motions set for a step
        #: (set_time), the state and triad update after it (accept)
        self.wall = {"output": 0.0, "loads": 0.0, "update": 0.0, "checkpoint": 0.0}
        self.history = []  # (t, probe values) rows, as written to probes.csv
        #: each step's estimated local error (§6.9) in a run in time with fixed steps
        self.time_errors = []
        self.model.keep_predictions = self.scheme.has_velocity
        self.wall_before = 0.0  # wall seconds of the run's earlier parts (restarts)
        self.restarts = []
        if self.resume is not None:
            self._load_checkpoint()

    # --- checkpoints and restart (checkpoint.py) ---------------------------------

    def _checked_checkpoint(self, folder: Path):
        """The last checkpoint of ``folder``, if this scene may go on from it."""
        path, meta = checkpoint.latest(folder, self.comm)
        differs = checkpoint.scene_difference(meta["scene"], self.scene)
        if differs:
            raise SceneError(f"--restart {folder}: the scene differs from the checkpointed one "
                             f"at {differs}")
        if meta["time"] >= self.scene["time"]["end"] * (1 - 1e-12):
            raise SceneError(f"--restart {folder}: the checkpoint is at t = {meta['time']:.6g}, "
                             f"not before time.end = {self.scene['time']['end']:g}; raise "
                             "time.end to go on")
        return path, meta

    def _load_checkpoint(self):
        path, meta = self.resume
        arrays = checkpoint.read_arrays(path, self.comm, self._mesh_digest(), meta)
        self.model.set_state(arrays, meta["increment_steps"])
        self.solver.F_n.array[:] = arrays["forces"]
        if hasattr(self.scheme, "dt_prev"):
            self.scheme.dt_prev = meta["last_step"]
        self.t, self.completed = meta["time"], meta["step"]
        self.level, self.last_turn = meta.get("substep_level", 0), meta.get("last_turn", 0.0)
        self.step = self.completed
        self.counts.update(meta["counts"])
        self.wall_before = meta["wall_s"]
        self.restarts = meta.get("restarts", []) + [{"time": self.t, "step": self.completed,
                                                      "checkpoint": path.name}]

    def _mesh_digest(self) -> str:
        """This process's mesh digest (checkpoint.py), computed once: the mesh never moves."""
        if not hasattr(self, "_digest"):
            self._digest = checkpoint.mesh_digest(self.model)
        return self._digest

    def _checkpoint_if_due(self, next_step: float | None = None, last: bool = False):
        """After a step: a checkpoint every ``output.checkpoint_every`` steps, and after
        the ``last`` (a finished run can be taken further: a larger time.end)."""
        every = self.scene["output"].get("checkpoint_every", 0)
        if not every or self.out_dir is None or (self.completed % every and not last):
            return
        t0 = _time.perf_counter()
        arrays, increment_steps = self.model.state()
        arrays["forces"] = self.solver.F_n.array.copy()
        meta = {"time": self.t, "step": self.completed, "counts": dict(self.counts),
                "increment_steps": increment_steps,
                "last_step": getattr(self.scheme, "dt_prev", None), "next_step": next_step,
                "substep_level": self.level, "last_turn": self.last_turn,
                "wall_s": self.wall_before + _time.perf_counter() - self._wall_start
                + self.setup_time,
                "restarts": self.restarts,
                # a row at this time is an output row (else one an interrupt or a
                # failure writes after it, which a restart drops)
                "output_row": bool(self.history) and self.history[-1][0] == self.t,
                "scene": {k: v for k, v in self.scene.items() if not k.startswith("_")},
                "mesh_digest": self._mesh_digest()}
        checkpoint.write(self.out_dir, self.completed, arrays, meta, self.comm)
        self.wall["checkpoint"] += _time.perf_counter() - t0

    # --- one step ---------------------------------------------------------------

    def _attempt(self, t_new: float, dt: float, scheme, limit_rotation: bool = True,
                 error_check=None):
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
        ok, its, res, reason = self.solver.solve()
        if self.stops.immediate:
            # a second signal inside a residual or Jacobian: PETSc turned it into a failed
            # solve (and may have left a vector locked); stop, do not cut
            raise RunInterrupted(self.stops.signum, immediate=True)
        if ok and not math.isfinite(res):
            ok, reason = False, "non-finite residual"
        limit = self._turn_limit(scheme)
        #: how many times too long a failed attempt was, where it shows (None: unknown)
        self.overreach = None
        if ok:
            # the solver measured it at every update, the converged iterate's last
            turns = self.solver.turns
            self.last_turn = turns[-1] if turns else m.largest_rotation_increment()
        elif self.solver.divergence is not None and self.solver.turns:
            # the first update's turn is the linearized one: it says how far the
            # step reached beyond what Newton can take
            self.overreach = self.solver.turns[0] / limit
        if ok and limit_rotation and scheme.has_velocity and self.last_turn > limit:
            ok, reason = False, (f"a director turned {self.last_turn:.3g} rad > "
                                 f"time.max_rotation = {limit:g}")
            self.overreach = self.last_turn / limit
        self.rejected = False
        if ok and error_check is not None:
            too_big = error_check()
            if too_big:
                ok, reason, self.rejected = False, too_big, True
        self.counts["newton_iterations"] += its
        if not ok:
            m.restore()
            return False, its, res, reason
        if m.keep_predictions:  # the step's error estimate (§6.9), for summary.json
            err = self._local_error()
            if err is not None:
                self.time_errors.append(err)
        self.solver.store_forces()
        t0 = _time.perf_counter()
        m.accept(scheme, dt, t_new)
        if m.drive and scheme.has_inertia:
            impulses.corner(m, self.solver, t_new)
        self.wall["update"] += _time.perf_counter() - t0
        return True, its, res, reason

    def _turn_limit(self, scheme) -> float:
        """The turn of a director a step should stay within: ``time.max_rotation`` in
        time, ``STATIC_TURN`` in static load steps."""
        return self.scene["time"]["max_rotation"] if scheme.has_velocity else STATIC_TURN

    def _halvings(self) -> int:
        """How many times to halve after the failed attempt: once, or as many times as
        its overreach asks (a turn 5 times too large: 3), at most ``MOST_HALVINGS``."""
        if self.overreach is None or self.overreach <= 2.0:
            return 1
        return min(MOST_HALVINGS, math.ceil(math.log2(self.overreach)))

    def _may_double(self, scheme) -> bool:
        """Whether a cut sub-step may be doubled: the doubled one would turn the
        directors by no more than 0.9 of the scheme's turn limit."""
        return 2.0 * self.last_turn <= 0.9 * self._turn_limit(scheme)

    def _free(self) -> bool:
        """No support, no prescribed motion and no drag hold the body's rigid motions."""
        return not (self.scene["boundary"] or self.scene["motion"] or self.model.get("drag"))

    def _unresolved_hint(self) -> str:
        """What to change when a step is not resolved and nothing holds the body: without
        mass either its stiffness is singular for every step size."""
        if self._free() and self.model.inertia_form is None:
            return ("; nothing holds this body: without a [[boundary]], a [[motion]], a "
                    "[fluid] or mass its rigid motions are free and every step is singular")
        return ""

    def _initial_equilibrium(self):
        """Equilibrium with the t = 0 loads and motions; the run then starts at rest.

        With drag the body may be free (no Dirichlet condition on its rigid
        motions), and a static solve would be singular.  The t = 0 solve then
        carries the drag of reaching that state from the reference in one step
        ``dt`` (backward Euler): a viscous regularisation that leaves the body
        where the fluid lets it go.  Either way the run starts at rest
        (``v = a = 0``), and the forces kept for the first step are those at rest.
        """
        m, dt = self.model, self.scene["time"]["dt"]
        start = BackwardEuler() if m.get("drag") else Static()
        # no prediction here to correct: a state that meets the tolerance (the
        # reference state under loads that start at zero) is the answer
        self.solver.force_iteration(False)
        try:
            ok, its, res, reason = self._attempt(0.0, dt, start, limit_rotation=False)
        finally:
            self.solver.force_iteration()
        if not ok:
            hint = ("; nothing holds this body, so the loads must start at zero (a ramp "
                    "from 0) unless a [fluid] holds it" if self._free() else "")
            raise RunFailed(f"no static equilibrium with the t = 0 loads and motions ({reason})"
                            + hint, 0.0, 0)
        m.v_n.x.array[:] = 0.0
        m.a_n.x.array[:] = 0.0
        m.increments = []  # reaching t = 0 is no rate to go on at
        if m.drive and self.scheme.has_inertia:
            # the driven dofs move off at the motion's own rate, the body with them
            m.set_coefficients(self.scheme.coefficients(dt))
            impulses.corner(m, self.solver, 0.0, start=True)
        m.set_coefficients(Static().coefficients(dt))
        self.solver.store_forces()

    def _advance(self, t_end: float, steps_log, progress):
        """Advance from ``self.t`` to ``t_end`` (one nominal step), cutting as needed.

        The sub-step starts where the last nominal step left it (``self.level``
        halvings), so a nominal step too long for Newton is not tried whole again
        at every step; after two good sub-steps it is doubled, if the doubled one
        would not turn the directors too far (``_may_double``)."""
        max_cuts = self.scene["time"]["max_cuts"]
        level = min(self.level, max_cuts)
        dt = (t_end - self.t) / 2**level
        good = 0
        while self.t < t_end - 1e-12 * max(1.0, abs(t_end)):
            dt = min(dt, t_end - self.t)
            wall0 = _time.perf_counter()
            ok, its, res, reason = self._attempt(self.t + dt, dt, self.scheme)
            if ok:
                self.t += dt
                self.counts["steps"] += 1
                if steps_log is not None:
                    steps_log.row([self.t, dt, its, res, _time.perf_counter() - wall0])
                for f in self.observers:
                    f(self)
                good += 1
                if not self.scheme.has_velocity and self.last_turn > STATIC_TURN \
                        and level < max_cuts:
                    # a load step that turned too far: the next ones shorter (no failure)
                    halvings = min(MOST_HALVINGS, max_cuts - level,
                                   math.ceil(math.log2(self.last_turn / STATIC_TURN)))
                    dt, level, good = dt / 2**halvings, level + halvings, 0
                elif level > 0 and good >= 2 and self._may_double(self.scheme):
                    dt, level, good = 2 * dt, level - 1, 0
                continue
            if level >= max_cuts:
                raise RunFailed(f"step not resolved ({reason}, {its} Newton iterations, residual "
                                f"{res:.3e}) after {max_cuts} step halvings (time.max_cuts), "
                                f"dt = {dt:.3e}" + self._unresolved_hint(),
                                self.t + dt, self.step)
            halvings = min(self._halvings(), max_cuts - level)
            self.counts["dt_cuts"] += 1
            level, good = level + halvings, 0
            dt /= 2**halvings
            progress.log(f"step {self.step} at t = {self.t:.6g}: {reason} after {its} Newton "
                         f"iterations; dt to {dt:.3e}" + (f" ({halvings} halvings)"
                                                          if halvings > 1 else ""))
        self.level = level
        self.t = t_end  # exact nominal time, free of round-off from the sub-steps

    def _time_error_summary(self) -> dict | None:
        """Largest and mean estimated local error of the steps, or None (no estimate)."""
        if not self.time_errors:
            return None
        e = np.array(self.time_errors)
        return {"max": float(e.max()), "mean": float(e.mean()), "steps": int(len(e)),
                "warning_above_mean": TIME_ERROR_WARNING}

    # --- error-controlled steps (time.tolerance) ----------------------------------

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
                ok, its, res, reason = self._attempt(self.t + step, step, self.scheme,
                                                     error_check=check)
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
                    progress.update(self.t, self.step, self.counts["newton_iterations"],
                                    self.solver.snes.getFunctionNorm())
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
                        raise RunFailed(f"step not resolved ({reason}, {its} Newton iterations, "
                                        f"residual {res:.3e}) after {time_['max_cuts']} step "
                                        f"halvings in a row (time.max_cuts), dt = {step:.3e}"
                                        + self._unresolved_hint(),
                                        self.t + step, self.counts["steps"] + 1)
                    halvings = self._halvings()
                    h = step / 2**halvings
                    progress.log(f"step {self.counts['steps'] + 1} at t = {self.t:.6g}: {reason} "
                                 f"after {its} Newton iterations; dt to {h:.3e}"
                                 + (f" ({halvings} halvings)" if halvings > 1 else ""))
                if h < dt_min * (1 - 1e-12):
                    raise RunFailed(f"step not resolved ({reason}) with dt = {step:.3e}: the next "
                                    f"try would be below time.dt_min = {dt_min:g}",
                                    self.t + step, self.counts["steps"] + 1)
            self.t = t_out
            self._write_output(logs, self.t)
            self._checkpoint_if_due(h, last=k == n_out)
            if k < n_out:
                self._stop_if_asked(logs)

    # --- the run -------------------------------------------------------------

    def run(self) -> dict:
        with self.stops:
            return self._run()

    def _last_row(self, logs: dict):
        """An output row at the last converged state, unless its time has one (a run
        that stops between output times keeps where it got to)."""
        if self.history and self.history[-1][0] != self.t:
            self._write_output(logs, self.t)

    def _stop_if_asked(self, logs: dict):
        """After a step: if a signal asked any rank to stop, write a last output row
        and stop (interrupts.py)."""
        signum = self.stops.requested()
        if signum:
            self._last_row(logs)
            raise RunInterrupted(signum, self.t, self.step)

    def _run(self) -> dict:
        scene, comm = self.scene, self.comm
        time_ = scene["time"]
        out = self.out_dir
        summary = self._summary("running")
        wall_start = self._wall_start = _time.perf_counter()
        progress = Progress(time_["end"], comm, self.quiet)
        progress.log(f"rftfem {__version__}: {scene['title']} — effects: "
                     f"{', '.join(self.model.active_effects())}; scheme {self.scheme.name}; "
                     f"{self.model.W.dofmap.index_map.size_global * self.model.W.dofmap.index_map_bs}"
                     f" dofs on {comm.size} process(es)")
        logs = self._open_outputs()
        try:
            if self.resume is None:
                self._initial_equilibrium()
                self._write_output(logs, 0.0)
            else:
                progress.log(f"restarted at t = {self.t:.6g} (step {self.completed}) from "
                             f"{self.resume[0]}")
            n_steps = max(1, math.ceil(time_["end"] / time_["dt"] - 1e-9))
            if time_.get("tolerance") is not None:
                self._run_adaptive(logs, progress)
                n_steps = 0
            for self.step in range(self.completed + 1, n_steps + 1):
                self._advance(min(self.step * time_["dt"], time_["end"]), logs.get("steps"),
                              progress)
                if self.step % time_["output_every"] == 0 or self.step == n_steps:
                    self._write_output(logs, self.t)
                progress.update(self.t, self.step, self.counts["newton_iterations"],
                                self.solver.snes.getFunctionNorm())
                self.completed = self.step
                self._checkpoint_if_due(last=self.step == n_steps)
                if self.step < n_steps:
                    self._stop_if_asked(logs)
            summary = self._summary("ok", wall_start)
            self._warn_time_error(progress)
        except RunFailed as err:
            self._last_row(logs)
            summary = self._summary("failed", wall_start)
            summary["failure"] = {"time": err.time, "step": err.step, "reason": err.reason}
            raise
        except BaseException as exc:
            if not (isinstance(exc, RunInterrupted) or self.stops.immediate):
                raise
            # a second signal may surface inside a PETSc callback as another error
            err = exc if isinstance(exc, RunInterrupted) else RunInterrupted(
                self.stops.signum, immediate=True)
            if err.time is None:  # stopped inside a step: where the last one ended
                err.time, err.step = self.t, self.completed
            summary = self._summary("interrupted", wall_start)
            summary["interrupt"] = {"signal": err.signal_name, "time": err.time,
                                    "step": err.step, "immediate": err.immediate}
            raise err from None
        finally:
            self.stops.closing()
            progress.close()
            for log in logs.values():
                log.close()
            if out is not None:
                write_json(out / "summary.json", summary, comm)
                render = scene.get("output", {}).get("render", "none")
                if render != "none" and "fields" in logs:
                    render_in_child(out, render, comm, progress)
        c = self.counts
        progress.final(f"done: {c['steps']} steps, {c['newton_iterations']} Newton iterations, "
                     f"{c['dt_cuts']} dt cuts"
                     + (f", {c['rejected_steps']} steps rejected by the error control"
                        if c["rejected_steps"] else "")
                     + f", {summary['wall_s']['total']:.1f} s"
                     + (f"; outputs in {out}" if out is not None else ""))
        return summary

    def _open_outputs(self) -> dict:
        logs = {}
        if self.out_dir is None:
            return logs
        out, again = self.out_dir, self.resume is not None
        fields = self.scene.get("output", {}).get("fields", True)
        segment = None
        if again:
            segment = self._continue_outputs(fields)
        logs["probes"] = CsvLog(out / "probes.csv", ["time", *self.probes.header()],
                                self.comm, append=again)
        logs["steps"] = CsvLog(out / "steps.csv",
                               ["time", "dt", "newton_its", "residual", "wall_s"], self.comm,
                               append=again)
        self.body = BodyLog(self.model)
        logs["body"] = CsvLog(out / "body.csv", ["time", *self.body.header()], self.comm,
                              append=again)
        if fields:
            extra = {name: f for comp in self.model.components
                     for name, f in comp.fields().items()}
            main = out / "fields.xdmf"
            logs["fields"] = (FieldWriter(self.model, segment, extra, main=main) if again
                              else FieldWriter(self.model, main, extra))
        return logs

    def _continue_outputs(self, fields: bool) -> Path | None:
        """A restart: the tables cut to the checkpoint's time (rows written after it
        go, they are written again), the probe rows kept as history, the field
        files of earlier restarts merged and cut the same way; returns the new
        segment's field file."""
        out, t = self.out_dir, self.t
        at_t = self.resume[1]["output_row"]
        rows, segment = None, None
        if self.comm.rank == 0:
            try:
                keep_rows_until(out / "steps.csv", t)
                keep_rows_until(out / "body.csv", t, at_t)
                rows = keep_rows_until(out / "probes.csv", t, at_t)
                if fields:
                    main = out / "fields.xdmf"
                    done = field_segments(main)
                    for earlier in done:
                        merge_field_segment(main, earlier)
                    keep_fields_until(main, t, at_t)
                    number = int(done[-1].stem.rsplit("-", 1)[1]) + 1 if done else 1
                    segment = str(out / f"fields-{number}.xdmf")
            except (OSError, ValueError) as exc:
                rows = f"--restart {out}: cannot continue its outputs ({exc})"
        rows, segment = self.comm.bcast((rows, segment), root=0)
        if isinstance(rows, str):
            raise SceneError(rows)
        n = len(self.probes.names)
        self.history = [(float(r[0]), np.array([float(v) for v in r[1:]]).reshape(n, 3))
                        for r in rows]
        return Path(segment) if segment else None

    def _write_output(self, logs: dict, t: float):
        t0 = _time.perf_counter()
        values = self.probes.values()
        self.history.append((t, values))
        if "probes" in logs:
            logs["probes"].row([t, *values.ravel()])
        if "body" in logs:
            logs["body"].row([t, *self.body.values(t)])
        if "fields" in logs:
            logs["fields"].write(t)
        self.wall["output"] += _time.perf_counter() - t0

    def _warn_time_error(self, progress):
        """One line when the fixed steps' mean error estimate says dt is too long."""
        est = self._time_error_summary()
        if est is not None and self.scene["time"].get("tolerance") is None \
                and est["mean"] > TIME_ERROR_WARNING:
            progress.warn(f"warning: time.dt = {self.scene['time']['dt']:g} may be too long: the "
                          f"steps' estimated local error is {est['mean']:.2g} on average (max "
                          f"{est['max']:.2g}) of the body's size, above {TIME_ERROR_WARNING:g}; "
                          "see summary.json time_error")

    def _summary(self, status: str, wall_start: float | None = None) -> dict:
        scene = {k: v for k, v in self.scene.items() if not k.startswith("_")}
        total = ((_time.perf_counter() - wall_start if wall_start else 0.0) + self.setup_time
                 + self.wall_before)
        timings = self.solver.timings
        return {
            "status": status,
            "scene": scene,
            "scene_file": self.scene.get("_path"),
            "overrides": list(self.scene.get("_overrides", [])),
            "active_effects": self.model.active_effects(),
            "scheme": self.scheme.name,
            "versions": {"rftfem": __version__, **compat.versions()},
            "mpi_size": self.comm.size,
            "dofs": self.model.W.dofmap.index_map.size_global * self.model.W.dofmap.index_map_bs,
            "time_reached": self.t,
            "counts": dict(self.counts),
            **({"restarts": self.restarts} if self.restarts else {}),
            "director_unit_error": self.model.director_unit_error(),
            **({"time_error": self._time_error_summary()} if self.time_errors else {}),
            "wall_s": {"compile": self.model.timings["compile"], "assembly": self.solver.assembly_time,
                       "solve": timings["solve"], "output": self.wall["output"],
                       "checkpoint": self.wall["checkpoint"], "total": total},
        }

    def close(self):
        self.solver.destroy()
        self.model.destroy()


def run(scene: dict, out_dir: Path | None = None, quiet: bool = False,
        petsc_args: list[str] | None = None, comm=None, observers=(),
        signals: bool = False, restart: Path | None = None) -> dict:
    """Run a validated scene; write outputs to ``out_dir``; return the summary.  With
    ``signals`` (the command line), SIGINT/SIGTERM stop it cleanly (interrupts.py);
    with ``restart``, go on from the last checkpoint in that folder (checkpoint.py)."""
    sim = Simulation(scene, out_dir, quiet, petsc_args, comm, observers, signals, restart)
    try:
        return sim.run()
    finally:
        sim.close()


def probe_history(summary_or_sim) -> np.ndarray:
    """(n_rows, 1 + 3 n_probes) array of the probe rows of a finished simulation."""
    rows = summary_or_sim.history
    return np.array([[t, *v.ravel()] for t, v in rows])


class _CompilerChatter(logging.Filter):
    """Drops the INFO lines (gcc command lines) that distutils/setuptools log on the
    root logger while cffi builds a JIT module; their build also resets the root
    level, so a level alone does not keep them quiet."""

    def filter(self, record):
        where = record.pathname.replace("\\", "/")
        return record.levelno >= logging.WARNING or not any(
            part in where for part in ("/distutils/", "/setuptools/", "/cffi/"))


def _quiet_compilers():
    """FFCx/cffi log every compilation at INFO on some stacks: keep the terminal readable."""
    for name in ("", "ffcx", "UFL", "cffi", "dolfinx"):
        logger = logging.getLogger(name)
        if logger.level == logging.NOTSET or logger.level < logging.WARNING:
            logger.setLevel(logging.WARNING)
    root = logging.getLogger()
    if not any(isinstance(f, _CompilerChatter) for f in root.filters):
        root.addFilter(_CompilerChatter())
