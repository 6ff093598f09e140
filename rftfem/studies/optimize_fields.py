"""``rftfem optimize --vary-field KEY=LO:HI``: a design loop over a material field's
values, with exact gradients (rftfem/studies/field_gradients.py).

The variables are the values of the field's profile grid (rows X,Y,Z,value,
rftfem/scene/profiles.py), each bounded by [LO, HI]: the scene's own profile if
the key is one; else, on a strip mesh, a grid on the strip's node lines (its
divisions + 1 values of X, and of Y), started from the scene's number or formula
there.  Every evaluation is an ordinary static run in ``DIR/eval-NNNN`` whose key
reads that folder's ``KEY.csv``; its objective (a formula of one run quantity
the adjoint can differentiate, e.g. ``tip_uz@end``) comes with the gradient by
every grid value.

Built-in constraints, linear in the values: ``mass`` (∫ρt dA) and ``volume``
(∫t dA), as ``--constraint 'mass=start'`` (the start's value), ``'volume<=2.5'``,
``'mass>=V'``.  Without constraints the method is scipy's L-BFGS-B; with them SLSQP
(L-BFGS-B takes bounds only), both on the values mapped to [0, 1].

Written to DIR: optimize.csv (a row per evaluation: objective, mass, volume, the
gradient's norm), best-KEY.csv (the best feasible values) and best.toml (the scene
reading it), optimize.png (objective and the best field along X).
"""

from __future__ import annotations

import csv
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from rftfem.errors import SceneError
from rftfem.studies.optimize_field_design import (
    FieldConstraint,
    FieldDesign,
    parse_field_constraint,
    parse_vary_field,
)

if TYPE_CHECKING:
    import argparse
    from collections.abc import Callable
    from typing import Any

    from rftfem.outputs.formulas import Objective

__all__ = ["FieldDesign", "parse_vary_field", "parse_field_constraint", "optimize_field"]

#: relative change of the merit at which the methods stop
F_TOLERANCE = 1e-7


@dataclass
class _Evaluation:
    index: int
    folder: Path
    values: np.ndarray
    status: str = "failed"
    objective: float | None = None
    gradient: np.ndarray | None = None
    totals: dict = field(default_factory=dict)
    wall: float = 0.0
    failure: str = ""


class _Budget(Exception):
    pass


