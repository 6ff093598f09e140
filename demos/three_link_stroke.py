"""Designing the three-link swimmer's stroke with ``rftfem optimize``.

    python3 demos/three_link_stroke.py [--out results/three_link_stroke]
                                       [--method nelder-mead] [--budget 40] [--grid 7]
                                       [--no-film] [--reuse]

The scene ``demos/three_link_stroke.toml`` drives the Purcell swimmer's outer
edges with sinusoids, the right one with amplitude ``r A`` and phase ``φ``
relative to the left one.  This script asks which stroke carries the body
farthest per unit of dissipated energy, three ways:

1. ``rftfem optimize`` over ``motion.1.amplitude`` (r A on a log scale) and
   ``motion.1.phase``, maximising ``−rate(centre_uy, 1, 3) / mean(drag_power, 1, 3)``
   (mm per mJ, cycles 2 and 3);
2. the same search by brute force: a ``--grid`` × ``--grid`` grid of the same
   intervals (``rftfem optimize --method grid``);
3. the film of the best stroke (``rftfem render``, MP4) beside the search's
   history plot (``optimize.png``).

Each evaluation is an ordinary run folder under ``OUT/optimize`` or ``OUT/grid``.
Prints both optima, the runs each needed and their wall time, and writes
``OUT/stroke.md``.  Exit status 1 if the optimiser's best is worse than the
grid's best.  With ``--reuse`` finished runs are read, not repeated.
"""

from __future__ import annotations

import argparse
import csv
import math
import subprocess
import sys
import time
from pathlib import Path

# the repository's .venv when this python3 lacks rftfem (scripts/repository_python.py)
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))
import repository_python  # noqa: E402

repository_python.ensure()

HERE = Path(__file__).resolve().parent
SCENE = HERE / "three_link_stroke.toml"
A = 0.1  # mm: the left edge's amplitude (the scene's motion.0.amplitude)
VARY = ["--vary", "motion.1.amplitude=0.03:0.3:log", "--vary", "motion.1.phase=-3:-0.15"]
OBJECTIVE = "-rate(centre_uy, 1, 3)/mean(drag_power, 1, 3)"


def optimize(out: Path, method: str, budget: int, reuse: bool) -> tuple[dict, int, float]:
    """Run ``rftfem optimize``; the best row of optimize.csv, the runs, the wall time."""
    cmd = [
        sys.executable,
        "-m",
        "rftfem",
        "optimize",
        str(SCENE),
        *VARY,
        "--objective",
        OBJECTIVE,
        "--maximize",
        "--method",
        method,
        "--budget",
        str(budget),
        "--out",
        str(out),
        *(["--reuse"] if reuse else []),
    ]
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True)
    wall = time.perf_counter() - t0
    with open(out / "optimize.csv", newline="") as f:
        rows = [r for r in csv.DictReader(f) if r["status"] == "ok"]
    return max(rows, key=lambda r: float(r["objective"])), len(rows), wall


def describe(row: dict) -> str:
    r = float(row["motion.1.amplitude"]) / A
    phase = float(row["motion.1.phase"])
    return (
        f"r = {r:.4f}, φ = {phase:.4f} rad ({math.degrees(phase):.1f}°): "
        f"{float(row['objective']):.5g} mm/mJ ({row['folder']})"
    )


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=Path("results/three_link_stroke"))
    parser.add_argument("--method", default="nelder-mead", help="rftfem optimize --method")
    parser.add_argument("--budget", type=int, default=40, help="the optimiser's runs at most")
    parser.add_argument("--grid", type=int, default=7, help="grid points per parameter")
    parser.add_argument("--no-film", action="store_true", help="skip the film of the optimum")
    parser.add_argument("--reuse", action="store_true", help="read finished runs")
    args = parser.parse_args(argv)

    best, runs, wall = optimize(args.out / "optimize", args.method, args.budget, args.reuse)
    grid, grid_runs, grid_wall = optimize(args.out / "grid", "grid", args.grid**2, args.reuse)
    lines = [
        "| search | runs | wall (s) | best stroke |",
        "| --- | --- | --- | --- |",
        f"| rftfem optimize --method {args.method} | {runs} | {wall:.0f} | {describe(best)} |",
        f"| brute-force grid {args.grid} × {args.grid} | {grid_runs} | {grid_wall:.0f} | "
        f"{describe(grid)} |",
    ]
    print("\n".join(lines))
    (args.out / "stroke.md").write_text("\n".join(lines) + "\n", encoding="utf-8")
    if not args.no_film:
        film = args.out / "optimum.mp4"
        subprocess.run(
            [
                sys.executable,
                "-m",
                "rftfem",
                "render",
                str(args.out / "optimize" / best["folder"]),
                "--out",
                str(film),
            ],
            check=True,
        )
        print(f"film of the best stroke: {film}; history: {args.out / 'optimize' / 'optimize.png'}")
    if float(best["objective"]) < float(grid["objective"]):
        print("the optimiser's best is worse than the grid's", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
