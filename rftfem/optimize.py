"""``rftfem optimize``: a design loop of ordinary runs.

    rftfem optimize SCENE.toml --vary KEY=LO:HI [--vary ...] --objective EXPR
                    [--maximize | --minimize] [--constraint 'EXPR<=V' ...]
                    [--method NAME] [--budget N] [--jobs J | --np P] [--reuse]
                    [--set KEY=VALUE ...] [--out DIR]

Each ``--vary`` is a scalar scene key (``shell.E``, ``magnetic.field.frequency``;
a component of a vector value as ``load.0.value.1``) and its interval; a
``:log`` suffix (``--vary shell.E=1e5:1e7:log``) searches it on a log scale.
The search starts from the scene's own values (the middle of an interval that
does not hold them).  The objective and constraints are formulas of the
quantities of ``rftfem collect`` (rftfem/objective.py), read off each
evaluation's run folder.

Every evaluation is an ordinary run in ``DIR/eval-NNNN`` (``rftfem render``,
``rftfem collect`` work on it).  A failed run (a bad scene at those values, a
numerical failure, a quantity it has no data for) is recorded and given a value
worse than any seen, so the method turns away from it; it never ends the loop.
With ``--reuse`` an evaluation whose folder already holds a finished run of the
same overrides is read, not run again: the methods are deterministic, so an
interrupted optimisation goes on where it stopped.

The methods are scipy.optimize's, on the parameters mapped to the unit box:
``nelder-mead`` (the default), ``powell``, ``cobyla`` (constraints handled as
constraints), ``l-bfgs-b`` (gradients by the adjoint for static scenes whose
objective is one quantity, rftfem/sensitivity.py; else forward differences,
their runs side by side with ``--jobs``) and ``grid`` (a brute-force grid of the
budget's size, side by side with ``--jobs``).  For the other methods, a
constraint adds a penalty proportional to its relative violation.

Written to DIR: ``optimize.csv`` (a row per evaluation, written as it ends),
``best.toml`` (the best feasible evaluation's scene, ready for ``rftfem run``)
and ``optimize.png`` (the objective against the evaluation, and each
parameter's trace).
"""

from __future__ import annotations

import csv
import json
import math
import re
import shutil
import time
import tomllib
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

from rftfem import objective as objectives
from rftfem import toml_writer
from rftfem.batch import failure_reason, launcher, run_child, run_here
from rftfem.errors import SceneError

METHODS = ("nelder-mead", "powell", "cobyla", "l-bfgs-b", "grid")
DEFAULT_METHOD = "nelder-mead"
DEFAULT_BUDGET = 40
#: the parameters' change (as a fraction of each interval) at which a method stops
X_TOLERANCE = 1e-3
#: the first steps of a method, as a fraction of each interval
FIRST_STEP = 0.25
#: forward-difference step of l-bfgs-b without an adjoint, a fraction of each interval
FD_STEP = 1e-3

DESCRIPTION = """\
Search scene parameters (--vary KEY=LO:HI) for the best value of an objective
written in the quantity language of `rftfem collect`, with optional constraints.
Every evaluation is an ordinary run folder; a failed run is recorded and
penalised. Writes optimize.csv (every evaluation), best.toml (the best scene,
ready to run) and optimize.png (objective and parameters against evaluation)."""

EPILOG = """\
objective and constraints: formulas (+ - * / ^, abs, sqrt, min, max, ...) of the
quantities of `rftfem collect`: COLUMN@TIME, rate(COLUMN, A, B), mean(...),
max(...), min(...), spin(PROBE_A, PROBE_B, AXIS, A, B), steady(NAME).
methods: nelder-mead (default), powell, cobyla, l-bfgs-b, grid
examples:
  rftfem optimize demos/rollup.toml --vary shell.E=5e5:5e6:log \\
      --objective 'abs(tip_uz@end - 3)' --budget 25
  rftfem optimize demos/swimming_sheet.toml --vary motion.0.wavenumber=0.2:1.5 \\
      --objective 'steady(front_ux_rate)' --maximize \\
      --constraint 'steady(drag_power)<=1e-3' --method cobyla
exit status: 0 optimisation written (also when runs failed), 2 bad option or scene"""


class BudgetSpent(Exception):
    """The budget of runs is used up: the method stops with the best so far."""


# --- the parameters ----------------------------------------------------------------