class _Runs:
    """The evaluations of a field search: a static run with the gradient by every grid
    value at each point the method asks for (once), a row of optimize.csv and a line
    each."""

    def __init__(
        self,
        args: argparse.Namespace,
        design: FieldDesign,
        texts: list[str],
        combine: object,
        constraints: list[FieldConstraint],
        out: Path,
        petsc_args: list[str],
        console: Any,
    ) -> None:
        self.args, self.design, self.texts, self.combine = args, design, texts, combine
        self.constraints, self.out, self.petsc_args = constraints, out, petsc_args
        self.console = console
        self.evaluations: list[_Evaluation] = []
        self.cache: dict[bytes, _Evaluation] = {}
        self.span = design.hi - design.lo
        self.handle = open(out / "optimize.csv", "w", encoding="utf-8", newline="")
        self.writer = csv.writer(self.handle, lineterminator="\n")
        self.writer.writerow(
            [
                "evaluation",
                "folder",
                "status",
                "objective",
                "mass",
                "volume",
                "gradient_norm",
                "wall_s",
                "failure",
            ]
        )

    def __call__(self, z: np.ndarray) -> _Evaluation:
        """The evaluation at the unit point ``z``, run if it is new; _Budget once the
        budget is spent."""
        values = self.design.lo + self.span * np.clip(np.asarray(z, float), 0.0, 1.0)
        tag = np.round(values, 12).tobytes()
        if tag in self.cache:
            return self.cache[tag]
        if len(self.evaluations) >= self.args.budget:
            raise _Budget
        ev = _Evaluation(
            len(self.evaluations) + 1, self.out / f"eval-{len(self.evaluations) + 1:04d}", values
        )
        self.evaluations.append(ev)
        self.cache[tag] = ev
        self._run(ev)
        self._write(ev)
        return ev

    def _run(self, ev: _Evaluation) -> None:
        """The run of the scene whose key reads the evaluation's KEY.csv, and its
        objective, gradient, mass and volume."""
        from rftfem.studies.gradient_runs import run_with_field_gradients

        design = self.design
        ev.folder.mkdir(parents=True, exist_ok=True)
        csv_file = (ev.folder / f"{design.name}.csv").resolve()
        design.write(ev.values, csv_file)
        t0 = time.perf_counter()
        status, J, grads = run_with_field_gradients(
            self.args.scene,
            [*self.args.overrides, f'{design.key}="{csv_file}"'],
            ev.folder,
            [design.key],
            self.texts,
            self.petsc_args,
            self.combine,
        )
        ev.wall = time.perf_counter() - t0
        if status == 0:
            g = grads[design.key]
            ev.status, ev.totals = "ok", dict(g.extra)
            ev.objective, ev.gradient = J, g.profile[1]
            if self.constraints and not _feasible(ev, self.constraints, self.evaluations[0]):
                ev.status = "infeasible"  # asked for by the method on its way
        else:
            ev.failure = f"exit status {status} (see {ev.folder.name}/run.log)"

    def _write(self, ev: _Evaluation) -> None:
        """The evaluation's row of optimize.csv and its line."""
        self.writer.writerow(
            [
                ev.index,
                ev.folder.name,
                ev.status,
                _num(ev.objective),
                _num(ev.totals.get("mass")),
                _num(ev.totals.get("volume")),
                _num(None if ev.gradient is None else float(np.linalg.norm(ev.gradient))),
                f"{ev.wall:.3f}",
                ev.failure,
            ]
        )
        self.handle.flush()
        self.console.out(
            f"  {ev.folder.name}: {ev.status}"
            + (
                f"  objective {ev.objective:.8g}  mass {ev.totals['mass']:.6g}  "
                f"volume {ev.totals['volume']:.6g}"
                if ev.objective is not None
                else f"; {ev.failure}"
            )
        )

    def close(self) -> None:
        self.handle.close()


def optimize_field(
    args: argparse.Namespace,
    design: FieldDesign,
    objective: Objective,
    constraints: list[FieldConstraint],
    sign: float,
    out: Path,
    petsc_args: list[str],
    console: Any,
) -> tuple[_Evaluation | None, str, list]:
    """Run the search; the best feasible evaluation, why it stopped, all evaluations."""
    from scipy import optimize

    texts, combine = run_quantities(objective)
    runs = _Runs(args, design, texts, combine, constraints, out, petsc_args, console)
    z0 = (design.start - design.lo) / runs.span
    first = runs(z0)
    if first.objective is None:
        runs.close()
        return None, "the start failed", runs.evaluations
    merit = _merit(runs, sign, max(abs(first.objective), 1e-300))
    cons = _constraint_functions(runs, first, z0)
    method = "SLSQP" if args.method == "slsqp" else "L-BFGS-B"
    bounds = [(0.0, 1.0)] * len(z0)
    try:
        if method == "SLSQP":
            res = optimize.minimize(
                merit,
                z0,
                jac=True,
                method=method,
                bounds=bounds,
                constraints=cons,
                options={"maxiter": args.budget, "ftol": F_TOLERANCE},
            )
        else:
            res = optimize.minimize(
                merit,
                z0,
                jac=True,
                method=method,
                bounds=bounds,
                options={"maxiter": args.budget, "ftol": F_TOLERANCE, "gtol": 1e-10},
            )
        why = f"{method}: {res.message}"
    except _Budget:
        why = f"{method}: the budget of {args.budget} runs is spent"
    runs.close()
    feasible = [e for e in runs.evaluations if e.status == "ok"]
    best = min(feasible, key=lambda e: sign * e.objective) if feasible else None
    return best, why, runs.evaluations


