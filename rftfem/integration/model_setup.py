"""A scene's model and what `rftfem check` reports on it: the body built from its mesh
and hinge lines, the Model with its effects, and the lines on the mesh and the liquid
(the compilers kept quiet while forms are made)."""

from __future__ import annotations

import gc
import logging
from pathlib import Path
from typing import TYPE_CHECKING

from mpi4py import MPI

from rftfem import petsc_options
from rftfem.model.shell_model import Model
from rftfem.outputs.writers import Probes
from rftfem.scene import scales

if TYPE_CHECKING:
    from rftfem.meshes import Recipe


#: models built in this process since the last full garbage collection; past
#: COLLECT_EVERY, the next build collects first (see :func:`_release_finished_models`)
_built = 0
COLLECT_EVERY = 16


def _release_finished_models() -> None:
    """Free the models of finished runs before a process builds many more.

    A model holds about 20 MPI communicators (its meshes', index maps' and PETSc
    objects' duplicates), released only when Python frees the model, and a
    finished run's objects refer to each other, so only the cyclic garbage
    collector frees them: in a long-lived process with many objects (an in-process
    sweep, an optimisation, a test suite) it may not run for hundreds of models.
    MPICH gives a process 2048 communicators; past them a duplication fails and the
    process aborts (exit 15) or crashes inside dolfinx's dof map construction (the
    current stack's suite did both, ~1300 tests into one process).  A full
    collection every COLLECT_EVERY models (0.1-0.3 s) keeps at most that many
    finished models alive.  Every process builds the same models, so under mpirun
    the ranks collect at the same point."""
    global _built
    _built += 1
    if _built > COLLECT_EVERY:
        gc.collect()
        _built = 1


def build_model(
    scene: dict, comm: MPI.Comm, compile_forms: bool = True, tangent: str | None = None
) -> Model:
    """The scene's body (its hinge lines cut into strip meshes) and its Model, with
    the Newton tangent ``tangent`` (default: the scene's ``solver.tangent``)."""
    from rftfem.meshes import build_body, realize

    _release_finished_models()

    scene_dir = Path(scene.get("_folder") or Path(scene.get("_path") or "scene.toml").parent)
    if scene["mesh"]["kind"] == "bodies":
        body = realize(comm, bodies_recipe(scene, scene_dir))
    else:
        lines = [h["where"] for h in scene.get("hinge") or []]
        body = build_body(comm, scene["mesh"], scene_dir, hinges=lines)
    if tangent is None:
        tangent = petsc_options.tangent(scene.get("solver"))
    return Model(scene, body, compile_forms=compile_forms, tangent=tangent)


def bodies_recipe(scene: dict, scene_dir: Path) -> Recipe:
    """The recipe of a scene's [[body]] tables in one mesh, each body's own hinge
    lines cut in it (rftfem.meshes.bodies)."""
    from rftfem.meshes import body_recipe
    from rftfem.meshes.bodies import Placed, bodies_recipe

    def own_lines(name):
        cut = [h["where"].split(":", 1)[1] for h in scene["hinge"] if h.get("body") == name]
        return [w for w in cut if w not in ("hinge-left", "hinge-right")]

    return bodies_recipe(
        [
            Placed(
                b["name"],
                body_recipe(b["mesh"], scene_dir, hinges=own_lines(b["name"])),
                b["at"],
                b["turn"],
            )
            for b in scene["mesh"]["bodies"]
        ]
    )


def check(scene: dict, comm: MPI.Comm | None = None) -> list[str]:
    """Validate what needs the mesh (selectors, regions, probes); return the active effects."""
    return check_report(scene, comm)[0]


def check_report(scene: dict, comm: MPI.Comm | None = None) -> tuple[list[str], list, list[str]]:
    """``check``, the scene's groups (scales.py) and lines on its mesh and liquid."""
    comm = comm or MPI.COMM_WORLD
    quiet_compilers()
    model = build_model(scene, comm, compile_forms=False)
    Probes(model, scene.get("output", {}).get("probes", []))
    report = model.body.report
    lines = report.lines() if report is not None else []
    if model.fluid is not None:  # RFT: its coefficients; Stokes: sizes, cost, error
        lines += model.fluid.check_lines()
    # what the run would warn of at its start (a wall too close, a body too large)
    lines += [f"warning: {line}" for comp in model.components for line in comp.warnings()]
    return model.active_effects(), scales.groups(scene, model), lines


class _CompilerChatter(logging.Filter):
    """Drops the INFO lines (gcc command lines) that distutils/setuptools log on the
    root logger while cffi builds a JIT module; their build also resets the root
    level, so a level alone does not keep them quiet."""

    def filter(self, record):
        where = record.pathname.replace("\\", "/")
        return record.levelno >= logging.WARNING or not any(
            part in where for part in ("/distutils/", "/setuptools/", "/cffi/")
        )


def quiet_compilers() -> None:
    """FFCx/cffi log every compilation at INFO on some stacks: keep the terminal readable."""
    for name in ("", "ffcx", "UFL", "cffi", "dolfinx"):
        logger = logging.getLogger(name)
        if logger.level == logging.NOTSET or logger.level < logging.WARNING:
            logger.setLevel(logging.WARNING)
    root = logging.getLogger()
    if not any(isinstance(f, _CompilerChatter) for f in root.filters):
        root.addFilter(_CompilerChatter())
