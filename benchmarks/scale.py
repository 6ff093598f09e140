"""How the cost of a step grows with the mesh: the swimming sheet refined from 2k to
over 200k unknowns, serial and under mpirun, with the linear solvers to choose from.

Each (mesh, processes, solver) runs in its own process: the sheet's first steps
(default 3, after the t = 0 solve), outputs off. Printed per run: unknowns, wall
time per step, Newton iterations per step, time in Jacobian assembly and in the
linear solves per iteration, and the peak memory of the largest process. Then,
per series, the exponent p of time per step ~ unknowns^p fitted on the meshes
from 20k unknowns up, and the speed-up of two processes over one.

    .venv/bin/python benchmarks/scale.py                      # ~25 minutes
    .venv/bin/python benchmarks/scale.py --sizes 20x4 120x24 --np 1 2 --solvers reused
    .venv/bin/python benchmarks/scale.py --sizes 120x24 --solvers reused --repeat 4
    .venv/bin/python benchmarks/scale.py --sizes 120x24 --solvers reused --repeat 3 --ceiling

This machine's speed drifts by up to half within minutes, so a serial run and
an mpirun made one after the other can differ by more than the speed-up itself:
``--repeat N`` runs every setting N times in turn and keeps each one's fastest.
``--ceiling`` adds two serial runs made at once, one per core: they share only the
machine (caches, memory, the host), so ``2 × alone / slower of the two`` is the most
any two-process run of the same work can gain here; the mpirun's speed-up is then
also printed as a share of that ceiling.

Solvers (``solver.factorization``, docs/model.md §7.7): "every-iteration" (a MUMPS
LU of every tangent, the default up to 20k unknowns), "petsc" (the same with
PETSc's own LU, serial only), "every-step" (GMRES preconditioned by a MUMPS
factorisation made once a step), "reused" (the same factors kept across steps,
renewed when GMRES needs more than 20 iterations; the default above 20k unknowns).
The factorisations made are printed per step.
Figures go to stdout, results/benchmarks/scale.csv and scale.png.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import resource
import shutil
import subprocess
import sys
import time
from pathlib import Path

# the repository's .venv when this python3 lacks rftfem (scripts/repository_python.py)
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))
import repository_python  # noqa: E402

repository_python.ensure()

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "demos" / "swimming_sheet.toml"
SIZES = ["20x4", "40x8", "80x16", "120x24", "240x48"]
SOLVERS = {
    "every-iteration": ["-factorization", "every-iteration"],
    "petsc": ["-factorization", "every-iteration", "-pc_factor_mat_solver_type", "petsc"],
    "every-step": ["-factorization", "every-step"],
    "reused": ["-factorization", "reused"],
}


def one(size: str, steps: int, solver: str) -> None:
    """In a child (under mpirun or not): run, print one JSON line on rank 0."""
    from mpi4py import MPI

    import rftfem  # noqa: F401
    from rftfem.integration.simulation import Simulation
    from rftfem.scene.reading import load_scene

    nx, ny = (int(v) for v in size.split("x"))
    scene = load_scene(SCENE, [f"mesh.divisions=[{nx}, {ny}]", "output.fields=false"])
    t_stop = steps * scene["time"]["dt"]

    class Enough(Exception):
        pass

    def stop(sim):
        if sim.t >= t_stop * (1 - 1e-12):
            raise Enough

    sim = Simulation(scene, quiet=True, petsc_args=list(SOLVERS[solver]), observers=[stop])
    try:
        # the t = 0 solve and the first step are left out: one-off costs (MUMPS's
        # analysis, first touches) that a run of thousands of steps does not see
        sim.observers.insert(0, lambda s: s.counts["steps"] == 1 and _mark(s))
        try:
            sim.run()
        except Enough:
            pass
        wall = time.perf_counter() - sim._mark["wall"]
        n = sim.counts["steps"] - 1
        its = sim.counts["newton_iterations"] - sim._mark["its"]
        jac = sim.solver.timings["jacobian"] - sim._mark["jacobian"]
        sol = sim.solver.timings["solve"] - sim._mark["solve"]
        made = sim.solver.factors.made - sim._mark["made"]
        rss = MPI.COMM_WORLD.allreduce(
            resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, op=MPI.MAX
        )
        dofs = sim.model.W.dofmap.index_map.size_global * sim.model.W.dofmap.index_map_bs
        if MPI.COMM_WORLD.rank == 0:
            print(
                json.dumps(
                    {
                        "dofs": dofs,
                        "steps": n,
                        "step_s": wall / n,
                        "its": its / n,
                        "jacobian_s": jac / max(its, 1),
                        "solve_s": sol / max(its, 1),
                        "peak_mb": rss / 1024,
                        "cuts": sim.counts["dt_cuts"],
                        "factorizations": made / n,
                    }
                )
            )
    finally:
        sim.close()


def _mark(sim):
    sim._mark = {
        "wall": time.perf_counter(),
        "its": sim.counts["newton_iterations"],
        "jacobian": sim.solver.timings["jacobian"],
        "solve": sim.solver.timings["solve"],
        "made": sim.solver.factors.made,
    }


def launch(size: str, steps: int, np_: int, solver: str) -> dict | None:
    return finish(start(size, steps, np_, solver), size, np_, solver)


def start(size: str, steps: int, np_: int, solver: str) -> subprocess.Popen:
    cmd = [sys.executable, __file__, "--one", size, "--steps", str(steps + 1), "--solvers", solver]
    if np_ > 1:
        here = Path(sys.executable).parent / "mpirun"
        mpirun = str(here) if here.exists() else shutil.which("mpirun")
        cmd = [mpirun, "-n", str(np_), *cmd]
    env = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    return subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)


def finish(child: subprocess.Popen, size: str, np_: int, solver: str) -> dict | None:
    stdout, stderr = child.communicate(timeout=3600)
    lines = [ln for ln in stdout.splitlines() if ln.startswith("{")]
    if child.returncode != 0 or not lines:
        print(
            f"  {size} np={np_} {solver}: failed (exit {child.returncode}) "
            f"{(stderr or stdout).strip().splitlines()[-1:]}"
        )
        return None
    return json.loads(lines[-1])


def pair(size: str, steps: int, solver: str) -> dict | None:
    """Two serial runs at once, one per core, sharing nothing but the machine: the
    slower one's figures.  ``2 × (one alone) / (slower of the pair)`` is the most two
    processes can gain on this machine for this work, whatever the parallel code."""
    children = [start(size, steps, 1, solver) for _ in range(2)]
    done = [finish(c, size, 1, solver) for c in children]
    if None in done:
        return None
    return max(done, key=lambda r: r["step_s"])


def skipped(solver: str, size: str, np_: int) -> bool:
    """PETSc's own LU is serial, and slower than MUMPS from 120x24 on."""
    return solver == "petsc" and (np_ > 1 or _cells(size) > 120 * 24)


