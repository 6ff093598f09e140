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
rftfem/studies/optimize_report.py's.
"""

from __future__ import annotations

import math
import shutil
import time
from pathlib import Path
from typing import TYPE_CHECKING

from rftfem.errors import SceneError
from rftfem.studies import executors
from rftfem.studies import objective as objectives
from rftfem.studies.executors import check_executor_options, make_executor
from rftfem.studies.optimize_evaluations import BudgetSpent, Evaluator, parse_vary
from rftfem.studies.optimize_report import plot, write_best
from rftfem.studies.reuse import report

if TYPE_CHECKING:
    import argparse
    from collections.abc import Sequence
    from typing import Any

METHODS = ("cobyla", "nelder-mead", "powell", "l-bfgs-b", "grid")
DEFAULT_METHOD = "cobyla"
DEFAULT_BUDGET = 40
#: the parameters' change (as a fraction of each interval) at which a method stops
X_TOLERANCE = 1e-3
#: the first steps of a method, as a fraction of each interval
FIRST_STEP = 0.25

DESCRIPTION = """\
Search scene parameters (--vary KEY=LO:HI) for the best value of an objective
written in the quantity language of `rftfem collect`, with optional constraints.
Every evaluation is an ordinary run folder; a failed run is recorded and
penalised. Writes optimize.csv (every evaluation), best.toml (the best scene,
ready to run) and optimize.png (objective and parameters against evaluation)."""

EPILOG = """\
objective and constraints: formulas (+ - * / ^, abs, sqrt, min, max, ...) of the
quantities of `rftfem collect`: COLUMN@TIME, rate(COLUMN, A, B), mean(...),
max(...), min(...), spin(PROBE_A, PROBE_B, AXIS, A, B), steady(NAME), and of
scene(KEY), a number of the run's scene (a design's cost)
methods: cobyla (default), nelder-mead, powell, l-bfgs-b, grid
examples:
  rftfem optimize demos/end_shear.toml --vary shell.thickness=0.05:0.2 \\
      --objective 'tip_uz@end + 0.4*scene(shell.thickness)' \\
      --set 'load.0.value=[0,0,0.004]' --set time.dt=1
  rftfem optimize demos/swimming_sheet.toml --vary motion.0.amplitude=0.05:0.3 \\
      --objective 'steady(front_ux_rate)' --maximize \\
      --constraint 'steady(drag_power)<=2e-5' --budget 20
  rftfem optimize demos/three_link_stroke.toml --vary motion.1.phase=-3:-0.15 \\
      --objective '-rate(centre_uy, 1, 3)/mean(drag_power, 1, 3)' --maximize
  rftfem optimize demos/thickness_design.toml --vary-field shell.thickness=0.05:0.2 \
      --constraint mass=start --maximize \
      --objective 'atan((tip_uz@end - back_uz@end)/(0.5 + tip_ux@end - back_ux@end))'
