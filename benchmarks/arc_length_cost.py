"""What an arc-length step costs against a load step, on the same problem.

An arc-length update solves the bordered system by block elimination on the
step's one factorisation: two back-substitutions instead of one, and one
residual more (the loads' derivative in the load factor, a forward
difference).  Here both ways follow the same stretch of a path that has no
limit point, so they take similar steps, and the costs per Newton update and
per step are compared directly:

- the pull-out of an open-ended cylinder (tests/pullout.py, 12 × 8 cells, 2125
  dofs) up to P/Pmax = 0.45, before its snap;
- a cantilever strip of ``--cells`` quadrilaterals under a tip force bending it
  through 90° (default 64 × 8, 12 675 dofs).

Printed per problem and way: steps, Newton updates, wall seconds (solve loop
only), seconds per update and per step, and the share of residual, Jacobian and
linear-solve time.

    .venv/bin/python benchmarks/arc_length_cost.py
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

# the repository's .venv when this python3 lacks rftfem (scripts/repository_python.py)
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))
import repository_python  # noqa: E402

repository_python.ensure()

ROOT = Path(__file__).resolve().parents[1]

STRIP = """
title = "cantilever strip under a tip force"
[mesh]
length = 10.0
width = 1.0
divisions = [{nx}, {ny}]
[shell]
thickness = 0.1
E = 1.2e6
nu = 0.3
[time]
end = 1.0
dt = 0.1
[[boundary]]
where = "x=0"
fix = ["clamped"]
[[load]]
kind = "edge-force"
where = "x=L"
value = [0.0, 0.0, -3.0]
[output]
fields = false
"""


def run(scene_file: Path, sets: list[str]):
    import time

    from rftfem.integration.simulation import Simulation
    from rftfem.scene.reading import load_scene

    sim = Simulation(load_scene(scene_file, sets), out_dir=None, quiet=True)
    t0 = time.perf_counter()
    sim.run()
    wall = time.perf_counter() - t0
    s = sim.solver
    row = {
        "steps": sim.counts["steps"],
        "updates": sim.counts["newton_iterations"],
        "wall": wall,
        "residuals": s.calls["residual"],
        "jacobians": s.calls["jacobian"],
        "residual_s": s.timings["residual"],
        "jacobian_s": s.timings["jacobian"],
        "solve_s": s.timings["solve"],
        "load_factor": sim.load_factor,
    }
    sim.close()
    return row


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cells", type=int, nargs=2, default=[64, 8], metavar=("NX", "NY"))
    args = parser.parse_args()
    sys.path.insert(0, str(ROOT / "tests"))
    from pullout import octant_cylinder, scene_text

    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        octant_cylinder(tmp / "pullout.msh", 12, 8)
        (tmp / "pullout.toml").write_text(scene_text(dt=0.05, end=0.45))
        (tmp / "strip.toml").write_text(STRIP.format(nx=args.cells[0], ny=args.cells[1]))
        problems = {
            "pull-out to 0.45": tmp / "pullout.toml",
            f"strip {args.cells[0]}x{args.cells[1]}": tmp / "strip.toml",
        }
        print(
            f"{'problem':<18} {'way':<11} {'steps':>5} {'updates':>7} {'wall s':>7} "
            f"{'ms/update':>9} {'ms/step':>8}  residuals  jacobians  "
            "residual/jacobian/solve s"
        )
        for name, scene in problems.items():
            run(scene, ["time.end=0.1", "time.dt=0.1"])  # compile the forms first
            for way in ("static", "arc-length"):
                r = run(scene, [f"time.scheme={way}"])
                print(
                    f"{name:<18} {way:<11} {r['steps']:>5} {r['updates']:>7} "
                    f"{r['wall']:>7.2f} {1e3 * r['wall'] / r['updates']:>9.1f} "
                    f"{1e3 * r['wall'] / r['steps']:>8.1f}  {r['residuals']:>9} "
                    f"{r['jacobians']:>10}  {r['residual_s']:.2f}/{r['jacobian_s']:.2f}/"
                    f"{r['solve_s']:.2f}",
                    flush=True,
                )


if __name__ == "__main__":
    main()
