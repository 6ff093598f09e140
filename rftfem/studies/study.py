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

import math
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import TYPE_CHECKING

from rftfem.errors import SceneError
from rftfem.studies import executors
from rftfem.studies.executors import check_executor_options, make_executor
from rftfem.studies.reuse import key_of, report
from rftfem.studies.study_levels import Level, evaluate_level, plan, run_level
from rftfem.studies.study_report import SCHEME_ORDER, analyse, markdown, plot, table_rows, write_csv

if TYPE_CHECKING:
    import argparse
    from collections.abc import Sequence
    from typing import Any

    from rftfem.outputs.formulas import Objective

KINDS = ("dt", "mesh", "mesh.x", "mesh.y", "both", "fluid")

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
    quantities, kinds = _options(args)
    scene = _scene(args)
    out = args.out if args.out is not None else Path("results") / f"study-{Path(args.scene).stem}"
    plans = plan(scene, kinds, args.levels, out, args.factor)
    levels = list({id(lv): lv for series in plans.values() for lv in series}.values())
    _check_levels(levels, args, petsc_args)
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
    _run_levels(levels, args, executor, petsc_args, quantities, console, in_process)
    rows = table_rows(plans, quantities, scene["time"]["scheme"], args.factor, _stokes(scene))
    _write_study(rows, _command(args, kinds, petsc_args), levels, out, console, t0)
    return 0


def _options(args: argparse.Namespace) -> tuple[list[tuple[str, Objective]], list[str]]:
    """The quantities and kinds of the command line, and its numbers checked."""
    from rftfem.outputs.collect import parse_option

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
    return quantities, kinds


def _scene(args: argparse.Namespace) -> dict:
    """The scene with its overrides, its time scheme resolved."""
    from rftfem.scene.reading import load_scene, resolved_scheme

    scene = load_scene(args.scene, args.overrides)
    scene["time"]["scheme"] = resolved_scheme(scene)
    return scene


def _check_levels(levels: list[Level], args: argparse.Namespace, petsc_args: list[str]) -> None:
    """Every level's scene must be valid before anything runs; its key for --reuse."""
    from rftfem.scene.reading import load_scene

    for lv in levels:
        try:
            lv.key = key_of(load_scene(args.scene, [*args.overrides, *lv.overrides]), petsc_args)
        except SceneError as exc:
            raise SceneError(f"level {lv.k} of --refine {lv.kind}: {exc}") from None


def _run_levels(
    levels: list[Level],
    args: argparse.Namespace,
    executor: executors.Executor,
    petsc_args: list[str],
    quantities: Sequence[tuple[str, Objective]],
    console: Any,
    in_process: bool,
) -> None:
    """Run and evaluate every level, a line each; the executor is closed after."""

    def one(lv: Level) -> None:
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


def _stokes(scene: dict) -> str | None:
    """The Stokes method (it sets the mesh kinds' nominal order), None for another liquid."""
    fluid = scene.get("fluid") or {}
    return fluid.get("method", "layer") if fluid.get("model") == "stokes" else None


def _write_study(
    rows: list[dict],
    command: str,
    levels: list[Level],
    out: Path,
    console: Any,
    t0: float,
) -> None:
    """study.csv, study.md and study.png, the tables on the console and the count."""
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


def _command(args: argparse.Namespace, kinds: list[str], petsc_args: list[str]) -> str:
    """The command line that makes this study again, for study.md."""
    from rftfem.scene.overrides import as_arguments

    return " ".join(
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
