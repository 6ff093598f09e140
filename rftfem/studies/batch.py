"""Many runs in one process: the runs of ``rftfem study`` (and of any tool that
evaluates a scene at many settings) without a new interpreter for each.

A fresh ``rftfem run`` pays before its first step for the interpreter and the
FEniCSx imports (about 0.9 s here), then for gmsh's start, the mesh and loading
each compiled form's module from the JIT cache (about 0.4 s more), whatever the
size of the run.
In one process these are paid once and the compiled modules stay loaded, so a
second run of a scene sets up in a tenth of a second or so
(``benchmarks/sweep_cost.py`` measures it).

``run_here`` does what ``rftfem run SCENE --out FOLDER --quiet --set ...``
does, in this process: the same outputs, the same exit status (0 ok, 2 bad
scene or option, 3 failed numerically, 1 an internal error, its traceback in
the log), what the run prints written to ``FOLDER/run.log``.  A run that fails
leaves the process as it found it (its PETSc objects are destroyed), so the
next run starts clean.
"""

from __future__ import annotations

import contextlib
import os
import subprocess
import sys
import time
import traceback
from pathlib import Path
from typing import TYPE_CHECKING

from rftfem.errors import RunFailed, RunInterrupted, SceneError

if TYPE_CHECKING:
    from collections.abc import Callable


def run_here(
    scene_file: str | Path,
    overrides: list[str],
    folder: Path,
    petsc_args: list[str] | None = None,
    simulate: Callable[..., object] | None = None,
) -> int:
    """Run ``scene_file`` with ``overrides`` into ``folder`` in this process (serial);
    its messages go to ``folder/run.log``; return the exit status of ``rftfem run``.
    ``simulate(scene, out_dir=, quiet=, petsc_args=)`` replaces the plain run (a run
    that also takes its gradient, rftfem/studies/sensitivity.py)."""
    from rftfem.integration.simulation import run as run_simulation
    from rftfem.scene.reading import load_scene

    simulate = simulate or run_simulation

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    with (
        open(folder / "run.log", "w", encoding="utf-8") as log,
        contextlib.redirect_stdout(log),
        contextlib.redirect_stderr(log),
    ):
        t0 = time.perf_counter()
        try:
            scene = load_scene(str(scene_file), list(overrides))
            simulate(scene, out_dir=folder, quiet=True, petsc_args=list(petsc_args or []))
        except SceneError as exc:
            print(f"rftfem: error: {exc}")
            return SceneError.exit_status
        except RunFailed as exc:
            print(f"rftfem: {exc}; outputs so far are in {folder}")
            return RunFailed.exit_status
        except RunInterrupted as exc:  # not asked for here (no signal handlers): a stop
            print(f"rftfem: {exc}; outputs so far are in {folder}")
            return exc.exit_status
        except Exception:  # a bug: as `rftfem run` would, a traceback and exit 1
            traceback.print_exc()
            return 1
        print(
            f"rftfem: done in this process ({time.perf_counter() - t0:.2f} s), outputs in {folder}"
        )
        return 0


def run_child(
    scene_file: str | Path,
    overrides: list[str],
    folder: Path,
    launcher: list[str] = (),
    petsc_args: list[str] | None = None,
    die_with_parent: bool = False,
) -> int:
    """The same run as a child ``rftfem run`` (under ``launcher``, e.g. ``mpirun -n 2``),
    its output in ``folder/run.log``; its exit status.  ``die_with_parent``: the child
    is killed when this process dies (Linux), as a Dask worker's run must be."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    cmd = [
        *launcher,
        sys.executable,
        "-m",
        "rftfem",
        "run",
        str(scene_file),
        "--out",
        str(folder),
        "--quiet",
    ]
    from rftfem.scene.overrides import as_arguments

    cmd += as_arguments(list(overrides))
    cmd += list(petsc_args or [])
    env = child_environment(bool(launcher))
    for _ in range(2):
        with open(folder / "run.log", "w", encoding="utf-8") as log:
            status = subprocess.call(
                cmd,
                stdout=log,
                stderr=subprocess.STDOUT,
                env=env,
                preexec_fn=_die_with_parent if die_with_parent else None,
            )
        # a launch that ends in failure having said nothing at all (gmsh 4.8's start
        # now and then: tests/conftest.py run_command) is made once more; every real
        # failure says why
        if status == 0 or (folder / "run.log").stat().st_size > 0:
            break
    return status


def _die_with_parent():
    """In the child, before it runs: ask Linux to kill it when its parent dies."""
    import ctypes
    import signal

    try:
        ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass


#: prefixes of the variables an MPI process (a singleton too) leaves for its own
#: children: a launch that inherits them takes itself for a part of that job, and
#: Open MPI's mpirun then exits 1 without a word
#: (a user's own OMPI_MCA_ settings are kept)
_MPI_JOB_VARIABLES = (
    "PMIX_",
    "PMI_",
    "HYDRA_",
    "ORTE_",
    "OMPI_COMM_WORLD_",
    "OMPI_APP_CTX_",
    "OMPI_UNIVERSE_",
    "OMPI_FIRST_",
    "OMPI_NUM_APP_CTX",
    "OMPI_FILE_LOCATION",
    "OMPI_MCA_ess",
    "OMPI_MCA_orte_",
    "OMPI_MCA_pmix",
)


def child_environment(mpirun: bool) -> dict:
    """This process's environment for a child run, without the MPI job's variables;
    for an ``mpirun`` launch as root, with Open MPI's permission (a container's root:
    this launch is rftfem's own, so its user could not add it)."""
    env = {k: v for k, v in os.environ.items() if not k.startswith(_MPI_JOB_VARIABLES)}
    if mpirun and hasattr(os, "geteuid") and os.geteuid() == 0:
        env.update(OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    return env


def failure_reason(log: Path, status: int) -> str:
    """The line of a run's log that says why it ended without a summary: rftfem's own
    one-line error, else a traceback's last line, else the launcher's first words."""
    try:
        lines = [
            ln.strip()
            for ln in log.read_text(encoding="utf-8", errors="replace").splitlines()
            if any(c.isalnum() for c in ln)
        ]
    except OSError:
        lines = []
    own = [ln for ln in lines if ln.startswith("rftfem")]
    if own:
        line = own[-1]
    elif any(ln.startswith("Traceback") for ln in lines):
        line = lines[-1]
    else:
        line = lines[0] if lines else ""
    return (line or f"exit status {status}")[:300] + f" (exit status {status}; {log})"


def check_jobs(jobs: int, np: int, what: str) -> None:
    """``--jobs J`` (``what`` side by side) or ``--np P`` (each on P processes), not both."""
    from rftfem.errors import SceneError

    if jobs < 1 or np < 1:
        raise SceneError("--jobs and --np: expected at least 1")
    if jobs > 1 and np > 1:
        raise SceneError(
            f"--jobs and --np: give one of them ({what} side by side, or each on several processes)"
        )


def launcher(np: int) -> list[str]:
    """``mpirun -n P`` of the running stack (beside the interpreter, else on PATH)."""
    import shutil

    from rftfem.errors import SceneError

    if np <= 1:
        return []
    here = Path(sys.executable).parent / "mpirun"
    exe = str(here) if here.exists() else shutil.which("mpirun")
    if exe is None:
        raise SceneError(f"--np {np}: no mpirun beside {sys.executable} or on PATH")
    return [exe, "-n", str(np)]


__all__ = ["run_here", "run_child", "child_environment", "failure_reason", "check_jobs", "launcher"]
