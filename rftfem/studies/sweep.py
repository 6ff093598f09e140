"""``rftfem sweep``: a scene over a grid of values of any keys, run by an executor.

    rftfem sweep SCENE --vary KEY=v1,v2,... --vary KEY=LO:HI:N[:log] ...
                 --quantity NAME=EXPR ... [--executor E] [--jobs J] [--np P]
                 [--reuse] [--out DIR] [--set KEY=VALUE ...]

Every combination of the varied values is an ordinary run folder in ``--out``
(default ``results/sweep-<scene stem>``), named by its values. The quantities
(collect's language) are read from each finished run. ``sweep.csv`` has a row
per combination: the varied keys first, then ``status`` and the quantities,
then the folder, the wall time and, for a run that failed, why. ``sweep.png``
draws the quantities: a line against the key for one varied key, a heat map
for two numeric ones, small multiples beyond (rftfem/studies/sweep_report.py).

Every combination's scene is checked before anything runs. ``--reuse`` keeps
the runs a folder already holds finished from the same content (the completed
scene, the files it names, the PETSc options: :mod:`rftfem.studies.reuse`), so a
sweep cut short runs only what is missing, and an edited scene or profile runs
again what it changes. The executors are those of :mod:`rftfem.studies.executors`.
"""

from __future__ import annotations

import csv
import itertools
import math
import re
import shlex
import shutil
import sys
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from rftfem.errors import SceneError
from rftfem.studies import executors
from rftfem.studies.sweep_vary import Vary, parse_vary

if TYPE_CHECKING:
    import argparse
    from collections.abc import Callable, Sequence
    from typing import Any

    from rftfem.outputs.formulas import Objective

DESCRIPTION = (
    "Run a scene over a grid of values of any keys (every combination of the "
    "--vary lists and ranges, each an ordinary run folder); write sweep.csv "
    "(the varied keys, status, the quantities) and sweep.png."
)
EPILOG = """examples:
  rftfem sweep demos/swimming_sheet.toml --vary motion.0.amplitude=0.05,0.1,0.15 \\
      --quantity 'U=steady(front_ux_rate)'
  rftfem sweep demos/bidirectional_strip.toml --vary magnetic.field.frequency=2:8:4 \\
      --vary magnetic.field.strength=1e-5:4e-5:3:log \\
      --quantity 'speed=rate(centroid_z, 1.1, 2.1)' --executor dask --jobs 2

exit status: 0 the sweep ran (failed runs are rows of sweep.csv), 2 bad option or scene"""

#: most combinations a sweep may have (a typo in N should not start a million runs)
MAX_RUNS = 10_000


@dataclass
class Point:
    """One combination: its values, folder and what became of its run."""

    index: int
    values: tuple
    folder: Path
    overrides: list[str]
    status: str = "pending"
    exit_status: int | None = None
    wall: float | None = None
    reason: str = ""
    quantities: dict = field(default_factory=dict)
    key: dict | None = None  # what --reuse compares (rftfem/studies/reuse.py)
    note: str = ""  # why a finished run was not reused, or not keyed


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.epilog = EPILOG
    parser.formatter_class = __import__("argparse").RawDescriptionHelpFormatter
    parser.add_argument("scene", metavar="SCENE.toml", help="the scene file")
    parser.add_argument(
        "--vary",
        metavar="KEY=VALUES",
        action="append",
        default=[],
        help="a key and its values: v1,v2,... (TOML values) or LO:HI:N "
        "(N numbers from LO to HI, evenly; LO:HI:N:log, geometrically); "
        "repeatable: every combination runs",
    )
    parser.add_argument(
        "--quantity",
        metavar="NAME=EXPR",
        action="append",
        default=[],
        dest="quantities",
        help="a column of sweep.csv from each run (collect's quantity "
        "language, e.g. 'U=steady(front_ux_rate)'); repeatable",
    )
    executors.add_arguments(parser, "sweep")  # --set, --out, --jobs, --reuse, ...


# ------------------------------------------------------------------ the grid


def _text(value) -> str:
    from rftfem.scene import toml_writer

    return toml_writer.value(value)


def _name(value) -> str:
    text = f"{value:.6g}" if isinstance(value, float) else str(value)
    return re.sub(r"[^\w.+\-]", "", text.replace(",", "_")) or "x"


def grid(varies: list[Vary], out: Path, overrides: list[str]) -> list[Point]:
    points = []
    for i, values in enumerate(itertools.product(*[v.values for v in varies])):
        label = "_".join(f"{v.key.split('.')[-1]}={_name(x)}" for v, x in zip(varies, values))
        sets = [f"{v.key}={_text(x)}" for v, x in zip(varies, values)]
        points.append(Point(i, values, out / f"{i + 1:04d}_{label}"[:120], [*overrides, *sets]))
    return points


