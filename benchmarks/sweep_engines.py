"""What the sweep engines cost: 16 runs of about 10 s, locally and on Dask.

The swimming sheet (demos/swimming_sheet.toml on a 10 × 2 mesh, run to a fixed
time, fields off) at 16 wave amplitudes, by ``rftfem sweep`` with

- ``--executor local --jobs 1``: the runs one after the other in the sweep's own
  process (imports and compiled forms loaded once);
- ``--executor local --jobs 2``: two child ``rftfem run`` processes at a time;
- ``--executor dask --jobs 1`` and ``--jobs 2``: a local Dask cluster of one and
  two single-threaded workers, each run a child ``rftfem run`` of the worker.

Printed per engine: the sweep's wall time, the runs' own time (summary.json's
``wall_s.total``: set-up, steps and outputs), the overhead per run (wall time ×
workers − the runs' own time, over the runs: starting processes, the engine's
scheduling, reading the results), and the speed-up of two workers over one.

    .venv/bin/python benchmarks/sweep_engines.py [--runs 16] [--end 2.0]
"""

from __future__ import annotations

import argparse
import csv
import json
import os
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
ENGINES = [("local", 1), ("local", 2), ("dask", 1), ("dask", 2)]


def sweep(out: Path, executor: str, jobs: int, runs: int, end: float) -> tuple[float, float]:
    """(wall time of the sweep, sum of the runs' own wall times)."""
    amplitudes = ",".join(f"{0.05 + 0.01 * k:.2f}" for k in range(runs))
    cmd = [
        sys.executable,
        "-m",
        "rftfem",
        "sweep",
        str(ROOT / "demos" / "swimming_sheet.toml"),
        "--vary",
        f"motion.0.amplitude={amplitudes}",
        "--quantity",
        "x=max(front_ux)",
        "--set",
        "mesh.divisions=[10,2]",
        "--set",
        "time.until=end",
        "--set",
        f"time.end={end!r}",
        "--set",
        "output.fields=false",
        "--executor",
        executor,
        "--jobs",
        str(jobs),
        "--out",
        str(out),
    ]
    env = dict(os.environ, OMP_NUM_THREADS="1")
    t0 = time.perf_counter()
    done = subprocess.run(cmd, capture_output=True, text=True, env=env)
    wall = time.perf_counter() - t0
    if done.returncode != 0:
        raise SystemExit(f"{executor} --jobs {jobs}: {done.stderr[-1500:]}")
    own = 0.0
    with open(out / "sweep.csv", encoding="utf-8") as fh:
        for row in csv.DictReader(fh):
            if row["status"] != "ok":
                raise SystemExit(f"{executor} --jobs {jobs}: a run failed: {row['reason']}")
            summary = json.loads((out / row["folder"] / "summary.json").read_text())
            own += float(summary["wall_s"]["total"])
    return wall, own


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=16)
    parser.add_argument(
        "--end", type=float, default=2.0, help="time.end of each run (2 s: about 10 s of run here)"
    )
    args = parser.parse_args(argv)
    results = {}
    with tempfile.TemporaryDirectory() as tmp:
        # one untimed run first: the forms compiled and the caches warm
        sweep(Path(tmp) / "warm", "local", 1, 1, args.end)
        for executor, jobs in ENGINES:
            wall, own = sweep(Path(tmp) / f"{executor}{jobs}", executor, jobs, args.runs, args.end)
            results[(executor, jobs)] = (wall, own)
            print(f"{executor} --jobs {jobs}: {wall:.1f} s", flush=True)
    print(f"\n{args.runs} runs of the sheet to t = {args.end:g} (10 × 2)\n")
    print(
        "| engine | workers | sweep wall (s) | runs' own (s) | overhead a run (s) | speed-up on 2 |"
    )
    print("| --- | ---: | ---: | ---: | ---: | ---: |")
    for executor, jobs in ENGINES:
        wall, own = results[(executor, jobs)]
        overhead = (wall * jobs - own) / args.runs
        speedup = f"{results[(executor, 1)][0] / wall:.2f}" if jobs == 2 else ""
        print(f"| {executor} | {jobs} | {wall:.1f} | {own:.1f} | {overhead:.2f} | {speedup} |")
    # local --jobs 1 runs in the sweep's process (no process to start); at two workers
    # both engines start a child `rftfem run` per run: the difference is the engine's
    extra = (results[("dask", 2)][0] - results[("local", 2)][0]) * 2 / args.runs
    print(f"\nDask over local child processes, 2 workers: {extra:+.2f} s a run")
    return 0


if __name__ == "__main__":
    sys.exit(main())
