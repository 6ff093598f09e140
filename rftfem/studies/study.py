"""``rftfem study``: what accuracy costs, for one scene, measured.

    rftfem study SCENE.toml --quantity NAME=EXPR [--refine dt|mesh|both ...]
                 [--levels N] [--set KEY=VALUE ...] [--out DIR] [--jobs J | --np P]

The scene runs at ``N`` successive refinements of each kind asked for, level 0
being the scene as given (with its ``--set`` overrides):

* ``dt``: ``time.dt`` halved per level, ``time.output_every`` doubled, so that
  every level writes its rows at the same times;
* ``mesh``: ``mesh.divisions`` doubled per level (generated strips only);
  ``mesh.x`` and ``mesh.y`` the divisions along X or Y alone (a Stokes sheet's
  dense operator grows with the square of the nodes);
* ``both``: both at once.

``--factor F`` refines by F instead of 2 per level (divisions rounded to whole
cells; dt takes a whole F only, so that every level writes rows at the same times).

Each level is an ordinary run in its own folder ``DIR/<kind>-<k>``
(level 0 is shared by the kinds, ``DIR/level-0``), so every run can be opened,
rendered and collected as any other.  One level at a time (``--jobs 1``, no
``--np``), the levels run in the study's own process (rftfem/studies/batch.py: the
imports and the compiled forms' loading are paid once); with ``--jobs``,
``--np`` or ``--processes`` each is a child ``rftfem run``.

For every level and quantity the study reports the value, its change from the
level before, the observed order

    p_k = log(|Q_{k-1} − Q_{k-2}| / |Q_k − Q_{k-1}|) / log F        (from level 2 on)

and the Richardson estimate of the level's error

    E_k = |Q_k − Q_{k-1}| / (F^p − 1)

with ``p`` the observed order where it is known and positive, capped at the
nominal order of the kind (the scheme's order for ``dt``: 1 for backward Euler,
2 for the others; 2 for the mesh kinds, 1 in Stokes flow, whose regularized
single layer is first order in the spacing), and the nominal order where no
order is observed; the order used is in the table.  The estimate assumes the
levels are in the asymptotic range: an observed order far from the nominal one
says they are not (a change that falls faster than the scheme allows is one
level leaving a pre-asymptotic regime, not a better method).

Written to DIR: ``study.csv`` (a row per level and quantity), ``study.md`` (the
same as tables, with the command) and ``study.png`` (estimated error against
wall time, log-log, a curve per kind; one panel per quantity).  The wall time
of a level is its run's total minus its form compilation (a warm cache costs
nothing then).  A level that fails (bad scene at that resolution, exit 3,
a quantity it has no data for) stays in the tables as failed, with its reason,
and the levels after it still run.
"""

from __future__ import annotations

import json
import math
import shutil
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from rftfem.errors import SceneError
from rftfem.studies import executors
from rftfem.studies.batch import failure_reason
from rftfem.studies.executors import check_executor_options, make_executor
from rftfem.studies.reuse import keep_key, key_of, report, reused
from rftfem.studies.study_report import SCHEME_ORDER, analyse, markdown, plot, table_rows, write_csv

if TYPE_CHECKING:
    import argparse
    from collections.abc import Sequence
    from typing import Any

    from rftfem.outputs.formulas import Objective

KINDS = ("dt", "mesh", "mesh.x", "mesh.y", "both", "fluid")
#: which of mesh.divisions each kind refines
_DIVIDED = {"mesh": (0, 1), "both": (0, 1), "mesh.x": (0,), "mesh.y": (1,)}

DESCRIPTION = """\
Run a scene at successive refinements (dt halved, mesh divisions doubled, or
both) and report, for each level, the cost (unknowns, steps, Newton iterations,
dt cuts, wall time without compilation), the quantities asked for, their change,
the observed order of convergence and a Richardson error estimate. Writes
study.csv, study.md and study.png (estimated error against wall time)."""

