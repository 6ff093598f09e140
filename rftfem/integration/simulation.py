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

import contextlib
import math
import threading
import time as _time
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from mpi4py import MPI

from rftfem import petsc_options
from rftfem.errors import RunFailed, RunInterrupted, SceneError
from rftfem.integration.arclength import PathFollowing
from rftfem.integration.error_control import ErrorControl
from rftfem.integration.interrupts import NoStops, StopRequests
from rftfem.integration.model_setup import build_model, quiet_compilers
from rftfem.integration.restart import Restarts
from rftfem.integration.run_outputs import RunOutputs
from rftfem.integration.schemes import make_scheme
from rftfem.integration.solver import StepSolver
from rftfem.integration.steady import SteadyWatch
from rftfem.integration.step_control import StepControl
from rftfem.integration.step_watch import StepWatch
from rftfem.model.effects.base import NonlocalEffect
from rftfem.model.reactions import Reactions
from rftfem.outputs.progress import Progress, render_in_child
from rftfem.outputs.writers import BodyLog, Probes, write_json
from rftfem.scene import scales
from rftfem.scene.time_rules import scene_period as steady_period

if TYPE_CHECKING:
    from collections.abc import Callable, Iterable


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
            error = (
                f"--out {out}: expected a folder (or a path where one can be made), found a file"
            )
        except OSError as exc:
            error = f"--out {out}: cannot make this folder ({exc.strerror or exc})"
    error = comm.bcast(error, root=0)
    if error:
        raise SceneError(error)


