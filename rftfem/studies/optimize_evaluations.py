"""The evaluations of ``rftfem optimize`` (rftfem/studies/optimize.py): the parameters and
their unit box, one run folder per evaluation, its objective and constraints, the
penalties, optimize.csv.

:class:`Parameter` (rftfem/studies/optimize_parameters.py) is one ``--vary
KEY=LO:HI[:log]``, mapped to [0, 1] (linearly, or linearly in its logarithm);
:class:`Evaluator` runs the points a method asks for (in this process, or as child
runs side by side), scores them and writes a row of optimize.csv as each ends.  The
score a method minimises (``merit``) is the signed objective plus a constraint's
penalty, or for a failed run a value worse than any seen.  The adjoint's gradients
are read by rftfem/studies/optimize_gradients.py.
"""

from __future__ import annotations

import csv
import math
import shutil
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from rftfem.errors import SceneError
from rftfem.studies.batch import failure_reason
from rftfem.studies.optimize_gradients import adjoint_quantity, read_gradient, without_gradient
from rftfem.studies.optimize_parameters import Parameter, parse_vary
from rftfem.studies.reuse import keep_key, key_of, reused, status_of

if TYPE_CHECKING:
    from collections.abc import Sequence
    from typing import Any

    import numpy as np

    from rftfem.outputs.formulas import Objective
    from rftfem.studies.executors import Executor
    from rftfem.studies.objective import Constraint

#: forward-difference step of l-bfgs-b without an adjoint, a fraction of each interval
FD_STEP = 1e-3


class BudgetSpent(Exception):
    """The budget of runs is used up: the method stops with the best so far."""


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
    note: str = ""  # why a finished run was not reused, or not keyed (reuse.report)
    gradient: list | None = None  # d objective / d x (the adjoint's), if computed