# ------------------------------------------------------------------ running


class _Progress:
    """One line: redrawn in place on a terminal, else printed at most every 30 s."""

    def __init__(self, total: int, console):
        self.total, self.console, self.t0 = total, console, time.perf_counter()
        self.done = self.failed = self.reused = 0
        self.tty = sys.stdout.isatty()
        self.last = 0.0
        self.lock = threading.Lock()

    def finished(self, point: Point):
        with self.lock:
            self.done += 1
            self.failed += point.status == "failed"
            self.reused += point.status.startswith("reused")
            line = (
                f"rftfem sweep: {self.done}/{self.total} runs done"
                + (f", {self.failed} failed" if self.failed else "")
                + (f", {self.reused} reused" if self.reused else "")
                + f", {time.perf_counter() - self.t0:.0f} s"
            )
            now = time.perf_counter()
            if self.tty:
                sys.stdout.write("\r\033[K" + line + ("\n" if self.done == self.total else ""))
                sys.stdout.flush()
            elif now - self.last > 30 or self.done == self.total:
                self.console.out(line)
                self.last = now


def run_point(
    point: Point,
    scene_file: str | Path,
    executor: executors.Executor,
    petsc_args: list[str],
    reuse: bool,
    quantities: Sequence[tuple[str, Objective]],
) -> None:
    from rftfem.studies.batch import failure_reason
    from rftfem.studies.reuse import keep_key, reused

    t0 = time.perf_counter()
    kept, point.note = reused(point.folder, point.key, reuse)
    if kept:
        point.status = "reused"
    else:
        if point.folder.exists():
            shutil.rmtree(point.folder)
        point.folder.mkdir(parents=True)
        point.exit_status = executor.run(scene_file, point.overrides, point.folder, petsc_args)
        point.status = "ok" if point.exit_status == 0 else "failed"
        if point.exit_status != 0:
            point.reason = failure_reason(point.folder / "run.log", point.exit_status)
        else:
            point.note = (
                keep_key(point.folder, point.key, scene_file, point.overrides, petsc_args, "sweep")
                or point.note
            )
    point.wall = time.perf_counter() - t0
    if point.status != "failed":
        _read_quantities(point, quantities)


def _read_quantities(point: Point, quantities) -> None:
    from rftfem.outputs.quantities import RunFolder, Unavailable

    run = RunFolder(point.folder)
    missing = False
    for name, quantity in quantities:
        try:
            point.quantities[name] = quantity.evaluate(run)
        except (Unavailable, SceneError) as exc:
            point.quantities[name] = None
            point.reason = (point.reason + "; " if point.reason else "") + f"{name}: {exc}"
            missing = True
    if missing:  # the run is fine, its row is not: say so in the status column
        point.status += ", quantity missing"


def write_csv(points: list[Point], varies: list[Vary], names: list[str], path: Path) -> None:
    with open(path, "w", encoding="utf-8", newline="") as fh:
        writer = csv.writer(fh, lineterminator="\n")
        writer.writerow([v.key for v in varies] + ["status", *names, "folder", "wall_s", "reason"])
        for p in points:
            q = [
                ("" if p.quantities.get(n) is None else repr(float(p.quantities[n]))) for n in names
            ]
            writer.writerow(
                [_cell(x) for x in p.values]
                + [p.status, *q, p.folder.name, "" if p.wall is None else f"{p.wall:.2f}", p.reason]
            )


def _cell(value) -> str:
    return (
        repr(value)
        if isinstance(value, float)
        else (_text(value) if not isinstance(value, str) else value)
    )


def main(args: argparse.Namespace, petsc_args: list[str], console: Any) -> int:
    if not args.vary:
        raise SceneError("--vary: give at least one key to vary (e.g. --vary shell.E=1e5,2e5)")
    executors.check_executor_options(args.jobs, args.np, args.executor, "runs")
    varies, quantities, out, points = _combinations(args, petsc_args)
    names = [n for n, _ in quantities]
    executor = executors.make_executor(
        args.executor, args.jobs, args.np, args.slurm, args.executor_config, args.print_job_script
    )
    if executor is None:  # --print-job-script
        return 0
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        executor.close()
        raise SceneError(f"--out {out}: {exc.strerror or exc}") from None
    console.out(
        f"rftfem sweep: {len(points)} runs of {args.scene} in {out}, executor {executor.describe()}"
    )
    progress = _Progress(len(points), console)

    def table() -> None:
        write_csv(points, varies, names, out / "sweep.csv")

    t0 = time.perf_counter()
    _run_points(points, args, executor, petsc_args, quantities, progress, table)
    _report(points, varies, names, out, args, console, t0)
    return 0