--vary-field: the values of a material field on its profile grid (the scene's
profile, or a strip's node lines) are the variables, with exact gradients
(static scenes); l-bfgs-b, or slsqp with constraints on mass or volume
(=, <=, >=; a number or 'start'); writes best-KEY.csv and best.toml reading it
exit status: 0 optimisation written (also when runs failed), 2 bad option or scene"""


# --- the methods -------------------------------------------------------------------


def search(method: str, ev: Evaluator, z0: Sequence[float], budget: int) -> str:
    """Run ``method`` from the unit point ``z0``; the reason it stopped."""
    import numpy as np
    from scipy import optimize

    n = len(z0)
    z0 = np.asarray(z0, float)
    bounds = [(0.0, 1.0)] * n
    try:
        if method == "grid":
            m = max(2, int(math.floor(budget ** (1.0 / n) + 1e-9)))
            axes = [np.linspace(0.0, 1.0, m)] * n
            grid = np.array(np.meshgrid(*axes, indexing="ij")).reshape(n, -1).T
            ev.merits(list(grid))
            return f"grid of {m}^{n} points evaluated"
        if method == "nelder-mead":
            simplex = [z0] + [
                z0 + np.eye(n)[j] * (FIRST_STEP if z0[j] + FIRST_STEP <= 1 else -FIRST_STEP)
                for j in range(n)
            ]
            res = optimize.minimize(
                ev.merit,
                z0,
                method="Nelder-Mead",
                bounds=bounds,
                options={
                    "initial_simplex": np.array(simplex),
                    "xatol": X_TOLERANCE,
                    "fatol": math.inf,
                    "maxfev": 10 * budget,
                },
            )
        elif method == "powell":
            res = optimize.minimize(
                ev.merit,
                z0,
                method="Powell",
                bounds=bounds,
                options={
                    "xtol": X_TOLERANCE,
                    "ftol": 1e-9,
                    "direc": np.eye(n) * FIRST_STEP,
                    "maxfev": 10 * budget,
                },
            )
        elif method == "cobyla":
            cons = [{"type": "ineq", "fun": lambda z, j=j: z[j]} for j in range(n)]
            cons += [{"type": "ineq", "fun": lambda z, j=j: 1.0 - z[j]} for j in range(n)]
            if ev.constraints:
                cons.append({"type": "ineq", "fun": ev.constraint_margins})
            objective = (lambda z: ev.sign * _value_or_merit(ev, z)) if ev.constraints else ev.merit
            # scipy's Fortran COBYLA calls back into Python and prints two lines of its
            # own when a callback raises: the stop (budget spent, a bad objective) is
            # kept instead, later calls return at once, and it is raised afterwards
            stop = _Stop()
            cons = [
                dict(c, fun=stop.guard(c["fun"], lambda z, k=k: [0.0] * k))
                for c, k in zip(cons, [1] * (2 * n) + [len(ev.constraints)])
            ]
            res = optimize.minimize(
                stop.guard(objective, lambda z: 0.0),
                z0,
                method="COBYLA",
                constraints=cons,
                options={"rhobeg": FIRST_STEP, "tol": X_TOLERANCE, "maxiter": 10 * budget},
            )
            stop.raise_kept()
        elif method == "l-bfgs-b":
            res = optimize.minimize(
                ev.merit_and_gradient,
                z0,
                jac=True,
                method="L-BFGS-B",
                bounds=bounds,
                options={"maxfun": 10 * budget, "ftol": 1e-12, "gtol": 1e-10},
            )
        else:  # guarded by the option check
            raise SceneError(f"--method: unknown method '{method}'")
    except BudgetSpent:
        return f"the budget of {budget} runs was spent"
    return f"{method} stopped: {' '.join(str(res.message).split())}"


class _Stop:
    """An exception raised by a callback, kept until the method returns."""

    def __init__(self):
        self.kept = None

    def guard(self, fun, fallback):
        def guarded(z):
            if self.kept is None:
                try:
                    return fun(z)
                except (BudgetSpent, SceneError) as exc:
                    self.kept = exc
            return fallback(z)

        return guarded

    def raise_kept(self):
        if self.kept is not None:
            raise self.kept


def _value_or_merit(ev: Evaluator, z) -> float:
    """COBYLA's objective with its constraints apart: the objective of a run (signed
    back by the caller), a failed run's merit otherwise."""
    e = ev.evaluate([z])[0]
    return e.objective if e.status in ("ok", "infeasible") else ev.sign * e.merit


# --- command line ------------------------------------------------------------------


