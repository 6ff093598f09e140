"""The levels of ``rftfem study``: each refinement's overrides, its run and what it read back."""

from __future__ import annotations

import json
import math
import shutil
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from rftfem.errors import SceneError
from rftfem.studies.batch import failure_reason
from rftfem.studies.reuse import keep_key, reused

if TYPE_CHECKING:
    from collections.abc import Sequence

    from rftfem.outputs.formulas import Objective
    from rftfem.studies import executors

#: which of mesh.divisions each kind refines
_DIVIDED = {"mesh": (0, 1), "both": (0, 1), "mesh.x": (0,), "mesh.y": (1,)}


@dataclass
class Level:
    """One run of the study."""

    kind: str  # "dt", "mesh", "both" (level 0: "base")
    k: int
    overrides: list[str]
    folder: Path
    dt: float = math.nan
    divisions: list[int] | None = None
    fluid_refine: int | None = None  # the Stokes layer's fluid.refine, when it is refined
    status: str = "not run"
    failure: str = ""
    dofs: int | None = None
    steps: int | None = None
    newton: int | None = None
    cuts: int | None = None
    wall: float | None = None
    compile: float | None = None
    values: dict = field(default_factory=dict)  # quantity name -> float or None
    exit_status: int = 0
    key: dict | None = None  # what --reuse compares (rftfem/studies/reuse.py)
    note: str = ""  # why a finished run was not reused, or not keyed


def _toml(value) -> str:
    if isinstance(value, list):
        return "[" + ",".join(_toml(v) for v in value) + "]"
    return repr(value)


def plan(
    scene: dict, kinds: list[str], levels: int, out: Path, factor: float = 2.0
) -> dict[str, list[Level]]:
    """The levels of each kind (level 0 is the same object in every kind), each
    ``factor`` times finer than the one before (divisions rounded to whole cells)."""
    time_ = scene["time"]
    dt0, every0 = float(time_["dt"]), int(time_.get("output_every", 1))
    mesh = scene.get("mesh") or {}
    div0 = mesh.get("divisions") if mesh.get("kind", "strip") != "gmsh" else None
    _check_refinable(scene, kinds, factor, div0)
    fluid = scene.get("fluid") or {}
    refine0 = int(fluid.get("refine") or 0)
    if "fluid" in kinds:
        _check_fluid(fluid, factor)
    base = Level(
        "base",
        0,
        [],
        out / "level-0",
        dt=dt0,
        divisions=list(div0) if div0 else None,
        fluid_refine=refine0 if "fluid" in kinds else None,
    )
    plans = {}
    for kind in kinds:
        series = [base]
        for k in range(1, levels):
            series.append(_refined(base, kind, k, out, factor, every0, div0, refine0))
        plans[kind] = series
    return plans


def _check_refinable(scene: dict, kinds: list[str], factor: float, div0: list | None) -> None:
    """Whether the scene has what ``--refine`` of each kind halves or doubles."""
    if any(k in _DIVIDED for k in kinds) and not div0:
        raise SceneError(
            "--refine mesh: the scene's [mesh] has no divisions to double "
            "(a mesh read from a file is refined in gmsh, not here)"
        )
    if scene["time"]["scheme"] == "static" and any(k in ("dt", "both") for k in kinds):
        raise SceneError(
            "--refine dt: the scene is static (time.scheme resolves to "
            '"static"): its steps are load steps with no time error to refine'
        )
    if any(k in ("dt", "both") for k in kinds) and not float(factor).is_integer():
        raise SceneError(
            f"--factor {factor:g} with --refine dt: the levels would write "
            "their rows at different times (time.output_every is scaled by "
            "the factor); use a whole factor for dt"
        )


