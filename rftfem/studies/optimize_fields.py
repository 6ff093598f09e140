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
import math
import re
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from rftfem.errors import SceneError

if TYPE_CHECKING:
    import argparse
    from typing import Any

    from rftfem.outputs.formulas import Objective

__all__ = ["FieldDesign", "parse_vary_field", "parse_field_constraint", "optimize_field"]

#: relative change of the merit at which the methods stop
F_TOLERANCE = 1e-7


@dataclass
class FieldDesign:
    """One ``--vary-field KEY=LO:HI``: the grid, the start values and the bounds."""

    key: str
    lo: float
    hi: float
    points: np.ndarray
    start: np.ndarray

    @property
    def name(self) -> str:
        return self.key.split(".")[-1]

    def write(self, values: np.ndarray, path: Path) -> None:
        rows = "\n".join(
            f"{p[0]!r},{p[1]!r},{p[2]!r},{float(v)!r}" for p, v in zip(self.points.tolist(), values)
        )
        path.write_text(f"X,Y,Z,{self.name}\n{rows}\n", encoding="utf-8")


@dataclass
class FieldConstraint:
    text: str
    name: str  # mass or volume
    sense: str  # <=, >= or =
    bound: float | None  # None: the start's value


def parse_vary_field(text: str, scene: dict) -> FieldDesign:
    from rftfem.scene.fields import field_values, profile_file
    from rftfem.scene.profiles import read_profile
    from rftfem.studies.field_gradients import FIELD_KEYS

    key, sep, rng = text.partition("=")
    key = key.strip()
    bits = [b.strip() for b in rng.split(":")]
    if not sep or len(bits) != 2:
        raise SceneError(
            f"--vary-field '{text}': expected KEY=LO:HI (e.g. shell.thickness=0.05:0.2)"
        )
    if (
        key not in FIELD_KEYS
        or key in ("shell.E", "shell.nu")
        and scene["shell"]["material"] == "orthotropic"
    ):
        raise SceneError(
            f"--vary-field '{text}': expected one of {', '.join(FIELD_KEYS)} "
            "(E and nu of an isotropic shell)"
        )
    try:
        lo, hi = float(bits[0]), float(bits[1])
    except ValueError:
        raise SceneError(f"--vary-field '{text}': expected numbers LO and HI") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
        raise SceneError(f"--vary-field '{text}': expected finite LO < HI")
    value = scene["shell"][key.split(".")[-1]]
    if isinstance(value, dict):
        points, values = read_profile(
            profile_file(scene, value["profile"]), f"{key}.profile", columns=1, names="value"
        )
        start = values[:, 0]
    else:
        mesh = scene["mesh"]
        if mesh["kind"] != "strip":
            raise SceneError(
                f"--vary-field {key}: the mesh is not a strip; give {key} as a "
                'profile ({ profile = "file.csv" }): its grid values are the '
                "design's variables"
            )
        nx, ny = mesh["divisions"]
        X, Y = np.linspace(0.0, mesh["length"], nx + 1), np.linspace(0.0, mesh["width"], ny + 1)
        points = np.array([[x, y, 0.0] for y in Y for x in X])
        start = field_values(scene, value, points, key)
    return FieldDesign(key, lo, hi, points, np.clip(start, lo, hi))