@dataclass
class Parameter:
    """One ``--vary KEY=LO:HI[:log]``: the key, its interval and its scene value."""

    key: str
    lo: float
    hi: float
    log: bool
    set_key: str            # the key of --set (the vector's for a component)
    index: int | None       # the component, or None
    vector: list | None     # the scene's vector (for a component)
    start: float

    def from_unit(self, z: float) -> float:
        z = min(1.0, max(0.0, float(z)))
        if z == self.to_unit(self.start):  # the scene's own value, not a round trip
            return self.start
        if self.log:
            return math.exp(math.log(self.lo) + z * (math.log(self.hi) - math.log(self.lo)))
        return self.lo + z * (self.hi - self.lo)

    def to_unit(self, x: float) -> float:
        if self.log:
            return (math.log(x) - math.log(self.lo)) / (math.log(self.hi) - math.log(self.lo))
        return (x - self.lo) / (self.hi - self.lo)

    def dx_dz(self, x: float) -> float:
        return x * (math.log(self.hi) - math.log(self.lo)) if self.log else self.hi - self.lo

    def override(self, x: float) -> str:
        if self.index is None:
            return f"{self.set_key}={toml_writer.value(x)}"
        vec = list(self.vector)
        vec[self.index] = x
        return f"{self.set_key}={toml_writer.value(vec)}"


def _lookup(scene: dict, key: str):
    node = scene
    for part in key.split("."):
        if isinstance(node, list) and re.fullmatch(r"\d+", part) and int(part) < len(node):
            node = node[int(part)]
        elif isinstance(node, dict) and part in node:
            node = node[part]
        else:
            return None
    return node


def parse_vary(text: str, scene: dict) -> Parameter:
    """``KEY=LO:HI[:log]`` against the loaded scene (its value is the start)."""
    key, sep, rng = text.partition("=")
    key = key.strip()
    bits = [b.strip() for b in rng.split(":")]
    if not sep or not key or len(bits) not in (2, 3) or (len(bits) == 3 and bits[2] != "log"):
        raise SceneError(f"--vary '{text}': expected KEY=LO:HI or KEY=LO:HI:log "
                         f"(e.g. shell.E=1e5:1e7:log)")
    try:
        lo, hi = float(bits[0]), float(bits[1])
    except ValueError:
        raise SceneError(f"--vary '{text}': expected numbers LO and HI, found "
                         f"'{bits[0]}' and '{bits[1]}'") from None
    log = len(bits) == 3
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
        raise SceneError(f"--vary '{text}': expected finite LO < HI, found {lo:g} and {hi:g}")
    if log and lo <= 0:
        raise SceneError(f"--vary '{text}': a log scale needs LO > 0, found {lo:g}")
    head, _, last = key.rpartition(".")
    value, set_key, index, vector = _lookup(scene, key), key, None, None
    if isinstance(_lookup(scene, head), list) and re.fullmatch(r"\d+", last) \
            and not isinstance(value, dict):
        vector, set_key, index = list(_lookup(scene, head)), head, int(last)
    if value is not None and (isinstance(value, bool) or not isinstance(value, (int, float))):
        raise SceneError(f"--vary {key}: expected a key with a number value, found "
                         f"{toml_writer.value(value) if not isinstance(value, dict) else 'a table'}")
    start = float(value) if value is not None and lo <= value <= hi else None
    p = Parameter(key, lo, hi, log, set_key, index, vector, math.nan)
    p.start = start if start is not None else p.from_unit(0.5)
    return p


# --- the evaluations ---------------------------------------------------------------


@dataclass
class Evaluation:
    index: int
    folder: Path
    x: list[float]
    status: str = "not run"
    objective: float | None = None
    constraints: list = field(default_factory=list)
    merit: float = math.nan
    failure: str = ""
    wall: float | None = None
    reused: bool = False
    gradient: list | None = None   # d objective / d x (the adjoint's), if computed


