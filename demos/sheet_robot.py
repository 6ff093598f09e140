"""The sheet robot (demos/sheet_robot.toml): swimming speed against the field's
frequency and strength, and where the sheet stops following the field.

    python3 demos/sheet_robot.py [--out results/sheet_robot] [--freqs 1 2 4 8 16 32 64 128]
                                 [--fields 1 2 4] [--periods 8] [--settle 1.0] [--window 0.5]

Each run drives the scene's sheet with a field of b mT whose direction swings
±1 rad about Z at f Hz, ramped up over the first two periods, for ``--periods``
periods at 128 steps a period (BDF2, as the scene).  Measured over the last half of the run:

- the swimming speed: the centroid's mean velocity along X (mm/s, and body
  lengths per second);
- the bend: the size of the sheet's net magnetic moment (body.csv's moment_x..z),
  which is zero for the flat sheet (its magnetization turns once along it) and
  grows as the sheet bends into its C, averaged over the window, and over the
  largest of the same field strength (a slow swing's).  A sheet that follows
  the field bends as far as in a slow swing; past its relaxation rate it bends
  less.

Runs whose folder already holds a finished run (summary.json "ok") are measured,
not repeated.  The whole default sweep is long (the 128 Hz runs take some 24 000
steps each); ``--freqs`` and ``--fields`` pick a part of it.

Writes ``sweep.csv`` (one row per run) and ``sweep.png`` (speed and bend
against frequency, one curve per field strength), and prints the table.
"""

from __future__ import annotations

import argparse
import csv
import sys
from pathlib import Path

# the repository's .venv when this python3 lacks rftfem (scripts/repository_python.py)
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))
import repository_python  # noqa: E402

repository_python.ensure()

import numpy as np

HERE = Path(__file__).resolve().parent
SCENE = HERE / "sheet_robot.toml"
LENGTH = 3.7
SWING = 1.0  # rad: the field's direction swings ±SWING about Z
STEPS_PER_PERIOD = 128


def field(b_mT: float, f: float) -> list[str]:
    """The field's formulas: b mT, swinging ±SWING about Z at f Hz, ramped over two periods."""
    b = b_mT * 1e-6  # N/(A·mm)
    ramp = f"min(1, {f!r}*t/2)"
    angle = f"{SWING!r}*sin(2*pi*{f!r}*t)"
    return [f"{b!r}*{ramp}*sin({angle})", "0", f"{b!r}*{ramp}*cos({angle})"]


def swim(
    b_mT: float, f: float, periods: int, out: Path, settle: float = 1.0, window: float = 0.5
) -> dict:
    import rftfem

    span = max(periods / f, window)
    end = 2 / f + settle + span
    row = {"field_mT": b_mT, "frequency_Hz": f, "status": "ok"}
    if not _finished(out):
        scene = rftfem.load_scene(
            SCENE,
            set={
                "magnetic.field.B": field(b_mT, f),
                "time.end": end,
                "time.dt": 1 / (STEPS_PER_PERIOD * f),
                "output.fields": False,
            },
        )
        try:
            rftfem.run(scene, out=out)
        except rftfem.RunFailed as exc:
            row["status"] = f"failed: {exc}"
            return row
    body = rftfem.Result(out).body
    t = body["time"].to_numpy()
    x = body["centroid_x"].to_numpy()
    inside = t >= end - span - 1e-12
    speed = (x[inside][-1] - x[inside][0]) / (t[inside][-1] - t[inside][0])
    moment = body[["moment_x", "moment_y", "moment_z"]].to_numpy()[inside]
    row.update(
        speed_mm_s=speed,
        body_lengths_s=speed / LENGTH,
        moment=float(np.linalg.norm(moment, axis=1).mean()),
    )
    return row


def _finished(out: Path) -> bool:
    """Whether ``out`` holds a finished run (its summary says "ok")."""
    import rftfem

    try:
        return rftfem.Result(out).ok
    except rftfem.SceneError:  # no run folder there yet
        return False


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out", type=Path, default=Path("results/sheet_robot"))
    p.add_argument("--freqs", type=float, nargs="+", default=[1, 2, 4, 8, 16, 32, 64, 128])
    p.add_argument(
        "--fields", type=float, nargs="+", default=[1, 2, 4], help="field strengths in mT"
    )
    p.add_argument("--periods", type=int, default=8)
    p.add_argument("--settle", type=float, default=1.0, help="seconds after the ramp")
    p.add_argument("--window", type=float, default=0.5, help="shortest measured span (s)")
    args = p.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    rows = []
    print(f"{'B mT':>5} {'f Hz':>6} {'speed mm/s':>11} {'L/s':>7} {'|Q| A·mm²':>10}")
    for b in args.fields:
        mine = []
        for f in sorted(args.freqs):
            row = swim(b, f, args.periods, args.out / f"b{b:g}_f{f:g}", args.settle, args.window)
            rows.append(row)
            mine.append(row)
            if row["status"] != "ok":
                print(f"{b:5g} {f:6g} {row['status']}", flush=True)
                continue
            print(
                f"{b:5g} {f:6g} {row['speed_mm_s']:11.4f} {row['body_lengths_s']:7.3f} "
                f"{row['moment']:10.3f}",
                flush=True,
            )
        largest = max((r["moment"] for r in mine if r["status"] == "ok"), default=None)
        for r in mine:
            if r["status"] == "ok":
                r["bend"] = r["moment"] / largest
    print(
        "bend (|Q| over the largest of its field strength): "
        + "; ".join(
            f"{r['field_mT']:g} mT {r['frequency_Hz']:g} Hz {r['bend']:.2f}"
            for r in rows
            if r["status"] == "ok"
        )
    )
    keys = ["field_mT", "frequency_Hz", "status", "speed_mm_s", "body_lengths_s", "moment", "bend"]
    with open(args.out / "sweep.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=keys)
        w.writeheader()
        for r in rows:
            w.writerow({k: r.get(k, "") for k in keys})
    _plot(rows, args.out / "sweep.png")
    print(f"wrote {args.out / 'sweep.csv'} and {args.out / 'sweep.png'}")
    return 0


def _plot(rows, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a1, a2) = plt.subplots(2, 1, figsize=(6, 6), sharex=True)
    for b in sorted({r["field_mT"] for r in rows}):
        ok = sorted(
            (r for r in rows if r["field_mT"] == b and r["status"] == "ok"),
            key=lambda r: r["frequency_Hz"],
        )
        f = [r["frequency_Hz"] for r in ok]
        a1.plot(f, [r["speed_mm_s"] for r in ok], marker="o", label=f"{b:g} mT")
        a2.plot(f, [r["bend"] for r in ok], marker="o", label=f"{b:g} mT")
    a1.axhline(0.0, lw=0.6, color="grey")
    a1.set_ylabel("speed along X (mm/s)")
    a1.set_xscale("log")
    a1.set_title("Sheet robot: field swinging ±1 rad about Z")
    a1.legend(fontsize=8)
    a2.axhline(0.5, ls="--", lw=0.8, color="grey")
    a2.set_ylabel("bend: |Q| / its largest")
    a2.set_xlabel("frequency (Hz)")
    a2.set_xscale("log")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    sys.exit(main())