def parse_field_constraint(text: str) -> FieldConstraint:
    m = re.fullmatch(r"\s*(mass|volume)\s*(<=|>=|==|=)\s*(\S+)\s*", text)
    if m is None:
        raise SceneError(
            f"--constraint '{text}': with --vary-field expected mass or volume, "
            "=, <= or >=, and a number or 'start' (e.g. 'mass=start')"
        )
    bound = None
    if m[3] != "start":
        try:
            bound = float(m[3])
        except ValueError:
            raise SceneError(
                f"--constraint '{text}': expected a number or 'start' after '{m[2]}'"
            ) from None
    return FieldConstraint(text, m[1], "=" if m[2] in ("=", "==") else m[2], bound)


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

    from rftfem.studies.gradient_runs import run_with_field_gradients

    texts, combine = run_quantities(objective)
    evaluations: list[_Evaluation] = []
    cache: dict[bytes, _Evaluation] = {}
    span = design.hi - design.lo
    handle = open(out / "optimize.csv", "w", encoding="utf-8", newline="")
    writer = csv.writer(handle, lineterminator="\n")
    writer.writerow(
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

    def run(z) -> _Evaluation:
        values = design.lo + span * np.clip(np.asarray(z, float), 0.0, 1.0)
        tag = np.round(values, 12).tobytes()
        if tag in cache:
            return cache[tag]
        if len(evaluations) >= args.budget:
            raise _Budget
        ev = _Evaluation(len(evaluations) + 1, out / f"eval-{len(evaluations) + 1:04d}", values)
        evaluations.append(ev)
        cache[tag] = ev
        ev.folder.mkdir(parents=True, exist_ok=True)
        csv_file = (ev.folder / f"{design.name}.csv").resolve()
        design.write(values, csv_file)
        t0 = time.perf_counter()
        status, J, grads = run_with_field_gradients(
            args.scene,
            [*args.overrides, f'{design.key}="{csv_file}"'],
            ev.folder,
            [design.key],
            texts,
            petsc_args,
            combine,
        )
        ev.wall = time.perf_counter() - t0
        if status == 0:
            g = grads[design.key]
            ev.status, ev.totals = "ok", dict(g.extra)
            ev.objective, ev.gradient = J, g.profile[1]
            if constraints and not _feasible(ev, constraints, evaluations[0]):
                ev.status = "infeasible"  # asked for by the method on its way
        else:
            ev.failure = f"exit status {status} (see {ev.folder.name}/run.log)"
        writer.writerow(
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
        handle.flush()
        console.out(
            f"  {ev.folder.name}: {ev.status}"
            + (
                f"  objective {ev.objective:.8g}  mass {ev.totals['mass']:.6g}  "
                f"volume {ev.totals['volume']:.6g}"
                if ev.objective is not None
                else f"; {ev.failure}"
            )
        )
        return ev

    z0 = (design.start - design.lo) / span
    first = run(z0)
    if first.objective is None:
        handle.close()
        return None, "the start failed", evaluations
    scale = max(abs(first.objective), 1e-300)

    def merit(z):
        ev = run(z)
        if ev.objective is None:  # a failed run: worse than any seen, the search steps back
            worst = max(sign * e.objective for e in evaluations if e.objective is not None) / scale
            return worst + max(abs(worst), 1.0), np.zeros(len(z))
        return sign * ev.objective / scale, sign * ev.gradient * span / scale

    cons = []
    for c in constraints:
        start = first.totals[c.name]
        bound = start if c.bound is None else c.bound
        slope = _linear_slope(first, c.name, span)  # linear: value(z0) + slope·(z − z0)
        if not np.any(slope):
            handle.close()
            raise SceneError(
                f"--constraint '{c.text}': the body's {c.name} does not depend "
                f"on {design.key}" + (" (its density is 0)" if c.name == "mass" else "")
            )

        def fun(z, c=c, bound=bound, start=start, slope=slope):
            value = start + slope @ (np.asarray(z) - z0)
            return (bound - value if c.sense == "<=" else value - bound) / max(abs(bound), 1e-300)

        def jac(z, c=c, bound=bound, slope=slope):
            return (-slope if c.sense == "<=" else slope) / max(abs(bound), 1e-300)

        cons.append({"type": "eq" if c.sense == "=" else "ineq", "fun": fun, "jac": jac})
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
    handle.close()
    feasible = [e for e in evaluations if e.status == "ok"]
    best = min(feasible, key=lambda e: sign * e.objective) if feasible else None
    return best, why, evaluations


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
