"""``rftfem optimize``: a design loop of ordinary runs.

    rftfem optimize SCENE.toml --vary KEY=LO:HI [--vary ...] --objective EXPR
                    [--maximize | --minimize] [--constraint 'EXPR<=V' ...]
                    [--method NAME] [--budget N] [--jobs J | --np P] [--reuse]
                    [--set KEY=VALUE ...] [--out DIR]

``--vary-field KEY=LO:HI`` instead searches the values of a material field
(rftfem/studies/optimize_fields.py, docs/materials.md).

Each ``--vary`` is a scalar scene key (``shell.E``, ``magnetic.field.frequency``;
a component of a vector value as ``load.0.value.1``) and its interval; a
``:log`` suffix (``--vary shell.E=1e5:1e7:log``) searches it on a log scale.
The search starts from the scene's own values (the middle of an interval that
does not hold them).  The objective and constraints are formulas of the
quantities of ``rftfem collect`` (rftfem/studies/objective.py), read off each
evaluation's run folder.

Every evaluation is an ordinary run in ``DIR/eval-NNNN`` (``rftfem render``,
``rftfem collect`` work on it).  A failed run (a bad scene at those values, a
numerical failure, a quantity it has no data for) is recorded and given a value
worse than any seen, so the method turns away from it; it never ends the loop.
With ``--reuse`` an evaluation whose folder already holds a finished run (ok or
failed) of the same content (rftfem/studies/reuse.py: the completed scene, the
files it names, the PETSc options) is read, not run again: the methods are
deterministic, so an interrupted optimisation goes on where it stopped.

The methods are scipy.optimize's, on the parameters mapped to the unit box:
``cobyla`` (the default: the fewest runs to 1 % of the optimum on the demos,
benchmarks/optimize_methods.py; constraints handled as constraints),
``nelder-mead``, ``powell``, ``l-bfgs-b`` (gradients by the adjoint for static scenes whose
objective reads one quantity of the run besides scene() values, rftfem/studies/sensitivity.py;
else forward differences,
their runs side by side with ``--jobs``) and ``grid`` (a brute-force grid of the
budget's size, side by side with ``--jobs``).  For the other methods, a
constraint adds a penalty proportional to its relative violation.

Written to DIR: ``optimize.csv`` (a row per evaluation, written as it ends),
``best.toml`` (the best feasible evaluation's scene, ready for ``rftfem run``)
and ``optimize.png`` (the objective against the evaluation, and each
parameter's trace).

The evaluations (parameters, runs, scores, optimize.csv) are
rftfem/studies/optimize_evaluations.py's; best.toml and optimize.png are
rftfem/studies/optimize_report.py's; the methods rftfem/studies/optimize_methods.py's
and the options rftfem/studies/optimize_options.py's.
"""

from __future__ import annotations

import shutil
import time
from pathlib import Path
from typing import TYPE_CHECKING

from rftfem.errors import SceneError
from rftfem.studies import objective as objectives
from rftfem.studies.executors import check_executor_options, make_executor
from rftfem.studies.optimize_evaluations import Evaluator
from rftfem.studies.optimize_methods import METHODS, method_named, search
from rftfem.studies.optimize_options import (
    DEFAULT_BUDGET,  # noqa: F401
    DEFAULT_METHOD,
    DESCRIPTION,
    EPILOG,
    add_arguments,
)
from rftfem.studies.optimize_parameters import parse_vary
from rftfem.studies.optimize_report import plot, write_best
from rftfem.studies.reuse import report

if TYPE_CHECKING:
    import argparse
    from typing import Any

    from rftfem.outputs.formulas import Objective
    from rftfem.studies.executors import Executor
    from rftfem.studies.objective import Constraint
    from rftfem.studies.optimize_evaluations import Evaluation
    from rftfem.studies.optimize_parameters import Parameter

# --- command line ------------------------------------------------------------------