def _combinations(
    args: argparse.Namespace, petsc_args: list[str]
) -> tuple[list[Vary], list[tuple[str, Objective]], Path, list[Point]]:
    """The varied keys, the quantities, the folder and every combination, each a
    valid scene (with its key for --reuse) before anything runs."""
    from rftfem.outputs.collect import parse_option
    from rftfem.scene.reading import load_scene
    from rftfem.studies.reuse import key_of

    scene = load_scene(args.scene, args.overrides)
    varies = [parse_vary(v, scene) for v in args.vary]
    keys = [v.key for v in varies]
    if len(set(keys)) < len(keys):
        raise SceneError("--vary: a key is given twice")
    quantities = [parse_option(q) for q in args.quantities]
    names = [n for n, _ in quantities]
    if len(set(names)) < len(names):
        raise SceneError("--quantity: a name is given twice")
    count = math.prod(len(v.values) for v in varies)
    if count > MAX_RUNS:
        raise SceneError(f"--vary: {count} combinations, more than {MAX_RUNS}")
    out = args.out if args.out is not None else Path("results") / f"sweep-{Path(args.scene).stem}"
    points = grid(varies, out, args.overrides)
    for p in points:  # every combination is a valid scene before anything runs
        try:
            p.key = key_of(load_scene(args.scene, p.overrides), petsc_args)
        except SceneError as exc:
            raise SceneError(f"run {p.folder.name}: {exc}") from None
    return varies, quantities, out, points


def _run_points(
    points: list[Point],
    args: argparse.Namespace,
    executor: executors.Executor,
    petsc_args: list[str],
    quantities: Sequence[tuple[str, Objective]],
    progress: _Progress,
    table: Callable[[], None],
) -> None:
    """Run every point, ``table`` (sweep.csv) written after each; the executor is
    closed after."""

    def one(p: Point) -> None:
        try:
            run_point(p, args.scene, executor, petsc_args, args.reuse, quantities)
        except Exception as exc:  # the engine failed this run: a row, not a crash
            p.status, p.reason = "failed", f"{exc.__class__.__name__}: {exc}"[:300]
        progress.finished(p)
        table()  # what is known so far

    try:
        local_here = isinstance(executor, executors.LocalExecutor) and executor.in_process
        if local_here:  # gmsh and PETSc want the main thread
            for p in points:
                one(p)
        else:
            with ThreadPoolExecutor(max_workers=max(1, args.jobs)) as pool:
                list(pool.map(one, points))
    finally:
        executor.close()
        table()


def _report(
    points: list[Point],
    varies: list[Vary],
    names: list[str],
    out: Path,
    args: argparse.Namespace,
    console: Any,
    t0: float,
) -> None:
    """sweep.png, command.txt and what the console is told of the runs."""
    from rftfem.studies import sweep_report
    from rftfem.studies.reuse import report

    drawn = sweep_report.plot(points, varies, names, out / "sweep.png", args.scene)
    (out / "command.txt").write_text(_command(args) + "\n", encoding="utf-8")
    failed = sum(p.status == "failed" for p in points)
    report([(p.note, p.folder.name) for p in points], console, "sweep")
    missing = [p for p in points if p.status.endswith("quantity missing")]
    if missing:
        console.err(
            f"rftfem sweep: {len(missing)} run(s) ok without every quantity "
            f"(status 'quantity missing'), the first in {missing[0].folder.name}: "
            f"{missing[0].reason}"
        )
    console.err(
        f"rftfem sweep: {len(points) - failed} of {len(points)} runs ok in "
        f"{time.perf_counter() - t0:.0f} s; sweep.csv"
        + (", sweep.png" if drawn else "")
        + f" in {out}"
    )


def _command(args: argparse.Namespace) -> str:
    """The command line that makes this sweep again, for command.txt."""
    from rftfem.scene.overrides import as_arguments

    return " ".join(
        [
            "rftfem sweep",
            shlex.quote(args.scene),
            *[f"--vary {shlex.quote(v)}" for v in args.vary],
            *[f"--quantity {shlex.quote(q)}" for q in args.quantities],
            *map(shlex.quote, as_arguments(args.overrides)),
        ]
    )


__all__ = ["main", "add_arguments", "parse_vary", "grid", "Vary", "Point", "DESCRIPTION"]