class Simulation(StepControl, ErrorControl, PathFollowing, RunOutputs, Restarts):
    """One run of a scene; ``observers`` are called as ``f(sim)`` after every step.
    With ``signals``, SIGINT and SIGTERM stop the run after its step (interrupts.py);
    with ``restart`` (a results folder), the run goes on from its last checkpoint
    and appends to its outputs (checkpoint.py).

    The class is the run's state and its time loop; its parts are mixins, one
    module each: one step and its control (step_control.py), error-controlled steps and
    the time-error indicator (error_control.py), static path-following by arc
    length (arclength.py), outputs and the summary
    (run_outputs.py), checkpoints and restart (restart.py)."""

    def __init__(
        self,
        scene: dict,
        out_dir: Path | None = None,
        quiet: bool = False,
        petsc_args: list[str] | None = None,
        comm: MPI.Comm | None = None,
        observers: Iterable[Callable[[Simulation], object]] = (),
        signals: bool = False,
        restart: Path | None = None,
        warn: Callable[[str], object] | None = None,
    ):
        self.scene = scene
        #: a quiet run's warnings go here (a callable of the text) instead of stderr
        self.warn = warn
        self.comm = comm or MPI.COMM_WORLD
        self.stops = StopRequests(self.comm) if signals else NoStops()
        if restart is not None and out_dir is not None and Path(out_dir) != Path(restart):
            raise SceneError(
                f"--out {out_dir}: a restart appends to the folder it continues "
                f"({restart}); leave --out out or give that folder"
            )
        self.out_dir = (
            Path(restart if restart is not None else out_dir)
            if (restart or out_dir) is not None
            else None
        )
        #: (checkpoint folder, its meta) a restart goes on from, checked before the set-up
        self.resume = self._checked_checkpoint(restart) if restart is not None else None
        _make_out_dir(self.out_dir, self.comm)  # before the costly set-up: fail early
        self.quiet = quiet
        self.observers = list(observers)
        quiet_compilers()
        t0 = _time.perf_counter()
        with _compile_notice(quiet or self.comm.rank != 0):
            self.model = build_model(
                scene, self.comm, tangent=petsc_options.tangent(scene.get("solver"), petsc_args)
            )
        self.probes = Probes(self.model, scene.get("output", {}).get("probes", []))
        self.scheme = make_scheme(scene["time"])
        # time steps start Newton's tangent on the converged stress resultants; static
        # load steps on their start's own (docs/model.md §7.4)
        self.model.first_tangent_converged = self.scheme.has_velocity
        unknowns = self.model.W.dofmap.index_map.size_global * self.model.W.dofmap.index_map_bs
        solver = scene.get("solver")
        factorization = petsc_options.factorization(solver, petsc_args, unknowns)
        lu = petsc_options.lu_package(unknowns, self.comm.size)
        nonlocal_tangent = any(isinstance(c, NonlocalEffect) for c in self.model.components)
        self.options = petsc_options.merged(
            self.model.reference_force(), solver, petsc_args, factorization, lu, nonlocal_tangent
        )
        # rftfem's choice of PETSc's LU falls back on MUMPS; a user's is kept
        fallback = lu == "petsc" and not petsc_options.user_sets(
            "pc_factor_mat_solver_type", solver, petsc_args
        )
        self.solver = StepSolver(
            self.model, self.options, factorization, lu_fallback="mumps" if fallback else None
        )
        #: the named [[boundary]] and [[motion]] entries' reactions, set after each step
        self.reactions = Reactions(self.model)
        self.body = BodyLog(self.model, self.reactions)
        #: time.until = "periodic": the watch of the period means (steady.py) and the
        #: output rows (time, probes, body) it reads
        self.steady = None
        if scene["time"].get("until", "end") == "periodic":
            self.steady = SteadyWatch(
                steady_period(scene),
                scene["time"]["steady_tolerance"],
                self.probes.header() + self.body.header(),
            )
        self.rows = []
        self.setup_time = _time.perf_counter() - t0
        self.t = 0.0
        #: the load factor: the time the loads and motions are evaluated at (t itself,
        #: except in an arc-length run, whose t is the path's length)
        self.load_factor = 0.0
        self.last_residual = math.nan
        #: arc length (arclength.py): the next step's arc (None: the first, from Δλ =
        #: ``first_increment``, time.dt halved while it fails), the first arc, and the
        #: last step's displacement increment (the path's direction)
        self.arc = self.first_arc = self.path_direction = None
        self.first_increment = scene["time"]["dt"]
        self.step = 0
        self.completed = 0
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

    # --- the run -------------------------------------------------------------

    @property
    def completed(self) -> int:
        """Steps done (``self.step`` may be the one under way)."""
        return self._completed

    @completed.setter
    def completed(self, step: int) -> None:
        # the time they reached goes with them: a second signal may stop the run after
        # a step has moved ``self.t`` and before it counts as done
        self._completed, self.completed_time = step, self.t

    def run(self) -> dict:
        with self.stops:
            return self._run()

    def _stop_if_asked(self, logs: dict):
        """After a step: if a signal asked any rank to stop, write a last output row
        and stop (interrupts.py)."""
        signum = self.stops.requested()
        if signum:
            self._last_row(logs)
            raise RunInterrupted(signum, self.t, self.step)

    def _run(self) -> dict:
        time_, out = self.scene["time"], self.out_dir
        summary = self._summary("running")
        wall_start = self._wall_start = _time.perf_counter()
        path = self.scheme.name == "arc-length"
        progress = self._open_progress(path)
        logs = self._open_outputs()
        try:
            self._start(logs, progress)
            if path:
                self._run_arc_length(logs, progress)
            elif time_.get("tolerance") is not None:
                self._run_adaptive(logs, progress)
            else:
                self._run_fixed_steps(logs, progress)
            if self.steady is not None and not self.steady.result:
                self.steady.result = {"reached": False}
            if self.steady is not None and not self.steady.result["reached"]:
                progress.warn(
                    f'time.until = "periodic": not steady to '
                    f"{time_['steady_tolerance']:g} by time.end = {time_['end']:g}"
                )
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
            err, summary = self._interrupted(exc, logs, wall_start)
            raise err from None
        finally:
            self._close_run(logs, progress, summary)
        c = self.counts
        progress.final(
            f"done: {c['steps']} steps, {c['newton_iterations']} Newton iterations, "
            f"{c['dt_cuts']} dt cuts"
            + (
                f", {c['rejected_steps']} steps rejected "
                + ("for turning the path too far" if path else "by the error control")
                if c["rejected_steps"]
                else ""
            )
            + f", {summary['wall_s']['total']:.1f} s"
            + (f"; outputs in {out}" if out is not None else "")
        )
        return summary

    def _open_progress(self, path: bool) -> Progress:
        """The progress line, the watch of slow steps, the opening lines and warnings."""
        progress = Progress(
            self.scene["time"]["end"],
            self.comm,
            self.quiet,
            label="load factor" if path else "t",
            warn=self.warn,
        )
        self.progress_warn = progress.warn
        StepWatch(self.stops, self.comm, progress).attach(self.solver)
        for line in self._opening_lines():
            progress.log(line)
        for line in scales.aliasing_warnings(self.scene) + [
            line for comp in self.model.components for line in comp.warnings()
        ]:
            progress.warn("warning: " + line)
        return progress

    def _start(self, logs: dict, progress: Progress):
        """The state at t = 0 and its output row, or the checkpoint a restart goes on from."""
        if self.resume is not None:
            progress.log(
                f"restarted at t = {self.t:.6g} (step {self.completed}) from {self.resume[0]}"
            )
            return
        self._initial_equilibrium()
        compiled = self.model.timings["compile"]
        self._write_output(logs, 0.0)
        # the first row compiles the outputs' forms: that belongs to the set-up
        later = self.model.timings["compile"] - compiled
        self.setup_time += later
        self.wall["output"] -= later

    def _run_fixed_steps(self, logs: dict, progress: Progress):
        """Steps of time.dt to time.end (or to a steady period), a row every
        ``output_every`` steps, checkpoints, and a stop between steps if asked."""
        time_ = self.scene["time"]
        n_steps = max(1, math.ceil(time_["end"] / time_["dt"] - 1e-9))
        for self.step in range(self.completed + 1, n_steps + 1):
            self._advance(min(self.step * time_["dt"], time_["end"]), logs.get("steps"), progress)
            if self.step % time_["output_every"] == 0 or self.step == n_steps:
                self._write_output(logs, self.t)
            progress.update(
                self.t,
                self.step,
                self.counts["newton_iterations"],
                self.solver.snes.getFunctionNorm(),
            )
            self.completed = self.step
            steady = self._steady_after_step(progress)
            last = steady or self.step == n_steps
            self._checkpoint_if_due(last=last)
            if last:
                break
            self._stop_if_asked(logs)

    def _interrupted(self, exc: BaseException, logs: dict, wall_start: float):
        """The interrupt (a signal; a second one may surface inside a PETSc callback as
        another error) and the summary of a run it stopped."""
        err = (
            exc
            if isinstance(exc, RunInterrupted)
            else RunInterrupted(self.stops.signum, immediate=True)
        )
        if err.time is None:  # stopped inside a step: where the last one ended
            err.time, err.step = self.completed_time, self.completed
            self.t = err.time  # what the outputs reached (the state may be further)
        if err.dropped:  # a slow step dropped: the last completed step's row
            self._last_row(logs)
        summary = self._summary("interrupted", wall_start)
        summary["interrupt"] = {
            "signal": err.signal_name,
            "time": err.time,
            "step": err.step,
            "immediate": err.immediate,
            "dropped_step": err.dropped,
        }
        return err, summary

    def _close_run(self, logs: dict, progress: Progress, summary: dict):
        """Close the outputs and write summary.json, whatever ended the run; render."""
        self.stops.closing()
        progress.close()
        for log in logs.values():
            log.close()
        summary["warnings"] = list(progress.warnings)  # every warning the run said
        if self.out_dir is not None:
            write_json(self.out_dir / "summary.json", summary, self.comm)
            render = self.scene.get("output", {}).get("render", "none")
            if render != "none" and "fields" in logs:
                render_in_child(self.out_dir, render, self.comm, progress)

    def _steady_after_step(self, progress) -> bool:
        """At the end of a period (time.until = "periodic"): whether the run is steady."""
        watch = self.steady
        if watch is None:
            return False
        per_period = round(watch.period / self.scene["time"]["dt"])
        if self.step % per_period:
            return False
        start = self.t - watch.period * (1 + 1e-9)
        rows = np.array([r for r in self.rows if r[0] >= start])
        if len(rows) < 2:
            return False
        steady = watch.add_period(rows[:, 0], rows[:, 1:])
        if steady:
            progress.log(
                f"steady after {len(watch.means)} periods (t = {self.t:.6g}): "
                f"extrapolated values agree to {watch.tolerance:g}"
            )
        self.rows = [r for r in self.rows if r[0] >= self.t - watch.period * 1e-9]
        return steady

    def close(self) -> None:
        self.solver.destroy()
        self.model.destroy()