class Evaluator:
    """Runs evaluations (a folder each), reads their objective and constraints, writes
    the CSV rows, keeps the best; ``merit(z)`` is what a method minimises."""

    def __init__(self, scene_file, overrides, params, objective, constraints, sign, out,
                 budget, jobs, np_, reuse, petsc_args, console, gradients=False):
        self.scene_file, self.overrides, self.params = scene_file, list(overrides), params
        self.objective, self.constraints, self.sign = objective, constraints, sign
        self.out, self.budget, self.jobs, self.reuse = out, budget, jobs, reuse
        self.console, self.petsc_args, self.gradients = console, list(petsc_args), gradients
        self.launcher = launcher(np_)
        self.in_process = jobs == 1 and np_ == 1
        self.evaluations: list[Evaluation] = []
        self._cache: dict[tuple, Evaluation] = {}
        self._csv = open(out / "optimize.csv", "w", encoding="utf-8", newline="")
        self._writer = csv.writer(self._csv, lineterminator="\n")
        self._writer.writerow(["evaluation", "folder", "status", *[p.key for p in params],
                               "objective", *[c.text for c in constraints], "merit",
                               "wall_s", "reused", "failure"])
        self._csv.flush()

    def close(self):
        self._csv.close()

    # --- the runs

    def overrides_of(self, x) -> list[str]:
        return [*self.overrides, *[p.override(v) for p, v in zip(self.params, x)]]

    def xs(self, z) -> list[float]:
        return [p.from_unit(v) for p, v in zip(self.params, z)]

    def _key(self, x) -> tuple:
        return tuple(float(f"{v:.12g}") for v in x)

    def evaluate(self, zs) -> list[Evaluation]:
        """The evaluations at the unit points ``zs`` (runs side by side with --jobs);
        BudgetSpent once the budget is used and points are left."""
        todo, results = [], []
        for z in zs:
            x = self.xs(z)
            ev = self._cache.get(self._key(x))
            if ev is None:
                if len(self.evaluations) >= self.budget:
                    break
                ev = Evaluation(len(self.evaluations) + 1,
                                self.out / f"eval-{len(self.evaluations) + 1:04d}", x)
                self.evaluations.append(ev)
                self._cache[self._key(x)] = ev
                todo.append(ev)
            results.append(ev)
        if self.in_process or len(todo) <= 1:
            for ev in todo:
                self._run(ev)
        else:
            with ThreadPoolExecutor(max_workers=self.jobs) as pool:
                list(pool.map(self._run, todo))
        for ev in todo:
            self._score(ev)
        if len(results) < len(zs):
            raise BudgetSpent
        return results

    def _run(self, ev: Evaluation) -> None:
        overrides = self.overrides_of(ev.x)
        t0 = time.perf_counter()
        if self.reuse and _done(ev.folder, self.scene_file, overrides, self.gradients):
            ev.reused, status = True, 0
        else:
            if ev.folder.exists():
                shutil.rmtree(ev.folder)
            ev.folder.mkdir(parents=True)
            if self.gradients:
                from rftfem.sensitivity import run_with_gradient

                status, _, _ = run_with_gradient(
                    self.scene_file, overrides, ev.folder, [p.key for p in self.params],
                    self.objective.quantities[0].text, self.petsc_args)
            elif self.in_process:
                status = run_here(self.scene_file, overrides, ev.folder, self.petsc_args)
            else:
                status = run_child(self.scene_file, overrides, ev.folder, self.launcher,
                                   self.petsc_args)
        ev.wall = time.perf_counter() - t0
        self._read(ev, status)

    def _read(self, ev: Evaluation, status: int) -> None:
        from rftfem.quantities import RunFolder, Unavailable

        try:
            run = RunFolder(ev.folder)
        except SceneError:
            run = None
        if run is None or run.summary is None:
            ev.status, ev.failure = "failed", failure_reason(ev.folder / "run.log", status)
            return
        if status != 0 or run.status != "ok":
            reason = (run.summary.get("failure") or {}).get("reason") or \
                failure_reason(ev.folder / "run.log", status)
            ev.status, ev.failure = "failed", str(reason)
            return
        try:
            ev.objective = self.objective.evaluate(run)
            ev.constraints = [c.objective.evaluate(run) for c in self.constraints]
        except Unavailable as exc:
            ev.status, ev.failure = "failed", str(exc)
            return
        # any other SceneError (an unknown column) is a bad option: it ends the loop
        ev.status = "ok"
        if self.gradients:
            ev.gradient = _read_gradient(ev.folder, self.objective, self.params, ev.objective)

    def _score(self, ev: Evaluation) -> None:
        ok = [e for e in self.evaluations if e.status in ("ok", "infeasible")
              and e is not ev and not math.isnan(e.merit)]
        if ev.status == "ok":
            violation = sum(c.violation(v) / max(abs(c.bound), 1e-300)
                            for c, v in zip(self.constraints, ev.constraints))
            scale = max([abs(e.objective) for e in ok] + [abs(ev.objective), 1e-300])
            ev.merit = self.sign * ev.objective + 10.0 * scale * violation
            if violation > 0:
                ev.status = "infeasible"
        else:  # worse than any seen: the method turns away
            merits = [e.merit for e in ok]
            if merits:
                worst, best = max(merits), min(merits)
                ev.merit = worst + max(worst - best, 0.1 * abs(worst), 1e-300)
            else:
                ev.merit = 1e10
        self._write(ev)
        best = self.best()
        self.console.out(
            f"  {ev.folder.name}: {ev.status}{' (reused)' if ev.reused else ''}  "
            + "  ".join(f"{p.key}={v:.6g}" for p, v in zip(self.params, ev.x))
            + (f"  objective {ev.objective:.6g}" if ev.objective is not None else "")
            + (f"; {ev.failure}" if ev.failure else "")
            + (f"  (best {best.objective:.6g}, {best.folder.name})" if best else ""))

    def _write(self, ev: Evaluation) -> None:
        cons = ev.constraints or [None] * len(self.constraints)
        self._writer.writerow([ev.index, ev.folder.name, ev.status, *[repr(v) for v in ev.x],
                               _num(ev.objective), *[_num(v) for v in cons], _num(ev.merit),
                               _num(ev.wall, ".3f"), int(ev.reused), ev.failure])
        self._csv.flush()

    def best(self) -> Evaluation | None:
        """The feasible evaluation with the best objective (else the lowest merit)."""
        feasible = [e for e in self.evaluations if e.status == "ok"]
        if feasible:
            return min(feasible, key=lambda e: self.sign * e.objective)
        scored = [e for e in self.evaluations if e.status == "infeasible"]
        return min(scored, key=lambda e: e.merit) if scored else None

    # --- what the methods call

    def merit(self, z) -> float:
        return self.evaluate([z])[0].merit

    def merits(self, zs) -> list[float]:
        return [ev.merit for ev in self.evaluate(zs)]

    def constraint_margins(self, z) -> list[float]:
        """COBYLA's constraints (≥ 0 when met), relative to each bound; a failed run
        counts as violating them all."""
        ev = self.evaluate([z])[0]
        if ev.status not in ("ok", "infeasible"):
            return [-1.0] * len(self.constraints)
        return [((c.bound - v) if c.sense == "<=" else (v - c.bound)) / max(abs(c.bound), 1e-300)
                for c, v in zip(self.constraints, ev.constraints)]

    def merit_and_gradient(self, z):
        """The merit and its gradient in the unit box: the adjoint's when the runs give
        one, else forward differences (their runs side by side with --jobs)."""
        import numpy as np

        z = np.clip(np.asarray(z, float), 0.0, 1.0)
        ev = self.evaluate([z])[0]
        if ev.gradient is not None and ev.status == "ok":
            dz = [g * p.dx_dz(x) for g, p, x in zip(ev.gradient, self.params, ev.x)]
            return ev.merit, self.sign * np.array(dz)
        steps = [FD_STEP if zj + FD_STEP <= 1.0 else -FD_STEP for zj in z]
        points = [z + h * np.eye(len(z))[j] for j, h in enumerate(steps)]
        merits = self.merits(points)
        return ev.merit, np.array([(m - ev.merit) / h for m, h in zip(merits, steps)])


