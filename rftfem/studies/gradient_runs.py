"""A run of a static scene in this process with its exact gradient (the adjoint of
:mod:`rftfem.studies.sensitivity`, docs/model.md §7.6): what ``rftfem optimize``
evaluates when it can differentiate its objective."""

from __future__ import annotations

import time
from pathlib import Path

from rftfem.errors import SceneError
from rftfem.studies.sensitivity import check_request, gradient, keep_last_step

__all__ = ["run_with_gradient"]


def run_with_gradient(scene_file, overrides: list[str], folder, keys: list[str],
                      objective: str, petsc_args=None
                      ) -> tuple[int, float | None, list[float] | None]:
    """Run the static scene (time.scheme resolves to "static") in this process into
    ``folder`` as ``rftfem.studies.batch.run_here`` does (same outputs, exit statuses, messages
    to folder/run.log); if it succeeded return ``(0, J, [dJ/dkey for key in keys])``, J
    the objective on the converged final state and its gradient by the adjoint
    (docs/model.md §7.6), also written to folder/gradient.json.  A failed run gives
    ``(status, None, None)``; a key or objective that cannot be differentiated is a
    SceneError, raised before the run."""
    from rftfem.studies.batch import run_here
    from rftfem.outputs.writers import write_json
    from rftfem.scene.reading import load_scene
    from rftfem.integration.simulation import Simulation

    try:
        scene = load_scene(str(scene_file), list(overrides))
    except SceneError:
        scene = None  # run_here says why, in run.log, and returns exit status 2
    if scene is not None:
        try:
            check_request(scene, list(keys), objective)
        except SceneError as exc:  # said in run.log too, as run_here says a bad scene
            Path(folder).mkdir(parents=True, exist_ok=True)
            (Path(folder) / "run.log").write_text(f"rftfem: error: {exc}\n", encoding="utf-8")
            raise
    result = {}

    def simulate(scene, out_dir, quiet, petsc_args):
        # as simulation.run, with the last step's state kept before its triad update
        sim = Simulation(scene, out_dir=out_dir, quiet=quiet, petsc_args=petsc_args)
        try:
            last = keep_last_step(sim.model)
            sim.run()
            t1 = time.perf_counter()
            parsed, target = check_request(scene, list(keys), objective)
            J, grad = gradient(sim, last, parsed, target)
            print(f"rftfem: the gradient by the adjoint in {time.perf_counter() - t1:.2f} s")
            write_json(Path(out_dir) / "gradient.json",
                       {"objective": objective, "value": J, "gradient": dict(zip(keys, grad))},
                       sim.comm)
            result.update(value=J, gradient=grad)
        finally:
            sim.close()

    status = run_here(scene_file, overrides, Path(folder), petsc_args, simulate=simulate)
    if status != 0:
        return status, None, None
    return 0, result["value"], result["gradient"]
