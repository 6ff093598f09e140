"""What one step costs, against what it must cost (its floor).

A step that takes ``n`` Newton iterations cannot be cheaper than ``n`` times one
Jacobian assembly, one factorisation and solve, and one residual assembly, plus
the residual that starts the step.  This runs each demo for a stretch of steps
with its outputs (as a user would), then measures those three operations in the
same process on the final state, and prints per step:

- wall time and Newton iterations;
- the floor, and the ratio wall / floor;
- where the time goes: residuals, Jacobians, liftings of a prescribed
  increment, linear solves, loads and motions set for the step (with the
  prediction of its start), the state and triad update, outputs, and the rest
  (Python, SNES bookkeeping).

    .venv/bin/python benchmarks/step_cost.py                  # every case, ~2 minutes
    .venv/bin/python benchmarks/step_cost.py sheet --steps 400

Figures go to stdout and to results/benchmarks/step_cost.csv. Timings are of
this machine at the moment of the run: run it alone.
"""

from __future__ import annotations

import argparse
import csv
import sys
import tempfile
import time
from pathlib import Path

# the repository's .venv when this python3 lacks rftfem (scripts/repository_python.py)
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))
import repository_python  # noqa: E402

repository_python.ensure()

import rftfem  # noqa: F401  (sets up the FEniCSx stack)
from rftfem.integration.simulation import Simulation
from rftfem.scene.reading import load_scene

DEMOS = Path(__file__).resolve().parents[1] / "demos"

#: case -> (scene, overrides, default number of steps)
CASES = {
    "sheet": ("swimming_sheet.toml", [], 200),
    "strip": ("bidirectional_strip.toml", [], 200),
    "rollup": ("rollup.toml", [], 40),
    "three-link": ("three_link.toml", [], 200),
}


def _best(f, repeats: int = 5) -> float:
    """The shortest of ``repeats`` timings of ``f()``, in seconds."""
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        f()
        best = min(best, time.perf_counter() - t0)
    return best


def floor_parts(sim) -> dict:
    """One Jacobian, one factorisation + solve, one residual, on the current state."""
    solver = sim.solver
    snes, A = solver.snes, solver.A
    x = solver.x
    ksp = snes.getKSP()
    y = x.duplicate()

    def jacobian():
        solver._jacobian(snes, x, A, A)

    def factor_and_solve():
        A.assemble()  # a new matrix state: the next solve factorises again
        ksp.setOperators(A)
        ksp.solve(solver.b, y)

    def residual():
        solver._residual(snes, x, solver.b)

    jacobian()
    residual()
    parts = {
        "jacobian": _best(jacobian),
        "factor_solve": _best(factor_and_solve),
        "residual": _best(residual),
    }
    y.destroy()
    return parts


class _Enough(Exception):
    """Raised by the observer after the steps asked for: the demo's own scene (its
    ramps and end time) runs, only its first steps."""


def stopper(scene: dict, steps: int):
    """An observer that ends the run at the time of nominal step ``steps``."""
    t_stop = steps * scene["time"]["dt"]

    def stop(sim):
        if sim.t >= t_stop * (1 - 1e-12):
            raise _Enough

    return stop