EPILOG = """\
quantities (--quantity NAME=EXPR, at least one) are those of `rftfem collect`:
  COLUMN@TIME, rate(COLUMN, A, B), mean(COLUMN, A, B), max(...), min(...),
  spin(PROBE_A, PROBE_B, AXIS, A, B)  (mean turning rate of the line A->B about
  the axis x, y or z, in rad per unit time), steady(NAME)  (a steady value of a
  time.until = "periodic" run, e.g. steady(centroid_x_rate))
examples:
  rftfem study demos/swimming_sheet.toml --refine dt --levels 3 \\
      --quantity 'speed=steady(front_ux_rate)'
  rftfem study demos/rollup.toml --refine mesh --levels 4 --quantity 'tip=tip_uz@0.25'
  rftfem study demos/bidirectional_strip.toml --refine dt --levels 3 --jobs 2 \\
      --quantity 'speed=rate(centroid_z, 1.1, 2.1)'
exit status: 0 study written (also with failed levels), 2 bad option or scene"""


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


# --- the levels ---------------------------------------------------------------------


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
    fluid = scene.get("fluid") or {}
    refine0 = int(fluid.get("refine") or 0)
    if "fluid" in kinds:
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
            sets, f = [], factor**k
            dt, div = dt0, base.divisions
            if kind in ("dt", "both"):
                dt = dt0 / f
                sets += [f"time.dt={dt!r}", f"time.output_every={every0 * round(f)}"]
            if kind in _DIVIDED:
                div = [
                    max(1, round(n * f)) if i in _DIVIDED[kind] else n for i, n in enumerate(div0)
                ]
                sets.append(f"mesh.divisions={_toml(div)}")
            refine = None
            if kind == "fluid":  # the liquid's own grid, the shell untouched
                refine = refine0 + k
                sets.append(f"fluid.refine={refine}")
            series.append(
                Level(
                    kind,
                    k,
                    sets,
                    out / f"{kind}-{k}",
                    dt=dt,
                    divisions=div,
                    fluid_refine=refine if kind == "fluid" else base.fluid_refine,
                )
            )
        plans[kind] = series
    return plans


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


# --- orders and estimates ---------------------------------------------------------


def add_arguments(parser: argparse.ArgumentParser) -> None:
    import argparse

    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    parser.epilog = EPILOG
    parser.add_argument("scene", metavar="SCENE.toml", help="the scene file")
    parser.add_argument(
        "--quantity",
        metavar="NAME=EXPR",
        action="append",
        default=[],
        dest="quantities",
        help="what to converge (grammar below); repeatable",
    )
    parser.add_argument(
        "--refine",
        metavar="KIND",
        action="append",
        default=[],
        help="dt, mesh, mesh.x or mesh.y (the strip's divisions along X "
        "or Y only), both, or fluid (the Stokes layer's own force grid, "
        "fluid.refine + 1 a level; the shell untouched) (repeatable, or "
        "comma-separated: --refine dt,mesh); default dt",
    )
    parser.add_argument(
        "--factor",
        metavar="F",
        type=float,
        default=2.0,
        help="refinement from one level to the next (default 2; a mesh "
        "takes any F > 1, its divisions rounded; dt a whole F)",
    )
    parser.add_argument(
        "--levels",
        metavar="N",
        type=int,
        default=3,
        help="levels per kind, the scene itself included (default 3; 3 give one observed order)",
    )
    # --set, --out, --jobs, --np, --reuse, --executor...
    executors.add_arguments(
        parser, "study", "levels", reuse_note=" (a study extended or re-analysed)"
    )
    parser.add_argument(
        "--processes",
        action="store_true",
        help="run each level as its own `rftfem run` process, also with "
        "--jobs 1 (by default one-at-a-time levels run in the study's "
        "own process, which pays the imports and form loading once)",
    )


def _kinds(options: list[str]) -> list[str]:
    kinds = [k.strip() for text in (options or ["dt"]) for k in text.split(",") if k.strip()]
    for k in kinds:
        if k not in KINDS:
            raise SceneError(f"--refine: unknown kind '{k}' (expected {', '.join(KINDS)})")
    return list(dict.fromkeys(kinds))