class Evaluator:
    """Runs evaluations (a folder each), reads their objective and constraints, writes
    the CSV rows, keeps the best; ``merit(z)`` is what a method minimises."""

    def __init__(
        self,
        scene_file: str | Path,
        overrides: Sequence[str],
        params: list[Parameter],
        objective: Objective,
        constraints: list[Constraint],
        sign: float,
        out: Path,
        budget: int,
        jobs: int,
        executor: Executor,
        reuse: bool,
        petsc_args: Sequence[str],
        console: Any,
        gradients: bool = False,
    ):
        self.scene_file, self.overrides, self.params = scene_file, list(overrides), params
        self.objective, self.constraints, self.sign = objective, constraints, sign
        self.out, self.budget, self.jobs, self.reuse = out, budget, jobs, reuse
        self.console, self.petsc_args, self.gradients = console, list(petsc_args), gradients
        #: where the runs happen (rftfem/studies/executors.py)
        self.executor = executor
        self.in_process = getattr(executor, "in_process", False)
        self.evaluations: list[Evaluation] = []
        self._cache: dict[tuple, Evaluation] = {}
        self._csv = open(out / "optimize.csv", "w", encoding="utf-8", newline="")
        self._writer = csv.writer(self._csv, lineterminator="\n")
        self._writer.writerow(
            [
                "evaluation",
                "folder",
                "status",
                *[p.key for p in params],
                "objective",
                *[c.text for c in constraints],
                "merit",
                "wall_s",
                "reused",
                "failure",
            ]
        )
        self._csv.flush()

    def close(self) -> None:
        self._csv.close()

    # --- the runs

    def overrides_of(self, x: Sequence[float]) -> list[str]:
        return [*self.overrides, *[p.override(v) for p, v in zip(self.params, x)]]

    def xs(self, z: np.ndarray | Sequence[float]) -> list[float]:
        return [p.from_unit(v) for p, v in zip(self.params, z)]

    def _key(self, x) -> tuple:
        return tuple(float(f"{v:.12g}") for v in x)

    def evaluate(self, zs: Sequence[np.ndarray | Sequence[float]]) -> list[Evaluation]:
        """The evaluations at the unit points ``zs`` (runs side by side with --jobs);
        BudgetSpent once the budget is used and points are left."""
        todo, results = [], []
        for z in zs:
            x = self.xs(z)
            ev = self._cache.get(self._key(x))
            if ev is None:
                if len(self.evaluations) >= self.budget:
                    break
                ev = Evaluation(
                    len(self.evaluations) + 1, self.out / f"eval-{len(self.evaluations) + 1:04d}", x
                )
                self.evaluations.append(ev)
                self._cache[self._key(x)] = ev
                todo.append(ev)
            results.append(ev)
        # each is scored (and its row written) as it ends
        if self.in_process or len(todo) <= 1:
            for ev in todo:
                self._run(ev)
                self._score(ev)
        else:  # --jobs at a time, scored in the order asked for (a failed run's score
            # then does not depend on which run ended first)
            with ThreadPoolExecutor(max_workers=self.jobs) as pool:
                for k in range(0, len(todo), self.jobs):
                    chunk = todo[k : k + self.jobs]
                    list(pool.map(self._run, chunk))
                    for ev in chunk:
                        self._score(ev)
        if len(results) < len(zs):
            raise BudgetSpent
        return results

    def _run(self, ev: Evaluation) -> None:
        overrides = self.overrides_of(ev.x)
        t0 = time.perf_counter()
        key = self._key_of(overrides)
        kept, ev.note = reused(ev.folder, key, self.reuse, FINISHED)
        if kept and self.gradients and without_gradient(ev.folder):
            kept, ev.note = False, ""
        if kept:
            ev.reused, status = True, 0
        else:
            if ev.folder.exists():
                shutil.rmtree(ev.folder)
            ev.folder.mkdir(parents=True)
            if self.gradients:
                from rftfem.studies.gradient_runs import run_with_gradient

                status, _, _ = run_with_gradient(
                    self.scene_file,
                    overrides,
                    ev.folder,
                    [p.key for p in self.params],
                    adjoint_quantity(self.objective).text,
                    self.petsc_args,
                )
            else:
                status = self.executor.run(self.scene_file, overrides, ev.folder, self.petsc_args)
            if status_of(ev.folder) in FINISHED:  # a run to read again: key it
                ev.note = (
                    keep_key(
                        ev.folder, key, self.scene_file, overrides, self.petsc_args, "optimisation"
                    )
                    or ev.note
                )
        ev.wall = time.perf_counter() - t0
        self._read(ev, status)

    def _key_of(self, overrides: list[str]) -> dict | None:
        """The --reuse key of a run with ``overrides`` (rftfem/studies/reuse.py); None
        for a scene that does not load (its run fails and says why)."""
        from rftfem.scene.reading import load_scene

        try:
            return key_of(load_scene(str(self.scene_file), overrides), self.petsc_args)
        except SceneError:
            return None

    def _read(self, ev: Evaluation, status: int) -> None:
        from rftfem.outputs.quantities import RunFolder, Unavailable

        try:
            run = RunFolder(ev.folder)
        except SceneError:
            run = None
        if run is None or run.summary is None:
            ev.status, ev.failure = "failed", failure_reason(ev.folder / "run.log", status)
            return
        if status != 0 or run.status != "ok":
            reason = (run.summary.get("failure") or {}).get("reason") or failure_reason(
                ev.folder / "run.log", status
            )
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
            ev.gradient = read_gradient(run, self.objective, self.params)

    def _score(self, ev: Evaluation) -> None:
        ok = [
            e
            for e in self.evaluations
            if e.status in ("ok", "infeasible") and e is not ev and not math.isnan(e.merit)
        ]
        if ev.status == "ok":
            violation = sum(
                c.violation(v) / max(abs(c.bound), 1e-300)
                for c, v in zip(self.constraints, ev.constraints)
            )
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
            + (f"  (best {best.objective:.6g}, {best.folder.name})" if best else "")
        )

    def _write(self, ev: Evaluation) -> None:
        cons = ev.constraints or [None] * len(self.constraints)
        self._writer.writerow(
            [
                ev.index,
                ev.folder.name,
                ev.status,
                *[repr(v) for v in ev.x],
                _num(ev.objective),
                *[_num(v) for v in cons],
                _num(ev.merit),
                _num(ev.wall, ".3f"),
                int(ev.reused),
                ev.failure,
            ]
        )
        self._csv.flush()

    def best(self) -> Evaluation | None:
        """The feasible evaluation with the best objective (else the lowest merit)."""
        feasible = [e for e in self.evaluations if e.status == "ok"]
        if feasible:
            return min(feasible, key=lambda e: self.sign * e.objective)
        scored = [e for e in self.evaluations if e.status == "infeasible"]
        return min(scored, key=lambda e: e.merit) if scored else None

    # --- what the methods call

    def merit(self, z: np.ndarray | Sequence[float]) -> float:
        return self.evaluate([z])[0].merit

    def merits(self, zs: Sequence[np.ndarray | Sequence[float]]) -> list[float]:
        return [ev.merit for ev in self.evaluate(zs)]

    def constraint_margins(self, z: np.ndarray | Sequence[float]) -> list[float]:
        """COBYLA's constraints (≥ 0 when met), relative to each bound; a failed run
        counts as violating them all."""
        ev = self.evaluate([z])[0]
        if ev.status not in ("ok", "infeasible"):
            return [-1.0] * len(self.constraints)
        return [
            ((c.bound - v) if c.sense == "<=" else (v - c.bound)) / max(abs(c.bound), 1e-300)
            for c, v in zip(self.constraints, ev.constraints)
        ]

    def merit_and_gradient(self, z: np.ndarray | Sequence[float]) -> tuple[float, np.ndarray]:
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


#: the statuses of a run that --reuse reads again: a failed run too (the methods are
#: deterministic, so an interrupted optimisation goes on where it stopped)
FINISHED = ("ok", "failed")


def _num(v, fmt: str = ".10g") -> str:
    return "" if v is None or (isinstance(v, float) and math.isnan(v)) else format(v, fmt)


__all__ = [
    "Parameter",
    "parse_vary",
    "Evaluation",
    "Evaluator",
    "BudgetSpent",
    "FD_STEP",
    "adjoint_quantity",
]