def _merit(
    runs: _Runs, sign: float, scale: float
) -> Callable[[np.ndarray], tuple[float, np.ndarray]]:
    """What the method minimises, with its gradient in the unit box: the signed
    objective over the start's size."""

    def merit(z):
        ev = runs(z)
        if ev.objective is None:  # a failed run: worse than any seen, the search steps back
            worst = (
                max(sign * e.objective for e in runs.evaluations if e.objective is not None) / scale
            )
            return worst + max(abs(worst), 1.0), np.zeros(len(z))
        return sign * ev.objective / scale, sign * ev.gradient * runs.span / scale

    return merit


def _constraint_functions(runs: _Runs, first: _Evaluation, z0: np.ndarray) -> list[dict]:
    """SLSQP's constraints (relative to each bound, a number or the start's value),
    linear in the values; a total that does not depend on the field is a SceneError."""
    cons = []
    for c in runs.constraints:
        start = first.totals[c.name]
        bound = start if c.bound is None else c.bound
        slope = _linear_slope(first, c.name, runs.span)  # linear: value(z0) + slope·(z − z0)
        if not np.any(slope):
            runs.close()
            raise SceneError(
                f"--constraint '{c.text}': the body's {c.name} does not depend "
                f"on {runs.design.key}" + (" (its density is 0)" if c.name == "mass" else "")
            )

        def fun(z, c=c, bound=bound, start=start, slope=slope):
            value = start + slope @ (np.asarray(z) - z0)
            return (bound - value if c.sense == "<=" else value - bound) / max(abs(bound), 1e-300)

        def jac(z, c=c, bound=bound, slope=slope):
            return (-slope if c.sense == "<=" else slope) / max(abs(bound), 1e-300)

        cons.append({"type": "eq" if c.sense == "=" else "ineq", "fun": fun, "jac": jac})
    return cons


def _linear_slope(ev: _Evaluation, name: str, span: float) -> np.ndarray:
    """d total / dz of mass or volume (linear in the values), carried by the run's
    field gradient."""
    return np.asarray(ev.totals[f"d_{name}"]) * span


def _feasible(ev, constraints, first, rtol: float = 1e-6) -> bool:
    for c in constraints:
        bound = first.totals[c.name] if c.bound is None else c.bound
        value, tol = ev.totals[c.name], rtol * max(abs(bound), 1e-300)
        if (
            (c.sense == "<=" and value > bound + tol)
            or (c.sense == ">=" and value < bound - tol)
            or (c.sense == "=" and abs(value - bound) > tol)
        ):
            return False
    return True


def run_quantities(objective: Objective) -> tuple[list[str], object]:
    """The objective's run quantities (texts for the adjoint, e.g. ``tip_uz@end``) and
    ``combine(values) -> (J, [∂J/∂value])``: the formula and its partial derivatives
    (central differences; ``scene(KEY)`` values are read from the scene once)."""
    from rftfem.studies.objective import SceneValue

    run = [i for i, q in enumerate(objective.quantities) if not isinstance(q, SceneValue)]
    if any(isinstance(q, SceneValue) for q in objective.quantities):
        raise SceneError(
            f"--objective '{objective.text}': with --vary-field write numbers, not scene(KEY)"
        )

    def combine(values):
        env = {f"q{i}": float(v) for i, v in zip(run, values)}
        value = float(objective.formula.numbers(env))
        # steps of 1e-6 of the quantities' common size (one of them may be 0)
        size = max([abs(float(v)) for v in values] + [1e-300])
        partials = []
        for i in run:
            v = env[f"q{i}"]
            h = 1e-6 * max(abs(v), size)
            up = float(objective.formula.numbers(dict(env, **{f"q{i}": v + h})))
            down = float(objective.formula.numbers(dict(env, **{f"q{i}": v - h})))
            partials.append((up - down) / (2 * h))
        return value, partials

    return [objective.quantities[i].text for i in run], combine


def _num(v) -> str:
    return "" if v is None else format(float(v), ".10g")
