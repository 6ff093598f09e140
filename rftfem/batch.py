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
import time
import traceback
from pathlib import Path

from rftfem.errors import RunFailed, RunInterrupted, SceneError


def run_here(scene_file: str | Path, overrides: list[str], folder: Path,
             petsc_args: list[str] | None = None) -> int:
    """Run ``scene_file`` with ``overrides`` into ``folder`` in this process (serial);
    its messages go to ``folder/run.log``; return the exit status of ``rftfem run``."""
    from rftfem.scene import load_scene
    from rftfem.simulation import run as run_simulation

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    with open(folder / "run.log", "w", encoding="utf-8") as log, \
            contextlib.redirect_stdout(log), contextlib.redirect_stderr(log):
        t0 = time.perf_counter()
        try:
            scene = load_scene(str(scene_file), list(overrides))
            run_simulation(scene, out_dir=folder, quiet=True, petsc_args=list(petsc_args or []))
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
        print(f"rftfem: done in this process ({time.perf_counter() - t0:.2f} s), "
              f"outputs in {folder}")
        return 0


__all__ = ["run_here"]
