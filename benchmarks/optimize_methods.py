"""Which method of ``rftfem optimize`` needs the fewest runs: figures, nothing asserted.

    python3 benchmarks/optimize_methods.py [--problems trade-off,trade-off-2,stroke]
                                           [--methods nelder-mead,powell,cobyla,l-bfgs-b]
                                           [--budget 40] [--out results/optimize_methods]

Each method of ``rftfem optimize`` runs on each problem from the same start with
the same budget; printed per problem and method: the runs it took until its best
objective was within 1 % and within 0.1 % of the known optimum, the runs it made
in all before it stopped, its best, and its wall time.  The problems:

- ``trade-off``: the cantilever of demos/end_shear.toml under a small tip force,
  its thickness t costing λ per unit: f(t) = w(t) + λ t, least at t* = 0.1 where
  f* = 0.05333 (tests/test_optimize.py derives it); start t = 0.16;
- ``trade-off-2``: the same with the modulus as a second design variable costing
  λ₂ per unit, f(t, E) = w + λ₁ t + λ₂ E, least at t = 0.1, E = 1.2e6 where
  f* = 0.066667 (λ₁ = 3 w*/t*, λ₂ = w*/E*); start t = 0.16, E = 3e6, E on a log scale;
- ``stroke``: demos/three_link_stroke.toml, the swim per dissipated energy over the
  right edge's amplitude and phase; the optimum of the rigid-link reference model
  (tests/rigid_links.py) is 2.0791e6 mm/mJ at r = 0.936, φ = −1.376 rad, which
  rftfem's discretisation puts 0.3 % lower.  About 8 s a run.
"""

from __future__ import annotations

import argparse
import csv
import subprocess
import sys
import time
from pathlib import Path

# the repository's .venv when this python3 lacks rftfem (scripts/repository_python.py)
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))
import repository_python  # noqa: E402

repository_python.ensure()

ROOT = Path(__file__).resolve().parents[1]
CANTILEVER = [
    "--set",
    "load.0.value=[0,0,0.004]",
    "--set",
    "time.dt=1",
    "--set",
    "mesh.divisions=[8,1]",
    "--set",
    "shell.thickness=0.16",
]
PROBLEMS = {
    "trade-off": dict(
        scene="demos/end_shear.toml",
        optimum=0.4 / 3 * 0.1 + 0.04,
        sense="--minimize",
        args=[
            "--vary",
            "shell.thickness=0.05:0.2",
            "--objective",
            "tip_uz@end + 0.4*scene(shell.thickness)",
            *CANTILEVER,
        ],
    ),
    "trade-off-2": dict(
        scene="demos/end_shear.toml",
        optimum=0.4 / 3 * 0.1 * 2 + 0.04,
        sense="--minimize",
        args=[
            "--vary",
            "shell.thickness=0.05:0.2",
            "--vary",
            "shell.E=3e5:1e7:log",
            "--objective",
            f"tip_uz@end + 0.4*scene(shell.thickness) + {0.04 / 3 / 1.2e6!r}*scene(shell.E)",
            *CANTILEVER,
            "--set",
            "shell.E=3e6",
        ],
    ),
    "stroke": dict(
        scene="demos/three_link_stroke.toml",
        optimum=2.0791e6,
        sense="--maximize",
        args=[
            "--vary",
            "motion.1.amplitude=0.03:0.3:log",
            "--vary",
            "motion.1.phase=-3:-0.15",
            "--objective",
            "-rate(centre_uy, 1, 3)/mean(drag_power, 1, 3)",
        ],
    ),
}


def runs_to(rows, optimum: float, tolerance: float, maximize: bool):
    """The evaluation at which the best so far came within ``tolerance`` of ``optimum``."""
    best = None
    for i, r in enumerate(rows, 1):
        if r["status"] != "ok":
            continue
        v = float(r["objective"])
        best = v if best is None or (v > best if maximize else v < best) else best
        if abs(best - optimum) <= tolerance * abs(optimum):
            return i
    return None


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--problems",
        default="trade-off,trade-off-2",
        help=f"comma-separated, of {', '.join(PROBLEMS)} (default: the two fast ones)",
    )
    parser.add_argument("--methods", default="nelder-mead,powell,cobyla,l-bfgs-b")
    parser.add_argument("--budget", type=int, default=40)
    parser.add_argument("--out", type=Path, default=Path("results/optimize_methods"))
    args = parser.parse_args(argv)
    print(
        f"{'problem':<12} {'method':<12} {'to 1 %':>7} {'to 0.1 %':>9} {'runs':>5} "
        f"{'best':>12} {'wall s':>7}"
    )
    for name in args.problems.split(","):
        problem = PROBLEMS[name]
        for method in args.methods.split(","):
            out = args.out / name / method
            cmd = [
                sys.executable,
                "-m",
                "rftfem",
                "optimize",
                str(ROOT / problem["scene"]),
                *problem["args"],
                problem["sense"],
                "--method",
                method,
                "--budget",
                str(args.budget),
                "--out",
                str(out),
            ]
            t0 = time.perf_counter()
            done = subprocess.run(cmd, capture_output=True, text=True)
            wall = time.perf_counter() - t0
            if done.returncode != 0:
                print(f"{name:<12} {method:<12} failed: {done.stderr.strip()[-200:]}")
                continue
            with open(out / "optimize.csv", newline="") as f:
                rows = list(csv.DictReader(f))
            maximize = problem["sense"] == "--maximize"
            ok = [float(r["objective"]) for r in rows if r["status"] == "ok"]
            best = (max if maximize else min)(ok) if ok else float("nan")
            one, tenth = (runs_to(rows, problem["optimum"], tol, maximize) for tol in (1e-2, 1e-3))
            print(
                f"{name:<12} {method:<12} {one if one else '-':>7} {tenth if tenth else '-':>9} "
                f"{len(rows):>5} {best:>12.6g} {wall:>7.1f}",
                flush=True,
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
