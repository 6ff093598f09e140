"""Whole runs in Stokes flow against RFT: what a user waits for.

The swimming sheet as shipped (demos/swimming_sheet.toml, case I: T/32, steady
by ``time.until = "periodic"``), run by ``rftfem run`` in a child process:

* ``rft``: the scene as shipped (resistive-force theory, 20 × 4);
* ``stokes-10x2`` and ``stokes-20x4``: ``[fluid] model = "stokes"`` (water's μ) on
  the 10 × 2 mesh (within 0.4 % of the converged speed, docs/stokes.md) and on
  the shipped 20 × 4, the layer's factors kept (the default);
* ``…-every``: the same with ``fluid.factors = "every-update"`` (a factorisation
  and a derivative at every Newton update);
* ``…-wall``: a no-slip wall 2 below the sheet (``[fluid.wall]``).

With ``--steps K`` every run takes K steps (``time.until = "end"``) instead of
running to its steady state, for per-step figures.  With ``--before REV`` each
Stokes case is also run by the rftfem of commit REV (a git worktree in a
temporary folder, this .venv's Python and compiled forms), and the table shows
before, after and their ratio.  Printed: per run the steps, Newton updates, the
seconds of the steps (summary.json's total less its set-up) and a step, the
whole process's seconds (start-up, the layer's rules and error estimate, the
steps, outputs; forms already compiled) and its ratio to the RFT run's.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/stokes_runs.py --steps 40
    .venv/bin/python benchmarks/stokes_runs.py --cases rft stokes-10x2 stokes-20x4
    .venv/bin/python benchmarks/stokes_runs.py --steps 40 --before 8c1acd3
    .venv/bin/python benchmarks/stokes_runs.py --cases stokes-60x12 --steps 4 --np 2

``stokes-60x12`` (3025 nodes, not in the default list) is the size at which to
compare one process with two; the JSON lines give each step's seconds.  The
``direct-…`` cases (not in the default list) run the blobs' matrix-free direct
sums (``fluid.operator = "direct"``): on the shipped mesh, and on 4983 nodes
with and without the wall.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
# the repository's .venv when this python3 lacks rftfem (scripts/repository_python.py)
sys.path.insert(0, str(ROOT / "scripts"))
import repository_python  # noqa: E402

repository_python.ensure()

SHEET = ROOT / "demos" / "swimming_sheet.toml"
STOKES = [
    "--unset",
    "fluid.drag",
    "--set",
    'fluid.model="stokes"',
    "--set",
    "fluid.viscosity=1.0e-9",
]
WALL = ["--set", "fluid.wall.point=[0.0,0.0,-2.0]", "--set", "fluid.wall.normal=[0.0,0.0,1.0]"]
DIRECT = ["--set", 'fluid.method="blobs"', "--set", 'fluid.operator="direct"']
CASES = {
    "rft": [],
    "stokes-10x2": [*STOKES, "--set", "mesh.divisions=[10,2]"],
    "stokes-10x2-every": [
        *STOKES,
        "--set",
        "mesh.divisions=[10,2]",
        "--set",
        'fluid.factors="every-update"',
    ],
    "stokes-10x2-wall": [*STOKES, "--set", "mesh.divisions=[10,2]", *WALL],
    "stokes-20x4": [*STOKES],
    "stokes-20x4-every": [*STOKES, "--set", 'fluid.factors="every-update"'],
    "stokes-20x4-wall": [*STOKES, *WALL],
    # 3025 nodes: what two processes share (with --np 2 against 1)
    "stokes-60x12": [*STOKES, "--set", "mesh.divisions=[60,12]"],
    # the blobs' matrix-free direct sums: the shipped mesh, and 4983 nodes
    "direct-20x4": [*STOKES, *DIRECT],
    "direct-75x16": [*STOKES, *DIRECT, "--set", "mesh.divisions=[75,16]"],
    "direct-75x16-wall": [*STOKES, *DIRECT, "--set", "mesh.divisions=[75,16]", *WALL],
}


def run(
    case: str, out: Path, steps: int | None, source: Path | None = None, processes: int = 1
) -> dict:
    """One run of ``case`` into ``out`` (by the checkout at ``source`` if given, under
    ``mpirun -n processes`` if more than one)."""
    args = list(CASES[case])
    if source is not None:  # an earlier rftfem knows no fluid.factors (it made them all)
        pairs = [args[i : i + 2] for i in range(0, len(args), 2)]
        args = [a for pair in pairs if "fluid.factors" not in pair[1] for a in pair]
    if steps:
        dt = 2 * 3.141592653589793 / 100.0 / 32  # the demo's T/32 (ω = 100)
        args += ["--set", 'time.until="end"', "--set", f"time.end={steps * dt!r}"]
    env = dict(os.environ)
    if source is not None:
        env["PYTHONPATH"] = str(source) + os.pathsep + env.get("PYTHONPATH", "")
    cmd = [sys.executable, "-m", "rftfem", "run", str(SHEET), "--out", str(out), "--quiet", *args]
    if processes > 1:
        cmd = ["mpirun", "-n", str(processes), *cmd]
        env.update(
            OMPI_ALLOW_RUN_AS_ROOT="1",
            OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
            OMPI_MCA_rmaps_base_oversubscribe="1",
        )
    t0 = time.perf_counter()
    # (``-m`` puts the working folder first on the path: the checkout that runs)
    done = subprocess.run(cmd, env=env, capture_output=True, text=True, cwd=source or ROOT)
    wall = time.perf_counter() - t0
    if done.returncode != 0:
        raise SystemExit(f"{case}: exit {done.returncode}: {done.stderr[-1500:]}")
    summary = json.loads((out / "summary.json").read_text())
    seconds = summary["wall_s"]
    return {
        "case": case,
        "steps": summary["counts"]["steps"],
        "newton": summary["counts"]["newton_iterations"],
        "process": wall,
        "setup": seconds["setup"],
        "run": seconds["total"] - seconds["setup"],
        "speed": (summary.get("steady") or {}).get("values", {}).get("front_ux_rate"),
        "steps_s": _step_seconds(out),
    }


def _step_seconds(out: Path) -> list[float]:
    """Each step's wall seconds (steps.csv)."""
    import csv

    with open(out / "steps.csv", encoding="utf-8") as f:
        return [round(float(r["wall_s"]), 3) for r in csv.DictReader(f)]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--cases",
        nargs="+",
        choices=list(CASES),
        default=[c for c in CASES if c != "stokes-60x12" and not c.startswith("direct")],
    )
    parser.add_argument("--steps", type=int, help="every run takes this many steps")
    parser.add_argument("--before", help="also run the Stokes cases by this commit")
    parser.add_argument("--np", type=int, default=1, help="run under mpirun -n NP")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        source = None
        if args.before:
            source = tmp / "before"
            subprocess.run(
                ["git", "-C", str(ROOT), "worktree", "add", "--detach", str(source), args.before],
                check=True,
                capture_output=True,
            )
        try:
            rows = []
            for case in args.cases:
                rows.append(run(case, tmp / case, args.steps, processes=args.np))
                if source is not None and case != "rft":
                    rows[-1]["before"] = run(
                        case, tmp / f"{case}-before", args.steps, source, args.np
                    )
                print(json.dumps(rows[-1]), flush=True)
        finally:
            if source is not None:
                subprocess.run(
                    ["git", "-C", str(ROOT), "worktree", "remove", "--force", str(source)],
                    capture_output=True,
                )
    rft = next((r for r in rows if r["case"] == "rft"), None)
    print(
        "\n| run | steps | Newton updates | steps (s) | s a step | whole process (s) | "
        "× RFT | before (s) | after / before |"
    )
    print("| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
    for r in rows:
        ratio = f"{r['process'] / rft['process']:.2g}" if rft else "—"
        before = r.get("before")
        print(
            f"| {r['case']} | {r['steps']} | {r['newton']} | {r['run']:.1f} | "
            f"{r['run'] / max(r['steps'], 1):.3f} | {r['process']:.1f} | {ratio} | "
            + (
                f"{before['process']:.1f} | {r['process'] / before['process']:.2f} |"
                if before
                else "— | — |"
            )
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