def main(args: argparse.Namespace, petsc_args: list[str], console: Any) -> int:
    from rftfem.outputs.collect import parse_option
    from rftfem.scene.overrides import as_arguments
    from rftfem.scene.reading import load_scene, resolved_scheme

    if not args.quantities:
        raise SceneError(
            "--quantity: give at least one quantity to converge (e.g. --quantity 'tip=tip_uz@end')"
        )
    quantities = [parse_option(q) for q in args.quantities]
    names = [n for n, _ in quantities]
    if len(set(names)) < len(names):
        raise SceneError("--quantity: a name is given twice")
    kinds = _kinds(args.refine)
    if not (args.factor > 1.0 and math.isfinite(args.factor)):
        raise SceneError(f"--factor: expected a number > 1, found {args.factor:g}")
    if args.levels < 2:
        raise SceneError(f"--levels: expected at least 2, found {args.levels}")
    check_executor_options(args.jobs, args.np, args.executor, "levels")
    scene = load_scene(args.scene, args.overrides)
    scene["time"]["scheme"] = resolved_scheme(scene)
    out = args.out if args.out is not None else Path("results") / f"study-{Path(args.scene).stem}"
    plans = plan(scene, kinds, args.levels, out, args.factor)
    levels = list({id(lv): lv for series in plans.values() for lv in series}.values())
    # every level's scene must be valid before anything runs; its key for --reuse
    for lv in levels:
        try:
            lv.key = key_of(load_scene(args.scene, [*args.overrides, *lv.overrides]), petsc_args)
        except SceneError as exc:
            raise SceneError(f"level {lv.k} of --refine {lv.kind}: {exc}") from None
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise SceneError(f"--out {out}: {exc.strerror or exc}") from None
    # one run at a time on one process: all in this process, paying the imports and
    # loading the compiled forms once (rftfem/studies/batch.py); else each its own process
    in_process = args.executor == "local" and args.jobs == 1 and args.np == 1 and not args.processes
    executor = make_executor(
        args.executor,
        args.jobs,
        args.np,
        args.slurm,
        args.executor_config,
        args.print_job_script,
        in_process,
    )
    if executor is None:  # --print-job-script
        return 0
    console.out(
        f"rftfem study: {len(levels)} runs of {args.scene} "
        f"(refining {', '.join(kinds)}; {args.levels} levels) in {out}"
    )
    t0 = time.perf_counter()

    def one(lv: Level):
        run_level(lv, args.scene, args.overrides, executor, petsc_args, args.reuse)
        evaluate_level(lv, quantities)
        what = f"dt {lv.dt:.4g}" + (f", divisions {lv.divisions}" if lv.divisions else "")
        console.out(
            f"  {lv.folder.name}: {lv.status} ({what}"
            + (f", {lv.wall:.1f} s" if lv.wall is not None else "")
            + (f"; {lv.failure}" if lv.failure else "")
            + ")"
        )

    try:
        if in_process:  # in the main thread: gmsh and PETSc want it
            for lv in levels:
                one(lv)
        else:
            with ThreadPoolExecutor(max_workers=args.jobs) as pool:
                list(pool.map(one, levels))
    finally:
        executor.close()
    fluid = scene.get("fluid") or {}
    stokes = fluid.get("method", "layer") if fluid.get("model") == "stokes" else None
    rows = table_rows(plans, quantities, scene["time"]["scheme"], args.factor, stokes)
    command = " ".join(
        [
            "rftfem study",
            _quote(args.scene),
            *[f"--refine {k}" for k in kinds],
            f"--levels {args.levels}",
            *([f"--factor {args.factor:g}"] if args.factor != 2.0 else []),
            *[f"--quantity {_quote(q)}" for q in args.quantities],
            *map(_quote, as_arguments(args.overrides)),
        ]
        + ([f"--np {args.np}"] if args.np > 1 else [])
        + petsc_args
    )
    write_csv(rows, out / "study.csv")
    md = markdown(rows, command)
    (out / "study.md").write_text(md + "\n", encoding="utf-8")
    drawn = plot(rows, out / "study.png")
    console.out(md)
    report([(lv.note, lv.folder.name) for lv in levels], console, "study")
    failed = sum(lv.status != "ok" for lv in levels)
    console.err(
        f"rftfem study: {len(levels) - failed} of {len(levels)} runs ok in "
        f"{time.perf_counter() - t0:.0f} s; study.csv, study.md"
        + (", study.png" if drawn else "")
        + f" in {out}"
    )
    return 0


def _quote(arg: str) -> str:
    import shlex

    return shlex.quote(arg)


__all__ = [
    "main",
    "add_arguments",
    "plan",
    "analyse",
    "Level",
    "DESCRIPTION",
    "EPILOG",
    "KINDS",
    "SCHEME_ORDER",
]