def add_arguments(parser: argparse.ArgumentParser) -> None:
    import argparse

    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    parser.epilog = EPILOG
    parser.add_argument("scene", metavar="SCENE.toml", help="the scene file")
    parser.add_argument(
        "--vary",
        metavar="KEY=LO:HI",
        action="append",
        default=[],
        help="a scalar scene key and its interval (LO:HI:log for a log "
        "scale; load.0.value.1 for a component); repeatable",
    )
    parser.add_argument(
        "--vary-field",
        metavar="KEY=LO:HI",
        default=None,
        dest="vary_field",
        help="instead of --vary: the values of a material field (shell."
        "thickness, shell.E, shell.nu, shell.density) on its profile grid, "
        "each in [LO, HI], with exact gradients (static scenes); "
        "constraints 'mass=start', 'volume<=V'",
    )
    parser.add_argument(
        "--objective",
        metavar="EXPR",
        default=None,
        help="what to optimise: a formula of collect's quantities",
    )
    sense = parser.add_mutually_exclusive_group()
    sense.add_argument("--maximize", action="store_true", help="seek the largest objective")
    sense.add_argument(
        "--minimize", action="store_true", help="seek the smallest objective (the default)"
    )
    parser.add_argument(
        "--constraint",
        metavar="EXPR<=V",
        action="append",
        default=[],
        help="EXPR<=V or EXPR>=V, EXPR as the objective; repeatable",
    )
    parser.add_argument(
        "--method",
        metavar="NAME",
        default=None,
        help=f"{', '.join(METHODS)} (default {DEFAULT_METHOD}; with "
        "--vary-field l-bfgs-b, or slsqp with constraints)",
    )
    parser.add_argument(
        "--budget",
        metavar="N",
        type=int,
        default=DEFAULT_BUDGET,
        help=f"at most N runs (default {DEFAULT_BUDGET})",
    )
    # --set, --out, --jobs, --np, --reuse, --executor...
    executors.add_arguments(
        parser,
        "optimize",
        "evaluations",
        jobs_note=", where the method has several to make (grid; l-bfgs-b's differences)",
        reuse_note="; failed runs count as finished (resumes an optimisation)",
    )


def _method(name: str) -> str:
    m = name.strip().lower().replace("_", "-")
    m = {
        "nelder-mead": "nelder-mead",
        "neldermead": "nelder-mead",
        "lbfgsb": "l-bfgs-b",
        "brute": "grid",
    }.get(m, m)
    if m not in METHODS:
        raise SceneError(f"--method: unknown method '{name}' (expected {', '.join(METHODS)})")
    return m


def main(args: argparse.Namespace, petsc_args: list[str], console: Any) -> int:
    from rftfem.scene.reading import load_scene, resolved_scheme

    if args.vary_field is not None:
        from rftfem.studies.optimize_field_cli import main as field_main

        return field_main(args, petsc_args, console)
    if not args.vary:
        raise SceneError("--vary: give at least one KEY=LO:HI to search")
    if args.objective is None:
        raise SceneError(
            "--objective: give the quantity to optimise (e.g. --objective 'steady(front_ux_rate)')"
        )
    method = _method(args.method or DEFAULT_METHOD)
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
    static = resolved_scheme(scene) == "static"
    # gradients by the adjoint are taken in this process: with the local executor only
    gradients = (
        method == "l-bfgs-b"
        and static
        and args.np == 1
        and args.jobs == 1
        and args.executor == "local"
        and _differentiable(keys, objective, scene)
    )
    executor = make_executor(
        args.executor, args.jobs, args.np, args.slurm, args.executor_config, args.print_job_script
    )
    if executor is None:  # --print-job-script
        return 0
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
    sign = -1.0 if args.maximize else 1.0
    command = " ".join(
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
        return 0
    console.out(
        f"best: {best.folder.name}, objective {best.objective:.8g}"
        + ("" if best.status == "ok" else " (no evaluation met the constraints)")
        + "; "
        + ", ".join(f"{p.key} = {v:.8g}" for p, v in zip(params, best.x))
    )
    console.err(
        "rftfem optimize: optimize.csv, best.toml"
        + (", optimize.png" if drawn else "")
        + f" in {out}"
    )
    return 0


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