def measure(name: str, steps: int) -> dict:
    scene_file, overrides, _ = CASES[name]
    scene = load_scene(DEMOS / scene_file, overrides)

    stop = stopper(scene, steps)

    with tempfile.TemporaryDirectory() as out:
        sim = Simulation(scene, out_dir=Path(out), quiet=True, observers=[stop])
        try:
            t0 = time.perf_counter()
            try:
                sim.run()
            except _Enough:
                pass
            wall = time.perf_counter() - t0
            parts = floor_parts(sim)
            n = sim.counts["steps"]  # accepted steps, cut ones included
            its = sim.counts["newton_iterations"]
            timings, calls, extra = dict(sim.solver.timings), dict(sim.solver.calls), sim.wall
            dofs = sim.model.W.dofmap.index_map.size_global * sim.model.W.dofmap.index_map_bs
        finally:
            sim.close()
    per = {k: v / n for k, v in timings.items()}
    floor = (its / n) * (parts["jacobian"] + parts["factor_solve"] + parts["residual"]) + parts[
        "residual"
    ]
    step = wall / n
    rest = step - sum(per.values()) - sum(v / n for v in extra.values())
    return {
        "case": name,
        "dofs": dofs,
        "steps": n,
        "cuts": sim.counts["dt_cuts"],
        "its_per_step": its / n,
        "wall_per_step_ms": 1e3 * step,
        "floor_ms": 1e3 * floor,
        "ratio": step / floor,
        "jacobian_ms": 1e3 * parts["jacobian"],
        "factor_solve_ms": 1e3 * parts["factor_solve"],
        "residual_ms": 1e3 * parts["residual"],
        "residuals_per_step": calls["residual"] / n,
        "jacobians_per_step": calls["jacobian"] / n,
        "liftings_per_step": calls["lifting"] / n,
        "in_residuals_ms": 1e3 * per["residual"],
        "in_jacobians_ms": 1e3 * per["jacobian"],
        "in_liftings_ms": 1e3 * per["lifting"],
        "in_solves_ms": 1e3 * per["solve"],
        "in_loads_ms": 1e3 * extra["loads"] / n,
        "in_update_ms": 1e3 * extra["update"] / n,
        "in_output_ms": 1e3 * extra["output"] / n,
        "in_rest_ms": 1e3 * rest,
    }


def report(row: dict) -> None:
    print(
        f"\n{row['case']}: {row['dofs']} unknowns, {row['steps']} steps "
        f"({row['cuts']} cuts), {row['its_per_step']:.2f} Newton iterations per step"
    )
    print(
        f"  wall per step {row['wall_per_step_ms']:.2f} ms; floor {row['floor_ms']:.2f} ms "
        f"(Jacobian {row['jacobian_ms']:.2f} + factorisation and solve "
        f"{row['factor_solve_ms']:.2f} + residual {row['residual_ms']:.2f} ms per iteration); "
        f"wall / floor = {row['ratio']:.2f}"
    )
    print(
        f"  per step: {row['residuals_per_step']:.2f} residuals {row['in_residuals_ms']:.2f} ms, "
        f"{row['jacobians_per_step']:.2f} Jacobians {row['in_jacobians_ms']:.2f} ms, "
        f"{row['liftings_per_step']:.2f} liftings {row['in_liftings_ms']:.2f} ms, "
        f"solves {row['in_solves_ms']:.2f} ms, loads {row['in_loads_ms']:.2f} ms, "
        f"update {row['in_update_ms']:.2f} ms, output {row['in_output_ms']:.2f} ms, "
        f"rest {row['in_rest_ms']:.2f} ms"
    )


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "cases", nargs="*", metavar="CASE", help=f"which: {', '.join(CASES)} (default: all)"
    )
    parser.add_argument("--steps", type=int, help="steps per case (default: per case)")
    parser.add_argument("--csv", type=Path, default=Path("results/benchmarks/step_cost.csv"))
    args = parser.parse_args(argv)
    rows = []
    for name in cases_asked(parser, args.cases):
        rows.append(measure(name, args.steps or CASES[name][2]))
        report(rows[-1])
    write_csv(args.csv, rows)


def cases_asked(parser, cases: list[str]) -> list[str]:
    """The cases named on the command line (all when none), or a usage error."""
    unknown = [c for c in cases if c not in CASES]
    if unknown:
        parser.error(f"unknown case {unknown[0]!r}; expected one of {', '.join(CASES)}")
    return cases or list(CASES)


def write_csv(path: Path, rows: list[dict]) -> None:
    """The rows (dicts with the same keys) as a CSV file, its folder made."""
    if not rows:
        return
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", newline="", encoding="utf-8") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    print(f"\nwritten {path}")


if __name__ == "__main__":
    main()
