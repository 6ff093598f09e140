"""The walking sheet robot (demos/sheet_walking.toml): how far it walks in one
period of its field, against the field's frequency.

    python3 demos/sheet_walking.py [--out results/sheet_walking_sweep]
                                   [--freqs 0.25 0.5 1 2 4 8 16] [--periods 4]

Each run is the scene as shipped at f Hz: the field ramps up over the first
period, then rocks and swells for ``--periods`` periods more, at 256 steps a
period (BDF2, as the scene).  Measured from body.csv:

- the step: the centroid's advance along X over the last period (mm per field
  period, and in body lengths); the speed is the step times f;
- how steady the gait is: the change of the step from the period before the last.

At low frequency the sheet follows the field and every period takes the same
step (the quasi-static gait: 0.90-0.91 mm from 0.25 to 1 Hz); past 1 Hz the
liquid's drag keeps the arch from curling and tipping as far as the field asks
within a period, and the step shrinks (0.61 mm at 4 Hz, 0.30 mm at 16 Hz), while
the speed, step × f, still grows (4.8 mm/s at 16 Hz).

Runs whose folder already holds a finished run (summary.json "ok") are measured,
not repeated.  The default sweep is seven runs of about half a minute each.
Writes ``sweep.csv`` (one row per frequency) and ``sweep.png`` (step and speed
against frequency), and prints the table.  A film of one run:

    rftfem render results/sheet_walking_sweep/f1 --view xz --trail centroid --out walking.mp4

(the sweep's runs write no fields; ``--fields`` makes them).
"""

from __future__ import annotations

import argparse
import csv
import json
import sys
from pathlib import Path

# the repository's .venv when this python3 lacks rftfem (scripts/repository_python.py)
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))
import repository_python  # noqa: E402

repository_python.ensure()

import numpy as np

HERE = Path(__file__).resolve().parent
SCENE = HERE / "sheet_walking.toml"
LENGTH = 3.7
STEPS_PER_PERIOD = 256


def walk(f: float, periods: int, out: Path, fields: bool = False) -> dict:
    """Run the scene at ``f`` Hz (unless ``out`` holds a finished run) and measure it."""
    import rftfem

    end = (1 + periods) / f
    row = {"frequency_Hz": f, "status": "ok"}
    if not _finished(out):
        scene = rftfem.load_scene(
            SCENE,
            set={
                "parameters.f": f,
                "time.end": end,
                "time.dt": 1.0 / (STEPS_PER_PERIOD * f),
                "output.fields": fields,
            },
        )
        try:
            rftfem.run(scene, out=out)
        except rftfem.RunFailed as exc:
            row["status"] = f"failed at t = {exc.time:.4g}: {exc.reason}"
            return row
    body = np.genfromtxt(out / "body.csv", delimiter=",", names=True)
    steps = np.genfromtxt(out / "steps.csv", delimiter=",", names=True)
    t, x = body["time"], body["centroid_x"]
    last = np.interp(end, t, x) - np.interp(end - 1 / f, t, x)
    before = np.interp(end - 1 / f, t, x) - np.interp(end - 2 / f, t, x)
    its = steps["newton_its"]
    row.update(
        step_mm=last,
        step_body_lengths=last / LENGTH,
        speed_mm_s=last * f,
        change_from_period_before=last - before,
        newton_mean=float(its.mean()),
        newton_max=int(its.max()),
        steps=len(its),
    )
    return row


def _finished(out: Path) -> bool:
    try:
        return json.loads((out / "summary.json").read_text())["status"] == "ok"
    except (OSError, ValueError, KeyError):
        return False


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out", type=Path, default=Path("results/sheet_walking_sweep"))
    p.add_argument("--freqs", type=float, nargs="+", default=[0.25, 0.5, 1, 2, 4, 8, 16])
    p.add_argument(
        "--periods", type=int, default=4, help="periods after the ramp's (the last one is measured)"
    )
    p.add_argument("--fields", action="store_true", help="write fields (for films)")
    args = p.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    rows = []
    print(
        f"{'f Hz':>6} {'step mm':>9} {'step L':>7} {'speed mm/s':>11} {'change':>9} "
        f"{'Newton mean/max':>16}"
    )
    for f in sorted(args.freqs):
        row = walk(f, args.periods, args.out / f"f{f:g}", args.fields)
        rows.append(row)
        if row["status"] != "ok":
            print(f"{f:6g} {row['status']}", flush=True)
            continue
        print(
            f"{f:6g} {row['step_mm']:9.4f} {row['step_body_lengths']:7.3f} "
            f"{row['speed_mm_s']:11.4f} {row['change_from_period_before']:+9.1e} "
            f"{row['newton_mean']:10.2f} / {row['newton_max']}",
            flush=True,
        )
    keys = [
        "frequency_Hz",
        "status",
        "step_mm",
        "step_body_lengths",
        "speed_mm_s",
        "change_from_period_before",
        "newton_mean",
        "newton_max",
        "steps",
    ]
    with open(args.out / "sweep.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=keys)
        w.writeheader()
        for r in rows:
            w.writerow({k: r.get(k, "") for k in keys})
    _plot(rows, args.out / "sweep.png")
    print(f"wrote {args.out / 'sweep.csv'} and {args.out / 'sweep.png'}")
    return 0 if all(r["status"] == "ok" for r in rows) else 1


def _plot(rows, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ok = [r for r in rows if r["status"] == "ok"]
    f = [r["frequency_Hz"] for r in ok]
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(6, 6), sharex=True)
    a1.plot(f, [r["step_mm"] for r in ok], marker="o")
    a1.set_ylabel("step per field period (mm)")
    a1.set_ylim(bottom=0.0)
    right = a1.secondary_yaxis("right", functions=(lambda s: s / LENGTH, lambda b: b * LENGTH))
    right.set_ylabel("body lengths")
    a1.set_title("Sheet robot walking: field rocking ±0.5 rad, 1.5-3.5 mT")
    a2.plot(f, [r["speed_mm_s"] for r in ok], marker="o", color="C1")
    a2.set_ylabel("speed (mm/s)")
    a2.set_xlabel("field frequency (Hz)")
    a2.set_xscale("log")
    a2.set_yscale("log")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    sys.exit(main())
