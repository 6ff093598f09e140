"""What a sweep of many small runs costs beyond their steps.

A sweep point is an ordinary run of a small scene: the swimming sheet on a
10 × 2 mesh, 16 steps a period, run until its speed is steady
(``demos/swimming_sheet.toml`` with ``time.until = "periodic"``), at one wave
amplitude b.  The benchmark

1. warms the form cache with one run (not counted: a cold compile is paid once
   per machine, not per sweep);
2. runs one point as a fresh ``rftfem run`` process, several times, and splits
   its wall time into what comes before the first step (the interpreter and
   imports, then summary.json's ``wall_s.setup``: mesh, forms, model) and the
   stepping (``total − setup``);
3. runs the sweep of ``--points`` amplitudes in this one process
   (``rftfem.studies.batch.run_here``, what ``rftfem study`` does one level at a time),
   and prints its wall time against the sum of its runs' stepping times.

The goal (issue 34): the in-process sweep costs at most 1.5 × the sum of its
runs' stepping times.  Figures go to stdout and results/benchmarks/sweep_cost.csv.

    .venv/bin/python benchmarks/sweep_cost.py                  # 50 points, ~2 minutes
    .venv/bin/python benchmarks/sweep_cost.py --points 10 --fresh 2
"""

from __future__ import annotations

import argparse
import csv
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

# the repository's .venv when this python3 lacks rftfem (scripts/repository_python.py)
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))
import repository_python  # noqa: E402

repository_python.ensure()

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "demos" / "swimming_sheet.toml"
PERIOD = 2 * 3.141592653589793 / 100.0
#: the small scene: 10 × 2 cells, 16 steps a period, at most 20 periods, no fields
SETS = [
    "mesh.divisions=[10,2]",
    f"time.dt={PERIOD / 16!r}",
    f"time.end={20 * PERIOD!r}",
    "time.until=periodic",
    "output.fields=false",
    "time.output_every=1",
]


def amplitude_sets(k: int, n: int) -> list[str]:
    b = 0.05 + 0.15 * k / max(n - 1, 1)
    return [*SETS, f"motion.0.amplitude={b!r}"]


def stepping(summary: dict) -> float:
    wall = summary["wall_s"]
    return wall["total"] - wall["setup"]


def fresh_process(folder: Path, sets: list[str]) -> dict:
    """One point as its own ``rftfem run``: the process's wall time and its summary."""
    cmd = [sys.executable, "-m", "rftfem", "run", str(SCENE), "--out", str(folder), "--quiet"]
    for s in sets:
        cmd += ["--set", s]
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - t0
    summary = json.loads((folder / "summary.json").read_text())
    return {
        "wall": wall,
        "setup": summary["wall_s"]["setup"],
        "stepping": stepping(summary),
        "before_setup": wall - summary["wall_s"]["total"],
    }


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--points", type=int, default=50, help="sweep points (default 50)")
    parser.add_argument(
        "--fresh", type=int, default=3, help="fresh-process runs of one point to time (default 3)"
    )
    args = parser.parse_args(argv)
    from rftfem.studies.batch import run_here

    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        # 1. the form cache warm (a fresh process, so this process stays cold)
        fresh_process(tmp / "warm", amplitude_sets(0, args.points))
        # 2. fresh processes
        fresh = [
            fresh_process(tmp / f"fresh-{i}", amplitude_sets(0, args.points))
            for i in range(args.fresh)
        ]
        best = min(fresh, key=lambda r: r["wall"])
        print(
            f"one point as a fresh process (best of {args.fresh}): {best['wall']:.2f} s = "
            f"{best['before_setup']:.2f} s interpreter and imports + {best['setup']:.2f} s "
            f"set-up (mesh, forms, model) + {best['stepping']:.2f} s stepping",
            flush=True,
        )
        # 3. the sweep in this process (its first run pays the imports)
        rows, t0 = [], time.perf_counter()
        for k in range(args.points):
            folder = tmp / f"point-{k:03d}"
            status = run_here(SCENE, amplitude_sets(k, args.points), folder)
            summary = json.loads((folder / "summary.json").read_text())
            rows.append(
                {
                    "point": k,
                    "status": status,
                    "setup_s": summary["wall_s"]["setup"],
                    "stepping_s": stepping(summary),
                    "steps": summary["counts"]["steps"],
                    "periods": (summary.get("steady") or {}).get("periods"),
                }
            )
        sweep = time.perf_counter() - t0
    steps_sum = sum(r["stepping_s"] for r in rows)
    failed = sum(r["status"] != 0 for r in rows)
    setups = sorted(r["setup_s"] for r in rows)
    print(
        f"sweep of {args.points} points in one process: {sweep:.1f} s; the runs' stepping "
        f"{steps_sum:.1f} s; ratio {sweep / steps_sum:.2f} (goal <= 1.5); set-up per run "
        f"first {rows[0]['setup_s']:.2f} s, median {setups[len(setups) // 2]:.2f} s"
        + (f"; {failed} runs failed" if failed else "")
    )
    print(
        f"the same sweep as fresh processes (estimated from the fresh runs): "
        f"{args.points * best['wall']:.0f} s, of which "
        f"{args.points * (best['wall'] - best['stepping']):.0f} s before the first steps; "
        f"ratio {best['wall'] / best['stepping']:.2f}"
    )
    out = ROOT / "results" / "benchmarks"
    out.mkdir(parents=True, exist_ok=True)
    with open(out / "sweep_cost.csv", "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    print(f"rows: {out / 'sweep_cost.csv'}")
    return 0 if not failed else 1


if __name__ == "__main__":
    sys.exit(main())