def _cells(size: str) -> int:
    nx, ny = (int(v) for v in size.split("x"))
    return nx * ny


def fit(rows: list[dict]) -> float | None:
    import numpy as np

    big = [r for r in rows if r["dofs"] >= 20000]
    if len(big) < 2:
        return None
    x = np.log([r["dofs"] for r in big])
    y = np.log([r["step_s"] for r in big])
    return float(np.polyfit(x, y, 1)[0])


def plot(series: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4.2))
    for label, rows in series.items():
        if rows:
            ax.loglog([r["dofs"] for r in rows], [r["step_s"] for r in rows], "o-", label=label)
    ax.set_xlabel("unknowns")
    ax.set_ylabel("wall time per step (s)")
    ax.set_title("Swimming sheet: cost of a step against mesh size")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", nargs="+", default=SIZES, help="divisions NXxNY")
    parser.add_argument("--np", nargs="+", type=int, default=[1, 2], dest="nps")
    parser.add_argument("--solvers", nargs="+", default=list(SOLVERS), choices=list(SOLVERS))
    parser.add_argument("--steps", type=int, default=3)
    parser.add_argument(
        "--repeat",
        type=int,
        default=1,
        help="runs of each setting, taken in turn (serial, mpirun, serial, ...) "
        "so that the machine's drift falls on all alike; the fastest is kept",
    )
    parser.add_argument(
        "--ceiling",
        action="store_true",
        help="also run two serial runs at once (one per core) and print the "
        "speed-up they bound: the machine's, not the code's, limit",
    )
    parser.add_argument("--out", type=Path, default=Path("results/benchmarks"))
    parser.add_argument("--one", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.one:
        one(args.one, args.steps, args.solvers[0])
        return
    settings = [
        (solver, size, np_)
        for solver in args.solvers
        for size in args.sizes
        for np_ in args.nps
        if not skipped(solver, size, np_)
    ]
    if args.ceiling:
        settings += [
            (solver, size, "pair")
            for solver in args.solvers
            for size in args.sizes
            if 1 in args.nps and 2 in args.nps and not skipped(solver, size, 2)
        ]
    best = {}
    for round_ in range(args.repeat):
        for key in settings:
            r = (
                pair(key[1], args.steps, key[0])
                if key[2] == "pair"
                else launch(key[1], args.steps, key[2], key[0])
            )
            if r is None:
                continue
            print(
                f"  run {round_ + 1}/{args.repeat}: {key[0]}, {key[1]}, np={key[2]}: "
                f"{r['step_s']:.3f} s/step",
                flush=True,
            )
            if key not in best or r["step_s"] < best[key]["step_s"]:
                best[key] = r
    series, rows = {}, []
    for solver in args.solvers:
        for np_ in args.nps:
            if solver == "petsc" and np_ > 1:
                continue  # PETSc's own LU is serial
            label = f"{solver}, {np_} process{'es' if np_ > 1 else ''}"
            series[label] = []
            print(f"\n{label}")
            print(
                f"  {'mesh':>8s} {'unknowns':>9s} {'s/step':>8s} {'its/step':>8s} "
                f"{'Jacobian s':>10s} {'solve s':>8s} {'peak MB':>8s} {'LU/step':>8s}"
            )
            for size in args.sizes:
                if solver == "petsc" and _cells(size) > 120 * 24:
                    print(
                        f"  {size:>8s} skipped: PETSc's LU is already slower than MUMPS at 120x24"
                    )
                    continue
                r = best.get((solver, size, np_))
                if r is None:
                    continue
                r.update(mesh=size, np=np_, solver=solver)
                series[label].append(r)
                rows.append(r)
                print(
                    f"  {size:>8s} {r['dofs']:9d} {r['step_s']:8.3f} {r['its']:8.2f} "
                    f"{r['jacobian_s']:10.3f} {r['solve_s']:8.3f} {r['peak_mb']:8.0f} "
                    f"{r['factorizations']:8.2f}",
                    flush=True,
                )
            p = fit(series[label])
            if p is not None:
                print(f"  time per step ~ unknowns^{p:.2f} from 20k unknowns up")
    for solver in args.solvers:
        one_, two = series.get(f"{solver}, 1 process"), series.get(f"{solver}, 2 processes")
        if one_ and two:
            by = {r["mesh"]: r for r in one_}
            ups = [
                f"{r['mesh']} {by[r['mesh']]['step_s'] / r['step_s']:.2f}x"
                for r in two
                if r["mesh"] in by
            ]
            print(f"\n{solver}: speed-up of 2 processes: {', '.join(ups)}")
            bound = [
                (size, by[size]["step_s"], best[(solver, size, "pair")]["step_s"])
                for size in by
                if (solver, size, "pair") in best
            ]
            for size, alone, slower in bound:
                ceiling = 2 * alone / slower
                two_s = next((r["step_s"] for r in two if r["mesh"] == size), None)
                share = f"; mpirun reaches {alone / two_s / ceiling:.0%} of it" if two_s else ""
                print(
                    f"  {size}: two serial runs at once, the slower {slower:.3f} s/step "
                    f"against {alone:.3f} alone: this machine's ceiling for two processes "
                    f"is {ceiling:.2f}x{share}"
                )
    args.out.mkdir(parents=True, exist_ok=True)
    if rows:
        with open(args.out / "scale.csv", "w", newline="", encoding="utf-8") as f:
            writer = csv.DictWriter(f, fieldnames=list(rows[0]))
            writer.writeheader()
            writer.writerows(rows)
        plot(series, args.out / "scale.png")
        print(f"\nwritten {args.out / 'scale.csv'} and {args.out / 'scale.png'}")


if __name__ == "__main__":
    main()
