"""Error-controlled steps against fixed ones, on the bidirectional strip at 4 Hz.

The +X protocol (demos/bidirectional_strip.toml) to t = 2.2 s, its mean swimming
speed along Z from 0.2 s to the end (the window of demos/strip_sweep.sh).  Runs at
fixed steps of 1/(4 × N) s for N steps per period, and with ``time.tolerance`` (first
step 1/400 s, outputs every 0.02 s); each is compared with the finest fixed run.
Printed per run: steps, rejected steps, cuts, Newton iterations, wall time, the
speed and its difference from the finest; then which fixed step is the cheapest
within 2 % and whether a tolerance reached 2 % for less.

    .venv/bin/python benchmarks/strip_tolerance.py                    # ~25 minutes
    .venv/bin/python benchmarks/strip_tolerance.py --fixed 50 100 --tolerances 1e-2
    .venv/bin/python benchmarks/strip_tolerance.py --set time.rho_inf=0.5   # every run

Run it alone: the wall times are what it compares.  Figures also go to
results/benchmarks/strip_tolerance.csv.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

# the repository's .venv when this python3 lacks rftfem (scripts/repository_python.py)
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))
import repository_python  # noqa: E402

repository_python.ensure()

from step_cost import DEMOS, write_csv

from rftfem.outputs.quantities import evaluate

SCENE = DEMOS / "bidirectional_strip.toml"
END, START, FREQUENCY = 2.2, 0.2, 4.0
SPEED = f"rate(centroid_z, {START}, {END})"


def run(out: Path, sets: list[str]) -> dict:
    cmd = [
        sys.executable,
        "-m",
        "rftfem",
        "run",
        str(SCENE),
        "--out",
        str(out),
        "--quiet",
        "--set",
        f"time.end={END}",
        "--set",
        "output.fields=false",
    ]
    for s in sets:
        cmd += ["--set", s]
    done = subprocess.run(cmd, capture_output=True, text=True)
    if not (out / "summary.json").exists():  # refused before it ran (a bad --set)
        lines = done.stderr.strip().splitlines() or [f"exit {done.returncode}"]
        raise SystemExit(f"strip_tolerance: rftfem run refused the run: {lines[-1]}")
    summary = json.loads((out / "summary.json").read_text())
    c, wall = summary["counts"], summary["wall_s"]
    return {
        "status": summary["status"] if done.returncode == 0 else "failed",
        "steps": c["steps"],
        "rejected": c.get("rejected_steps", 0),
        "cuts": c["dt_cuts"],
        "newton": c["newton_iterations"],
        "wall_s": wall["total"] - wall["compile"],
        "speed": evaluate(SPEED, out) if done.returncode == 0 else float("nan"),
    }


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--fixed",
        type=int,
        nargs="*",
        default=[50, 100, 200],
        help="steps per period of the fixed runs; the last is the reference",
    )
    parser.add_argument("--tolerances", type=float, nargs="*", default=[1e-2, 3e-3, 1e-3])
    parser.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="a scene value for every run (as rftfem run --set)",
    )
    args = parser.parse_args(argv)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for n in args.fixed:
            dt = 1 / (FREQUENCY * n)
            r = run(Path(tmp) / f"fixed{n}", args.set + [f"time.dt={dt!r}", "time.output_every=1"])
            rows.append({"run": f"fixed, {n} steps per period", **r})
            print(rows[-1], flush=True)
        for tol in args.tolerances:
            r = run(
                Path(tmp) / f"tol{tol}",
                args.set + [f"time.tolerance={tol!r}", "time.dt=0.0025", "time.output_every=8"],
            )
            rows.append({"run": f"tolerance {tol:g}", **r})
            print(rows[-1], flush=True)
    reference = rows[len(args.fixed) - 1]["speed"]
    if args.set:
        print("\nevery run with " + " ".join(args.set))
    print(
        f"\n| run | steps | rejected | cuts | Newton its | wall (s) | speed (mm/s) | "
        f"vs {args.fixed[-1]} per period |\n|---|---|---|---|---|---|---|---|"
    )
    for r in rows:
        r["difference_pct"] = 100 * (r["speed"] / reference - 1)
        print(
            f"| {r['run']} | {r['steps']} | {r['rejected']} | {r['cuts']} | {r['newton']} | "
            f"{r['wall_s']:.0f} | {r['speed']:.4f} | {r['difference_pct']:+.2f} % |"
        )
    ok_fixed = [r for r in rows[: len(args.fixed) - 1] if abs(r["difference_pct"]) <= 2]
    ok_tol = [r for r in rows[len(args.fixed) :] if abs(r["difference_pct"]) <= 2]
    if ok_fixed:
        cheapest = min(ok_fixed, key=lambda r: r["wall_s"])
        print(f"\ncheapest fixed step within 2 %: {cheapest['run']}, {cheapest['wall_s']:.0f} s")
        best = min(ok_tol, key=lambda r: r["wall_s"]) if ok_tol else None
        if best:
            verdict = "less" if best["wall_s"] < cheapest["wall_s"] else "more"
            print(
                f"cheapest tolerance within 2 %: {best['run']}, {best['wall_s']:.0f} s "
                f"({verdict} than the fixed step)"
            )
        else:
            print("no tolerance reached 2 %")
    write_csv(Path("results/benchmarks/strip_tolerance.csv"), rows)


if __name__ == "__main__":
    main()