def main(args: argparse.Namespace, petsc_args: list[str], console: Any) -> int:
    if args.vary_field is not None:
        from rftfem.studies.optimize_field_cli import main as field_main

        return field_main(args, petsc_args, console)
    method, objective, constraints = _checked_options(args)
    scene, params = _parameters(args)
    keys = [p.key for p in params]
    gradients = _uses_adjoint(args, method, keys, objective, scene)
    executor = make_executor(
        args.executor, args.jobs, args.np, args.slurm, args.executor_config, args.print_job_script
    )
    if executor is None:  # --print-job-script
        return 0
    out = _out_folder(args, executor)
    sign = -1.0 if args.maximize else 1.0
    command = _command(args, method)
    _announce(args, method, keys, sign, gradients, out, console)
    ev = Evaluator(
        args.scene,
        args.overrides,
        params,
        objective,
        constraints,
        sign,
        out,
        args.budget,
        args.jobs,
        executor,
        args.reuse,
        petsc_args,
        console,
        gradients,
    )
    t0 = time.perf_counter()
    try:
        why = search(method, ev, [p.to_unit(p.start) for p in params], args.budget)
    finally:
        ev.close()
        executor.close()
        best = ev.best()
        if best is not None:
            write_best(ev, best, out / "best.toml", command)
        drawn = plot(
            ev, out / "optimize.png", command if len(command) < 110 else command[:107] + "..."
        )
    _report(ev, why, t0, best, drawn, out, console)
    return 0


def _checked_options(args: argparse.Namespace) -> tuple[str, Objective, list[Constraint]]:
    """The method, the objective and the constraints, the options checked."""
    if not args.vary:
        raise SceneError("--vary: give at least one KEY=LO:HI to search")
    if args.objective is None:
        raise SceneError(
            "--objective: give the quantity to optimise (e.g. --objective 'steady(front_ux_rate)')"
        )
    method = method_named(args.method or DEFAULT_METHOD)
    if args.budget < 1:
        raise SceneError(f"--budget: expected at least 1 run, found {args.budget}")
    check_executor_options(args.jobs, args.np, args.executor, "runs")
    objective = objectives.parse(args.objective)
    constraints = [objectives.parse_constraint(c) for c in args.constraint]
    if method == "l-bfgs-b" and constraints:
        raise SceneError(
            "--constraint: l-bfgs-b takes bounds only; use --method cobyla "
            "(or nelder-mead, powell with a penalty)"
        )
    return method, objective, constraints


def _parameters(args: argparse.Namespace) -> tuple[dict, list[Parameter]]:
    """The scene and the parameters of --vary, both ends of every interval checked."""
    from rftfem.scene.reading import load_scene

    scene = load_scene(args.scene, args.overrides)
    params = [parse_vary(v, scene) for v in args.vary]
    keys = [p.key for p in params]
    if len(set(keys)) < len(keys):
        raise SceneError("--vary: a key is given twice")
    for p in params:  # both ends of every interval must make a valid scene
        for x in (p.lo, p.hi):
            try:
                load_scene(args.scene, [*args.overrides, p.override(x)])
            except SceneError as exc:
                raise SceneError(f"--vary {p.key}={p.lo:g}:{p.hi:g}: at {x:g}: {exc}") from None
    return scene, params


def _uses_adjoint(
    args: argparse.Namespace, method: str, keys: list[str], objective: Objective, scene: dict
) -> bool:
    """Whether the runs give gradients by the adjoint: l-bfgs-b on a static scene whose
    objective can be differentiated."""
    from rftfem.scene.reading import resolved_scheme

    static = resolved_scheme(scene) == "static"
    # gradients by the adjoint are taken in this process: with the local executor only
    return (
        method == "l-bfgs-b"
        and static
        and args.np == 1
        and args.jobs == 1
        and args.executor == "local"
        and _differentiable(keys, objective, scene)
    )


