"""The solver options a user can pick, measured: what each costs and what it does
to the answer.

Each case (a demo's first steps, as in step_cost.py) runs once per option set,
given as `[solver]` options on the command line would be. Printed per run: wall
time per step, Newton iterations per step, step halvings, and how far the probes
at the last step are from the same run with tight tolerances (snes_atol 1e-11 f),
relative to the largest probe displacement. The defaults are the first row;
tolerances are given in units of the scene's driving force f.

    .venv/bin/python benchmarks/solver_options.py                 # all cases, ~10 minutes
    .venv/bin/python benchmarks/solver_options.py sheet --steps 100

Figures go to stdout and to results/benchmarks/solver_options.csv. Timings are
of this machine at the moment of the run: run it alone.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

# the repository's .venv when this python3 lacks rftfem (scripts/repository_python.py)
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))
import repository_python  # noqa: E402

repository_python.ensure()

import numpy as np
from step_cost import CASES, DEMOS, _Enough, cases_asked, stopper, write_csv

import rftfem  # noqa: F401  (sets up the FEniCSx stack)
from rftfem.integration.simulation import Simulation
from rftfem.scene.reading import load_scene

#: name -> PETSc options as on the command line, from the scene's driving force f
#: (the default snes_atol is 1e-7 f, rftfem/petsc_options.py)
OPTIONS = {
    "defaults (MUMPS LU, atol 1e-7 f)": lambda f: [],
    "PETSc's own LU": lambda f: ["-pc_factor_mat_solver_type", "petsc"],
    "MUMPS, METIS ordering": lambda f: ["-mat_mumps_icntl_7", "5"],
    "Jacobian every 2nd iteration": lambda f: ["-snes_lag_jacobian", "2"],
    "Jacobian every 3rd iteration, kept across steps": lambda f: [
        "-snes_lag_jacobian",
        "3",
        "-snes_lag_jacobian_persists",
        "true",
    ],
    "atol 1e-5 f": lambda f: ["-snes_atol", repr(1e-5 * f)],
    "atol 1e-9 f": lambda f: ["-snes_atol", repr(1e-9 * f)],
    "rtol 1e-8 of the first residual (the old default)": lambda f: ["-snes_rtol", "1e-8"],
}
#: the reference run: a residual of 1e-11 f, or updates at round-off
TIGHT = lambda f: ["-snes_atol", repr(1e-11 * f), "-snes_stol", "1e-14"]  # noqa: E731


def driving_force(name: str) -> float:
    scene_file, overrides, _ = CASES[name]
    sim = Simulation(load_scene(DEMOS / scene_file, overrides), quiet=True)
    try:
        return sim.model.reference_force()
    finally:
        sim.close()


def run(name: str, steps: int, petsc_args: list[str]) -> dict:
    scene_file, overrides, _ = CASES[name]
    scene = load_scene(DEMOS / scene_file, overrides)

    stop = stopper(scene, steps)

    sim = Simulation(scene, quiet=True, petsc_args=list(petsc_args), observers=[stop])
    try:
        t0 = time.perf_counter()
        status = "ok"
        try:
            sim.run()
        except _Enough:
            pass
        except Exception as exc:  # a failed run is a row of the table, not the end of it
            status = f"failed: {' '.join(str(exc).split())[:80]}"
        wall = time.perf_counter() - t0
        n = max(sim.counts["steps"], 1)
        if status == "ok" and sim.t < steps * scene["time"]["dt"] * (1 - 1e-12):
            status = f"stopped at t = {sim.t:g}"
        return {
            "wall_per_step_ms": 1e3 * wall / n,
            "steps": sim.counts["steps"],
            "its_per_step": sim.counts["newton_iterations"] / n,
            "cuts": sim.counts["dt_cuts"],
            "status": status,
            "probes": sim.probes.values().ravel().copy(),
        }
    finally:
        sim.close()


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "cases", nargs="*", metavar="CASE", help=f"which: {', '.join(CASES)} (default: all)"
    )
    parser.add_argument("--steps", type=int, default=100, help="steps per run (default 100)")
    parser.add_argument("--csv", type=Path, default=Path("results/benchmarks/solver_options.csv"))
    args = parser.parse_args(argv)
    rows = []
    for case in cases_asked(parser, args.cases):
        steps = min(args.steps, CASES[case][2])
        force = driving_force(case)
        reference = run(case, steps, TIGHT(force))
        if reference["status"] != "ok":
            print(f"\n{case}: the tight run failed ({reference['status']}); skipped")
            continue
        tight = reference["probes"]
        scale = np.abs(tight).max()
        print(f"\n{case}, {steps} steps (answer: probes at the last step against atol 1e-11 f)")
        print(f"  {'options':52s} {'ms/step':>9s} {'its/step':>9s} {'cuts':>5s} {'answer':>9s}")
        for label, opts in OPTIONS.items():
            r = run(case, steps, opts(force))
            diff = np.abs(r["probes"] - tight).max() / scale if r["status"] == "ok" else np.nan
            print(
                f"  {label:52s} {r['wall_per_step_ms']:9.2f} {r['its_per_step']:9.2f} "
                f"{r['cuts']:5d} {diff:9.1e}" + ("" if r["status"] == "ok" else f"  {r['status']}")
            )
            rows.append(
                {
                    "case": case,
                    "options": label,
                    "steps": r["steps"],
                    "wall_per_step_ms": r["wall_per_step_ms"],
                    "its_per_step": r["its_per_step"],
                    "cuts": r["cuts"],
                    "answer_difference": diff,
                    "status": r["status"],
                }
            )
    write_csv(args.csv, rows)


if __name__ == "__main__":
    main()
