"""Where the bidirectional magnetic strip steps out: the moment's lag behind the field.

The strip of demos/bidirectional_strip.toml (+X protocol) in a liquid of μ = 1.26e-8
N·s/mm² (the one its RFT coefficients were made for), at each field frequency
for a number of field periods after the 0.1 s ramp, 100 steps a period.  Per run
it prints the moment's lag behind the field, in turns, averaged over each field
period (the angle about the rotation axis, unwrapped): below a quarter turn the
strip rotates with the field; stepped out, the lag grows by whole turns.  The
table gives the turns lost and the range of the lag; docs/stokes.md §RFT against
Stokes quotes it.

    .venv/bin/python benchmarks/strip_step_out.py                   # Stokes, 10 × 2
    .venv/bin/python benchmarks/strip_step_out.py --liquid rft-mu --frequencies 96 104 112
    .venv/bin/python benchmarks/strip_step_out.py --mesh 5 1 --frequencies 80 84 88 96
    .venv/bin/python benchmarks/strip_step_out.py --refine 1 --frequencies 96

A Stokes run of 24 periods on 10 × 2 takes 3 to 5 minutes on one core.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
# the repository's .venv when this python3 lacks rftfem (scripts/repository_python.py)
sys.path.insert(0, str(ROOT / "scripts"))
import repository_python  # noqa: E402

repository_python.ensure()

import numpy as np  # noqa: E402

SCENE = ROOT / "demos" / "bidirectional_strip.toml"
MU = 1.26e-8
RAMP = 0.1
STEPS = 100
LIQUIDS = {
    "stokes": [
        "--unset",
        "fluid.drag",
        "--set",
        'fluid.model="stokes"',
        "--set",
        f"fluid.viscosity={MU}",
    ],
    "rft-mu": ["--unset", "fluid.drag", "--set", f"fluid.viscosity={MU}"],
}


def lags(folder: Path, frequency: float) -> np.ndarray:
    """The moment's lag behind the field (turns), averaged over each field period."""
    with open(folder / "body.csv", encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    t = np.array([float(r["time"]) for r in rows])
    field = np.array([[float(r[f"field_{k}"]) for k in "xy"] for r in rows])
    moment = np.array([[float(r[f"moment_{k}"]) for k in "xy"] for r in rows])
    after = t >= RAMP
    lag = (
        np.unwrap(np.arctan2(field[after, 1], field[after, 0]))
        - np.unwrap(np.arctan2(moment[after, 1], moment[after, 0]))
    ) / (2 * math.pi)
    period = np.floor((t[after] - RAMP) * frequency + 1e-9).astype(int)
    return np.array([lag[period == k].mean() for k in range(period.max())])


def run(frequency: float, args, folder: Path) -> dict:
    sets = [
        f"mesh.divisions=[{args.mesh[0]},{args.mesh[1]}]",
        f"magnetic.field.frequency={frequency}",
        f"time.dt={1 / (frequency * STEPS)!r}",
        f"time.end={RAMP + args.periods / frequency!r}",
        "time.output_every=1",
        'time.until="end"',
        "output.fields=false",
    ]
    if args.refine:
        sets.append(f"fluid.refine={args.refine}")
    cmd = [
        sys.executable,
        "-m",
        "rftfem",
        "run",
        str(SCENE),
        "--out",
        str(folder),
        "--quiet",
        *LIQUIDS[args.liquid],
        *[a for s in sets for a in ("--set", s)],
    ]
    done = subprocess.run(cmd, capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"{frequency} Hz: exit {done.returncode}: {done.stderr[-1500:]}")
    lag = lags(folder, frequency)
    lost = int(round(lag.max() - lag[0])) if len(lag) else 0
    wall = json.loads((folder / "summary.json").read_text())["wall_s"]["total"]
    return {
        "frequency": frequency,
        "periods": len(lag),
        "turns_lost": lost,
        "lag_min": float(lag.min()),
        "lag_max": float(lag.max()),
        "wall_s": wall,
        "lag": [round(float(v), 3) for v in lag],
    }


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--liquid", choices=list(LIQUIDS), default="stokes")
    parser.add_argument("--mesh", type=int, nargs=2, default=[10, 2])
    parser.add_argument("--refine", type=int, default=0, help="fluid.refine (Stokes)")
    parser.add_argument(
        "--frequencies", type=float, nargs="+", default=[80.0, 84.0, 88.0, 96.0, 104.0, 112.0]
    )
    parser.add_argument("--periods", type=int, default=24, help="field periods after the ramp")
    args = parser.parse_args(argv)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for f in args.frequencies:
            rows.append(run(f, args, Path(tmp) / f"f{f:g}"))
            print(json.dumps(rows[-1]), flush=True)
    print(
        f"\n{args.liquid}, {args.mesh[0]} × {args.mesh[1]}"
        + (f", fluid.refine = {args.refine}" if args.refine else "")
        + "\n"
    )
    print("| frequency (Hz) | periods | turns lost | lag (turns) | wall (s) |")
    print("| ---: | ---: | ---: | --- | ---: |")
    for r in rows:
        print(
            f"| {r['frequency']:g} | {r['periods']} | {r['turns_lost']} | "
            f"{r['lag_min']:.2f}–{r['lag_max']:.2f} | {r['wall_s']:.0f} |"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