def _out_folder(args: argparse.Namespace, executor: Executor) -> Path:
    """DIR made (the executor closed if it cannot be), without the evaluations of an
    earlier optimisation unless --reuse."""
    out = (
        args.out if args.out is not None else Path("results") / f"optimize-{Path(args.scene).stem}"
    )
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        executor.close()
        raise SceneError(f"--out {out}: {exc.strerror or exc}") from None
    if not args.reuse:
        for old in out.glob("eval-[0-9]*"):
            shutil.rmtree(old, ignore_errors=True)
    return out


def _command(args: argparse.Namespace, method: str) -> str:
    """The command line of this optimisation (best.toml's header, optimize.png's title)."""
    return " ".join(
        [
            "rftfem optimize",
            _quote(args.scene),
            *[f"--vary {_quote(v)}" for v in args.vary],
            f"--objective {_quote(args.objective)}",
            *(["--maximize"] if args.maximize else []),
            *[f"--constraint {_quote(c)}" for c in args.constraint],
            f"--method {method}",
            f"--budget {args.budget}",
            *[f"--set {_quote(o)}" for o in args.overrides],
        ]
    )


def _announce(
    args: argparse.Namespace,
    method: str,
    keys: list[str],
    sign: float,
    gradients: bool,
    out: Path,
    console: Any,
) -> None:
    """The line that says what is searched, and a note on --jobs a method cannot use."""
    console.out(
        f"rftfem optimize: {method} over {', '.join(keys)} "
        f"({'maximise' if sign < 0 else 'minimise'} {args.objective}; at most "
        f"{args.budget} runs{'; gradients by the adjoint' if gradients else ''}) in {out}"
    )
    if args.jobs > 1 and method in ("nelder-mead", "powell", "cobyla"):
        console.err(
            f"rftfem optimize: note: {method} makes one run at a time; --jobs "
            f"{args.jobs} has nothing to run side by side (grid and l-bfgs-b do)"
        )


def _report(
    ev: Evaluator,
    why: str,
    t0: float,
    best: Evaluation | None,
    drawn: bool,
    out: Path,
    console: Any,
) -> None:
    """Why the search stopped, its runs (failed, reused) and time, the best evaluation
    and the files written."""
    report([(e.note, e.folder.name) for e in ev.evaluations], console, "optimize")
    n_failed = sum(e.status == "failed" for e in ev.evaluations)
    n_reused = sum(e.reused for e in ev.evaluations)
    console.out(
        f"rftfem optimize: {why}; {len(ev.evaluations)} runs"
        + (f" ({n_failed} failed)" if n_failed else "")
        + (f" ({n_reused} reused)" if n_reused else "")
        + f" in {time.perf_counter() - t0:.0f} s"
    )
    if best is None:
        console.err(f"rftfem optimize: no run succeeded; optimize.csv in {out}")
        return
    console.out(
        f"best: {best.folder.name}, objective {best.objective:.8g}"
        + ("" if best.status == "ok" else " (no evaluation met the constraints)")
        + "; "
        + ", ".join(f"{p.key} = {v:.8g}" for p, v in zip(ev.params, best.x))
    )
    console.err(
        "rftfem optimize: optimize.csv, best.toml"
        + (", optimize.png" if drawn else "")
        + f" in {out}"
    )


def _differentiable(keys: list[str], objective, scene: dict) -> bool:
    """Whether rftfem/studies/sensitivity.py can differentiate the objective's one run quantity
    by these keys in this scene."""
    from rftfem.studies.optimize_evaluations import adjoint_quantity
    from rftfem.studies.sensitivity_request import supports

    quantity = adjoint_quantity(objective)
    return quantity is not None and supports(keys, quantity.text, scene)


def _quote(arg: str) -> str:
    import shlex

    return shlex.quote(arg)


__all__ = ["main", "add_arguments", "search", "METHODS", "DEFAULT_METHOD", "DESCRIPTION", "EPILOG"]