def _check_fluid(fluid: dict, factor: float) -> None:
    """``--refine fluid``: a Stokes layer, refined by the factor 2."""
    if fluid.get("model") != "stokes" or fluid.get("method", "layer") != "layer":
        raise SceneError(
            "--refine fluid: the scene's liquid is not the Stokes layer "
            '(fluid.model = "stokes", fluid.method = "layer"): nothing of '
            "its own to refine"
        )
    if factor != 2.0:
        raise SceneError(
            f"--factor {factor:g} with --refine fluid: each fluid.refine "
            "level halves the force grid; use the factor 2"
        )


def _refined(
    base: Level,
    kind: str,
    k: int,
    out: Path,
    factor: float,
    every0: int,
    div0: list | None,
    refine0: int,
) -> Level:
    """Level ``k`` of ``kind``: ``factor**k`` times finer than ``base``."""
    dt0 = base.dt
    sets, f = [], factor**k
    dt, div = dt0, base.divisions
    if kind in ("dt", "both"):
        dt = dt0 / f
        sets += [f"time.dt={dt!r}", f"time.output_every={every0 * round(f)}"]
    if kind in _DIVIDED:
        div = [max(1, round(n * f)) if i in _DIVIDED[kind] else n for i, n in enumerate(div0)]
        sets.append(f"mesh.divisions={_toml(div)}")
    refine = None
    if kind == "fluid":  # the liquid's own grid, the shell untouched
        refine = refine0 + k
        sets.append(f"fluid.refine={refine}")
    return Level(
        kind,
        k,
        sets,
        out / f"{kind}-{k}",
        dt=dt,
        divisions=div,
        fluid_refine=refine if kind == "fluid" else base.fluid_refine,
    )


def run_level(
    level: Level,
    scene_file: str,
    overrides: list[str],
    executor: executors.Executor,
    petsc_args: list[str],
    reuse: bool = False,
) -> None:
    """Run one level (a fresh folder) and read its summary into ``level``; with
    ``reuse``, a finished run of the same content (``level.key``,
    rftfem/studies/reuse.py) is read instead.  The run is the ``executor``'s
    (rftfem/studies/executors.py: in this process, a child ``rftfem run``, or a Dask
    worker's)."""
    overrides = [*overrides, *level.overrides]
    kept, level.note = reused(level.folder, level.key, reuse)
    if kept:
        level.status = "reused"
    else:
        if level.folder.exists():
            shutil.rmtree(level.folder)
        level.folder.mkdir(parents=True)
        level.exit_status = executor.run(scene_file, overrides, level.folder, petsc_args)
        if level.exit_status == 0:
            level.note = (
                keep_key(level.folder, level.key, scene_file, overrides, petsc_args, "study")
                or level.note
            )
    _read_summary(level)


def _read_summary(level: Level) -> None:
    status = level.exit_status
    try:
        summary = json.loads((level.folder / "summary.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        summary = None
    if summary is None:
        level.status = "failed"
        level.failure = failure_reason(level.folder / "run.log", status)
        return
    level.status = summary.get("status", "failed") if status == 0 else "failed"
    failure = summary.get("failure") or {}
    level.failure = str(failure.get("reason", "")) if level.status != "ok" else ""
    if status != 0 and not level.failure:
        level.failure = f"exit status {status}"
    counts, wall = summary.get("counts") or {}, summary.get("wall_s") or {}
    level.dofs, level.steps = summary.get("dofs"), counts.get("steps")
    level.newton, level.cuts = counts.get("newton_iterations"), counts.get("dt_cuts")
    level.compile = wall.get("compile")
    if wall.get("total") is not None:
        level.wall = wall["total"] - (level.compile or 0.0)


def evaluate_level(level: Level, quantities: Sequence[tuple[str, Objective]]) -> None:
    from rftfem.outputs.quantities import RunFolder

    if level.status != "ok":
        level.values = {name: None for name, _ in quantities}
        return
    run = RunFolder(level.folder)
    for name, q in quantities:
        try:
            level.values[name] = q.evaluate(run)
        except SceneError as exc:
            level.values[name] = None
            level.status, level.failure = "failed", f"quantity {name}: {exc}"


__all__ = ["Level", "plan", "run_level", "evaluate_level"]