def _done(folder: Path, scene_file, overrides: list[str], gradients: bool) -> bool:
    """A finished run (ok or failed) of the same scene and overrides is in ``folder``."""
    try:
        summary = json.loads((folder / "summary.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return False
    if gradients and summary.get("status") == "ok" and not (folder / "gradient.json").is_file():
        return False
    return (summary.get("status") in ("ok", "failed")
            and summary.get("overrides") == list(overrides)
            and Path(str(summary.get("scene_file", ""))).resolve() == Path(scene_file).resolve())


def _read_gradient(folder: Path, objective, params, value: float) -> list | None:
    """d objective / d parameter from gradient.json (the chain rule through the formula
    of its one quantity, by a central difference of the formula)."""
    try:
        data = json.loads((folder / "gradient.json").read_text(encoding="utf-8"))
        dq = [float(data["gradient"][p.key]) for p in params]
        q = float(data["value"])
    except (OSError, ValueError, KeyError, TypeError):
        return None
    h = 1e-6 * max(abs(q), 1e-300)
    f = objective.formula
    dfdq = (float(f.numbers({"q0": q + h})) - float(f.numbers({"q0": q - h}))) / (2 * h)
    return [dfdq * g for g in dq]


def _num(v, fmt: str = ".10g") -> str:
    return "" if v is None or (isinstance(v, float) and math.isnan(v)) else format(v, fmt)


# --- the methods -------------------------------------------------------------------


def search(method: str, ev: Evaluator, z0, budget: int) -> str:
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
            simplex = [z0] + [z0 + np.eye(n)[j] * (FIRST_STEP if z0[j] + FIRST_STEP <= 1
                                                   else -FIRST_STEP) for j in range(n)]
            res = optimize.minimize(ev.merit, z0, method="Nelder-Mead", bounds=bounds,
                                    options={"initial_simplex": np.array(simplex),
                                             "xatol": X_TOLERANCE, "fatol": math.inf,
                                             "maxfev": 10 * budget})
        elif method == "powell":
            res = optimize.minimize(ev.merit, z0, method="Powell", bounds=bounds,
                                    options={"xtol": X_TOLERANCE, "ftol": 1e-9,
                                             "direc": np.eye(n) * FIRST_STEP,
                                             "maxfev": 10 * budget})
        elif method == "cobyla":
            cons = [{"type": "ineq", "fun": lambda z, j=j: z[j]} for j in range(n)]
            cons += [{"type": "ineq", "fun": lambda z, j=j: 1.0 - z[j]} for j in range(n)]
            if ev.constraints:
                cons.append({"type": "ineq", "fun": ev.constraint_margins})
            objective = (lambda z: ev.sign * _value_or_merit(ev, z)) if ev.constraints \
                else ev.merit
            res = optimize.minimize(objective, z0, method="COBYLA", constraints=cons,
                                    options={"rhobeg": FIRST_STEP, "tol": X_TOLERANCE,
                                             "maxiter": 10 * budget})
        elif method == "l-bfgs-b":
            res = optimize.minimize(ev.merit_and_gradient, z0, jac=True, method="L-BFGS-B",
                                    bounds=bounds, options={"maxfun": 10 * budget,
                                                            "ftol": 1e-12, "gtol": 1e-10})
        else:  # guarded by the option check
            raise SceneError(f"--method: unknown method '{method}'")
    except BudgetSpent:
        return f"the budget of {budget} runs was spent"
    return f"{method} stopped: {' '.join(str(res.message).split())}"


def _value_or_merit(ev: Evaluator, z) -> float:
    """COBYLA's objective with its constraints apart: the objective of a run (signed
    back by the caller), a failed run's merit otherwise."""
    e = ev.evaluate([z])[0]
    return e.objective if e.status in ("ok", "infeasible") else ev.sign * e.merit


# --- outputs -----------------------------------------------------------------------


def write_best(ev: Evaluator, best: Evaluation, path: Path, command: str) -> None:
    """The best evaluation's scene (the scene file with its overrides) as TOML."""
    from rftfem.scene import apply_override

    raw = tomllib.loads(Path(ev.scene_file).read_text(encoding="utf-8"))
    for text in ev.overrides_of(best.x):
        apply_override(raw, text)
    mesh = raw.get("mesh") or {}
    if isinstance(mesh.get("file"), str):  # relative to the scene file: keep it found
        mesh["file"] = str((Path(ev.scene_file).resolve().parent / mesh["file"]).resolve())
    header = (f"The best evaluation of: {command}\n"
              f"{best.folder.name}: objective {best.objective!r} ({best.status}); "
              + ", ".join(f"{p.key} = {v!r}" for p, v in zip(ev.params, best.x)))
    path.write_text(toml_writer.document(raw, header), encoding="utf-8")


def plot(ev: Evaluator, path: Path, title: str) -> bool:
    """The objective against the evaluation (the best so far as a line) and each
    parameter's trace; False without matplotlib or evaluations."""
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return False
    evs = ev.evaluations
    if not evs:
        return False
    n = len(ev.params)
    fig, axes = plt.subplots(1 + n, 1, figsize=(7, 2.6 + 1.6 * n), sharex=True, squeeze=False)
    ax = axes[0][0]
    ok = [e for e in evs if e.objective is not None]
    feasible = [e for e in ok if e.status == "ok"]
    if feasible:
        ax.plot([e.index for e in feasible], [e.objective for e in feasible], "o",
                color="C0", label="evaluation")
    bad = [e for e in ok if e.status == "infeasible"]
    if bad:
        ax.plot([e.index for e in bad], [e.objective for e in bad], "s", mfc="none",
                color="C1", label="violates a constraint")
    best_so_far, line = None, []
    for e in evs:
        if e.status == "ok" and (best_so_far is None
                                 or ev.sign * e.objective < ev.sign * best_so_far):
            best_so_far = e.objective
        line.append(best_so_far)
    if best_so_far is not None:
        ax.step([e.index for e in evs], [math.nan if v is None else v for v in line],
                where="post", color="k", lw=1, label="best so far")
    failed = [e for e in evs if e.objective is None]
    for e in failed:
        ax.axvline(e.index, color="C3", lw=0.8, ls=":")
    if failed:
        ax.plot([], [], color="C3", ls=":", label="failed run")
    ax.set_ylabel("objective")
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=8)
    ax.grid(True, alpha=0.3)
    for j, p in enumerate(ev.params):
        ax = axes[1 + j][0]
        ax.plot([e.index for e in evs], [e.x[j] for e in evs], ".-", color="C2", lw=0.8)
        ax.set_ylabel(p.key, fontsize=8)
        if p.log:
            ax.set_yscale("log")
        ax.grid(True, alpha=0.3)
    axes[-1][0].set_xlabel("evaluation")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return True


# --- command line ------------------------------------------------------------------


def add_arguments(parser):
    import argparse

    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    parser.epilog = EPILOG
    parser.add_argument("scene", metavar="SCENE.toml", help="the scene file")
    parser.add_argument("--vary", metavar="KEY=LO:HI", action="append", default=[],
                        help="a scalar scene key and its interval (LO:HI:log for a log "
                             "scale; load.0.value.1 for a component); repeatable")
    parser.add_argument("--objective", metavar="EXPR", default=None,
                        help="what to optimise: a formula of collect's quantities")
    sense = parser.add_mutually_exclusive_group()
    sense.add_argument("--maximize", action="store_true", help="seek the largest objective")
    sense.add_argument("--minimize", action="store_true",
                       help="seek the smallest objective (the default)")
    parser.add_argument("--constraint", metavar="EXPR<=V", action="append", default=[],
                        help="EXPR<=V or EXPR>=V, EXPR as the objective; repeatable")
    parser.add_argument("--method", metavar="NAME", default=DEFAULT_METHOD,
                        help=f"{', '.join(METHODS)} (default {DEFAULT_METHOD})")
    parser.add_argument("--budget", metavar="N", type=int, default=DEFAULT_BUDGET,
                        help=f"at most N runs (default {DEFAULT_BUDGET})")
    parser.add_argument("--set", metavar="KEY=VALUE", action="append", default=[],
                        dest="overrides", help="override a scene key in every run; repeatable")
    parser.add_argument("--out", metavar="DIR", type=Path, default=None,
                        help="folder (default: results/optimize-<scene file stem>)")
    parser.add_argument("--jobs", metavar="J", type=int, default=1,
                        help="runs at the same time, each one process, where the method "
                             "has several to make (grid; l-bfgs-b's differences)")
    parser.add_argument("--np", metavar="P", type=int, default=1,
                        help="run each evaluation under mpirun -n P")
    parser.add_argument("--reuse", action="store_true",
                        help="read evaluations whose folder holds a finished run of the same "
                             "overrides instead of running them (resumes an optimisation)")


def _method(name: str) -> str:
    m = name.strip().lower().replace("_", "-")
    m = {"nelder-mead": "nelder-mead", "neldermead": "nelder-mead", "lbfgsb": "l-bfgs-b",
         "brute": "grid"}.get(m, m)
    if m not in METHODS:
        raise SceneError(f"--method: unknown method '{name}' (expected {', '.join(METHODS)})")
    return m


def main(args, petsc_args: list[str], console) -> int:
    from rftfem.scene import load_scene, resolved_scheme

    if not args.vary:
        raise SceneError("--vary: give at least one KEY=LO:HI to search")
    if args.objective is None:
        raise SceneError("--objective: give the quantity to optimise (e.g. "
                         "--objective 'steady(front_ux_rate)')")
    method = _method(args.method)
    if args.budget < 1:
        raise SceneError(f"--budget: expected at least 1 run, found {args.budget}")
    if args.jobs < 1 or args.np < 1:
        raise SceneError("--jobs and --np: expected at least 1")
    if args.jobs > 1 and args.np > 1:
        raise SceneError("--jobs and --np: give one of them (runs side by side, or each "
                         "run on several processes)")
    objective = objectives.parse(args.objective)
    constraints = [objectives.parse_constraint(c) for c in args.constraint]
    if method == "l-bfgs-b" and constraints:
        raise SceneError("--constraint: l-bfgs-b takes bounds only; use --method cobyla "
                         "(or nelder-mead, powell with a penalty)")
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
    gradients = (method == "l-bfgs-b" and static and len(objective.quantities) == 1
                 and args.np == 1 and args.jobs == 1 and _differentiable(keys, objective))
    out = args.out if args.out is not None else Path("results") / f"optimize-{Path(args.scene).stem}"
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise SceneError(f"--out {out}: {exc.strerror or exc}") from None
    if not args.reuse:
        for old in out.glob("eval-[0-9]*"):
            shutil.rmtree(old, ignore_errors=True)
    sign = -1.0 if args.maximize else 1.0
    command = " ".join(["rftfem optimize", _quote(args.scene),
                        *[f"--vary {_quote(v)}" for v in args.vary],
                        f"--objective {_quote(args.objective)}",
                        *(["--maximize"] if args.maximize else []),
                        *[f"--constraint {_quote(c)}" for c in args.constraint],
                        f"--method {method}", f"--budget {args.budget}",
                        *[f"--set {_quote(o)}" for o in args.overrides]])
    console.out(f"rftfem optimize: {method} over {', '.join(keys)} "
                f"({'maximise' if sign < 0 else 'minimise'} {args.objective}; at most "
                f"{args.budget} runs{'; gradients by the adjoint' if gradients else ''}) in {out}")
    if args.jobs > 1 and method in ("nelder-mead", "powell", "cobyla"):
        console.err(f"rftfem optimize: note: {method} makes one run at a time; --jobs "
                    f"{args.jobs} has nothing to run side by side (grid and l-bfgs-b do)")
    ev = Evaluator(args.scene, args.overrides, params, objective, constraints, sign, out,
                   args.budget, args.jobs, args.np, args.reuse, petsc_args, console, gradients)
    t0 = time.perf_counter()
    try:
        why = search(method, ev, [p.to_unit(p.start) for p in params], args.budget)
    finally:
        ev.close()
        best = ev.best()
        if best is not None:
            write_best(ev, best, out / "best.toml", command)
        drawn = plot(ev, out / "optimize.png", command if len(command) < 110
                     else command[:107] + "...")
    n_failed = sum(e.status == "failed" for e in ev.evaluations)
    n_reused = sum(e.reused for e in ev.evaluations)
    console.out(f"rftfem optimize: {why}; {len(ev.evaluations)} runs"
                + (f" ({n_failed} failed)" if n_failed else "")
                + (f" ({n_reused} reused)" if n_reused else "")
                + f" in {time.perf_counter() - t0:.0f} s")
    if best is None:
        console.err(f"rftfem optimize: no run succeeded; optimize.csv in {out}")
        return 0
    console.out(f"best: {best.folder.name}, objective {best.objective:.8g}"
                + ("" if best.status == "ok" else " (no evaluation met the constraints)")
                + "; " + ", ".join(f"{p.key} = {v:.8g}" for p, v in zip(params, best.x)))
    console.err("rftfem optimize: optimize.csv, best.toml"
                + (", optimize.png" if drawn else "") + f" in {out}")
    return 0


def _differentiable(keys: list[str], objective) -> bool:
    """Whether rftfem/sensitivity.py can differentiate this objective in these keys."""
    try:
        from rftfem.sensitivity import supports
    except (ImportError, AttributeError):
        return False
    return supports(keys, objective.quantities[0].text)


def _quote(arg: str) -> str:
    import shlex

    return shlex.quote(arg)


__all__ = ["main", "add_arguments", "parse_vary", "Parameter", "Evaluator", "search",
           "METHODS", "DEFAULT_METHOD", "DESCRIPTION", "EPILOG"]
