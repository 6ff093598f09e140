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
import threading
import time as _time
from pathlib import Path
from typing import TYPE_CHECKING

from mpi4py import MPI

from rftfem import petsc_options
from rftfem.errors import RunFailed, RunInterrupted, SceneError
from rftfem.integration.arclength import PathFollowing
from rftfem.integration.error_control import ErrorControl
from rftfem.integration.interrupts import NoStops, StopRequests
from rftfem.integration.model_setup import build_model, quiet_compilers
from rftfem.integration.restart import Checkpoints, checked_checkpoint
from rftfem.integration.run_outputs import RunOutputs, make_out_dir
from rftfem.integration.run_report import RunReport
from rftfem.integration.run_state import RunHooks, RunPosition
from rftfem.integration.run_view import RunView
from rftfem.integration.schemes import make_scheme
from rftfem.integration.solver import StepSolver
from rftfem.integration.step_control import StepController
from rftfem.model.effects.base import NonlocalEffect
from rftfem.model.reactions import Reactions
from rftfem.outputs.writers import BodyLog, Probes

if TYPE_CHECKING:
    from collections.abc import Callable, Iterable

    from rftfem.outputs.progress import Progress


class Simulation(RunView, RunReport):
    """One run of a scene; ``observers`` are called as ``f(sim)`` after every step.
    With ``signals``, SIGINT and SIGTERM stop the run after its step (interrupts.py);
    with ``restart`` (a results folder), the run goes on from its last checkpoint
    and appends to its outputs (checkpoint.py).

    The run's position (``pos``: time, steps, counts; run_state.py) and its loop; the
    parts it composes own their state: the step controller (``steps``,
    step_control.py), the time-error estimate and error-controlled steps
    (``errors``, error_control.py), path-following by arc length (``path``, an
    arc-length run's only; arclength.py), the outputs and summary (``outputs``,
    run_outputs.py) and the checkpoints (``checkpoints``, restart.py).  What callers
    read of it is run_view.py's, what it says run_report.py's."""

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
        self.out_dir = _results_folder(out_dir, restart)
        # the checkpoint a restart goes on from, checked before the set-up
        resume = checked_checkpoint(restart, scene, self.comm) if restart is not None else None
        make_out_dir(self.out_dir, self.comm)  # before the costly set-up: fail early
        self.quiet = quiet
        self.observers = list(observers)
        quiet_compilers()
        t0 = _time.perf_counter()
        self._build(scene, quiet, petsc_args)
        self.setup_time = _time.perf_counter() - t0
        self._compose(scene, resume)

    def _build(self, scene: dict, quiet: bool, petsc_args: list[str] | None) -> None:
        """The costly set-up: the model (its forms compiled), the scheme, the step
        solver and the outputs."""
        with _compile_notice(quiet or self.comm.rank != 0):
            self.model = build_model(
                scene, self.comm, tangent=petsc_options.tangent(scene.get("solver"), petsc_args)
            )
        self.probes = Probes(self.model, scene.get("output", {}).get("probes", []))
        self.scheme = make_scheme(scene["time"])
        # time steps start Newton's tangent on the converged stress resultants; static
        # load steps on their start's own (docs/model.md §7.4)
        self.model.first_tangent_converged = self.scheme.has_velocity
        self._make_solver(scene, petsc_args)
        #: the named [[boundary]] and [[motion]] entries' reactions, set after each step
        self.reactions = Reactions(self.model)
        self.body = BodyLog(self.model, self.reactions)
        self.outputs = RunOutputs(
            scene, self.model, self.scheme, self.comm, self.probes, self.body, self.out_dir
        )

    def _make_solver(self, scene: dict, petsc_args: list[str] | None) -> None:
        """The PETSc options (``options``) and the step solver (``solver``): the
        factorisation, the LU package and its fallback chosen for the model's size."""
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

    def _compose(self, scene: dict, resume: tuple[Path, dict] | None) -> None:
        """The parts the run composes (its position, the step controller, the error
        control, the path-following, the checkpoints), from a restart's checkpoint if
        ``resume``."""
        #: where the run is: its time, the step under way, the steps done, the counts
        self.pos = RunPosition()
        time_ = scene["time"]
        #: each step's estimated local error (§6.9), and error-controlled steps
        self.errors = ErrorControl(self.model, self.scheme, time_)
        free = not (scene["boundary"] or scene["motion"] or self.model.fluid)
        self.steps = StepController(
            self.model,
            self.solver,
            self.scheme,
            time_,
            self.stops,
            self.reactions,
            self.errors,
            free,
        )
        #: an arc-length run's path-following (its load factor, arcs, direction), else None
        self.path = (
            PathFollowing(
                self.model, self.solver, self.scheme, self.comm, time_, self.stops, self.reactions
            )
            if self.scheme.name == "arc-length"
            else None
        )
        self.model.keep_predictions = self.scheme.has_velocity
        self.checkpoints = Checkpoints(
            scene, self.model, self.solver, self.scheme, self.comm, self.out_dir, resume
        )
        if resume is not None:
            self.checkpoints.load(self.pos, self.steps.state, self._path_state())

    # --- the run -------------------------------------------------------------

    def run(self) -> dict:
        with self.stops:
            return self._run()

    def _path_state(self):
        return self.path.state if self.path is not None else None

    def _observe(self):
        for f in self.observers:
            f(self)

    def _output(self, t: float):
        self.outputs.write(t, self._loads_time(t))

    def _last_row(self):
        self.outputs.last_row(self.pos.t, self._loads_time(self.pos.t))

    def _checkpoint(self, next_step: float | None = None, last: bool = False):
        elapsed = _time.perf_counter() - self._wall_start + self.setup_time
        self.checkpoints.write_if_due(
            self.pos,
            self.steps.state,
            self._path_state(),
            output_row=self.outputs.wrote_at(self.pos.t),
            elapsed=elapsed,
            next_step=next_step,
            last=last,
        )

    def _stop_if_asked(self):
        """After a step: if a signal asked any rank to stop, write a last output row
        and stop (interrupts.py)."""
        signum = self.stops.requested()
        if signum:
            self._last_row()
            raise RunInterrupted(signum, self.pos.t, self.pos.step)

    def _hooks(self, progress: Progress) -> RunHooks:
        """What the loops over steps call back into this run."""
        return RunHooks(
            progress=progress,
            step_row=self.outputs.step_row,
            observe=self._observe,
            output=self._output,
            checkpoint=self._checkpoint,
            stop_if_asked=self._stop_if_asked,
            steady=lambda: self.outputs.steady_after_step(self.pos.t, self.pos.step, progress),
            wrote_at=self.outputs.wrote_at,
        )

    def _run(self) -> dict:
        time_ = self.scene["time"]
        summary = self._summary("running")
        wall_start = self._wall_start = _time.perf_counter()
        path = self.path is not None
        progress = self._open_progress(path)
        resume = self.checkpoints.resume
        self.outputs.open(
            self.pos.t, resume[1]["output_row"] if resume is not None else None, progress.warn
        )
        hooks = self._hooks(progress)
        steady = self.outputs.steady
        try:
            self._start(progress)
            if path:
                self.path.run(self.pos, hooks)
            elif time_.get("tolerance") is not None:
                first = (resume is not None and resume[1].get("next_step")) or time_["dt"]
                self.errors.run(self.pos, self.steps, hooks, first)
            else:
                self.steps.run(self.pos, hooks)
            if steady is not None and not steady.result:
                steady.result = {"reached": False}
            if steady is not None and not steady.result["reached"]:
                progress.warn(
                    f'time.until = "periodic": not steady to '
                    f"{time_['steady_tolerance']:g} by time.end = {time_['end']:g}"
                )
            summary = self._summary("ok", wall_start)
            self.errors.warn_if_too_long(progress)
        except RunFailed as err:
            self._last_row()
            summary = self._summary("failed", wall_start)
            summary["failure"] = {"time": err.time, "step": err.step, "reason": err.reason}
            raise
        except BaseException as exc:
            if not (isinstance(exc, RunInterrupted) or self.stops.immediate):
                raise
            err, summary = self._interrupted(exc, wall_start)
            raise err from None
        finally:
            self._close_run(progress, summary)
        self._report_done(progress, summary)
        return summary

    def _start(self, progress: Progress):
        """The state at t = 0 and its output row, or the checkpoint a restart goes on from."""
        resume = self.checkpoints.resume
        if resume is not None:
            progress.log(
                f"restarted at t = {self.pos.t:.6g} (step {self.pos.completed}) from {resume[0]}"
            )
            return
        self.steps.initial_equilibrium(self.pos)
        compiled = self.model.timings["compile"]
        self._output(0.0)
        # the first row compiles the outputs' forms: that belongs to the set-up
        later = self.model.timings["compile"] - compiled
        self.setup_time += later
        self.outputs.wall -= later

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


def _results_folder(out_dir: Path | None, restart: Path | None) -> Path | None:
    """The folder a run writes to: ``out_dir``, or the one a ``restart`` continues (a
    SceneError for another ``out_dir``), or None."""
    if restart is not None and out_dir is not None and Path(out_dir) != Path(restart):
        raise SceneError(
            f"--out {out_dir}: a restart appends to the folder it continues "
            f"({restart}); leave --out out or give that folder"
        )
    return (
        Path(restart if restart is not None else out_dir)
        if (restart or out_dir) is not None
        else None
    )


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