def run(
    scene: dict,
    out_dir: Path | None = None,
    quiet: bool = False,
    petsc_args: list[str] | None = None,
    comm: MPI.Comm | None = None,
    observers: Iterable[Callable[[Simulation], object]] = (),
    signals: bool = False,
    restart: Path | None = None,
    warn: Callable[[str], object] | None = None,
) -> dict:
    """Run a validated scene; write outputs to ``out_dir``; return the summary.  With
    ``signals`` (the command line), SIGINT/SIGTERM stop it cleanly (interrupts.py);
    with ``restart``, go on from the last checkpoint in that folder (checkpoint.py);
    ``warn``: where a quiet run's warnings go instead of stderr."""
    sim = Simulation(scene, out_dir, quiet, petsc_args, comm, observers, signals, restart, warn)
    try:
        return sim.run()
    finally:
        sim.close()


#: seconds the set-up may take before the run says it is compiling forms (a set-up
#: whose forms are in the cache takes about 1 s)
COMPILE_NOTICE_AFTER = 2.0


@contextlib.contextmanager
def _compile_notice(quiet: bool):
    """While the model is built: if it takes longer than ``COMPILE_NOTICE_AFTER``
    (its forms are not in the JIT cache yet), say so once instead of staying silent."""
    if quiet:
        yield
        return
    timer = threading.Timer(
        COMPILE_NOTICE_AFTER,
        lambda: print("compiling forms for this scene's effects (once; about 20-50 s)", flush=True),
    )
    timer.daemon = True
    timer.start()
    try:
        yield
    finally:
        timer.cancel()
