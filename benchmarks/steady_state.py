"""How soon a run may stop once steady, per way of deciding it, on the swimming sheet.

The sheet's case I (demos/swimming_sheet.toml as shipped, 62 periods) is run
once to its end; its output rows are then fed period by period to the steady
watch of ``time.until = "periodic"`` (rftfem/integration/steady.py) with each way of
estimating the steady values:

- ``none``:   the period means themselves (the transient run out);
- ``aitken``: Aitken's Δ² of the last three periods;
- ``shanks``: Shanks' second transform of the last five where it is defined
  (rftfem's).

Printed per way and tolerance: the period at which the run would stop, the
speed it would report and its error against the exact RFT speed 0.49763 mm/s,
and against the 62-period run's value over periods 54-62 (+0.20 %).

Then the scene as shipped (``time.until = "periodic"``) runs as a user runs it,
``rftfem run demos/swimming_sheet.toml`` in a fresh process with the form cache
warm, and its process wall time (set-up included) and the steady speed read
from its summary.json are printed (goal of issue 34: within 0.5 % of the exact
speed in at most 20 s).

    .venv/bin/python benchmarks/steady_state.py
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

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
EXACT = 0.49763


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--tolerances", type=float, nargs="+", default=[1e-2, 1e-3, 1e-4])
    args = parser.parse_args(argv)
    from rftfem.integration.simulation import run
    from rftfem.integration.steady import SteadyWatch
    from rftfem.outputs.quantities import read_csv
    from rftfem.scene.reading import load_scene
    from rftfem.scene.time_rules import scene_period

    scene = load_scene(
        ROOT / "demos" / "swimming_sheet.toml",
        ["output.fields=false", "time.output_every=1", "time.until=end"],
    )
    period = scene_period({**scene, "time": {**scene["time"], "until": "periodic"}})
    with tempfile.TemporaryDirectory() as tmp:
        summary = run(scene, out_dir=Path(tmp), quiet=True)
        hp, probes = read_csv(Path(tmp) / "probes.csv")
        hb, body = read_csv(Path(tmp) / "body.csv")
    wall_per_period = summary["wall_s"]["total"] / round(scene["time"]["end"] / period)
    columns = hp[1:] + hb[1:]
    rows = np.hstack([probes, body[:, 1:]])
    t = rows[:, 0]
    n = round(t[-1] / period)
    print(f"case I: {n} periods, {wall_per_period:.2f} s a period on this machine")
    print(
        f"{'way':<7} {'tolerance':>9} {'stops after':>11} {'speed mm/s':>11} "
        f"{'vs exact':>9} {'wall s':>7}"
    )
    for tol in args.tolerances:
        for way in ("none", "aitken", "shanks"):
            watch = SteadyWatch(period, tol, columns, method=way)
            stop = None
            for k in range(1, n + 1):
                sel = (t >= (k - 1) * period * (1 - 1e-9)) & (t <= k * period * (1 + 1e-9))
                if watch.add_period(t[sel], rows[sel, 1:]):
                    stop = k
                    break
            if stop is None:
                print(f"{way:<7} {tol:>9.0e} {'not steady':>11}")
                continue
            speed = watch.result["values"]["centroid_x_rate"]
            print(
                f"{way:<7} {tol:>9.0e} {stop:>8} per {speed:>11.5f} "
                f"{100 * (speed / EXACT - 1):>+8.3f}% {stop * wall_per_period:>7.1f}"
            )
    as_shipped()


def as_shipped():
    """``rftfem run demos/swimming_sheet.toml`` as a user runs it (the forms compiled
    by the run above): the process's wall time and summary.json's steady speed."""
    import json
    import subprocess
    import time

    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        subprocess.run(
            [
                sys.executable,
                "-m",
                "rftfem",
                "run",
                str(ROOT / "demos" / "swimming_sheet.toml"),
                "--out",
                tmp,
                "--quiet",
            ],
            check=True,
            stdout=subprocess.DEVNULL,
        )
        wall = time.perf_counter() - t0
        summary = json.loads((Path(tmp) / "summary.json").read_text())
    steady = summary["steady"]
    speed = steady["values"]["front_ux_rate"]
    print(
        f"as shipped (rftfem run demos/swimming_sheet.toml, fresh process, warm cache): "
        f"{wall:.1f} s, steady after {steady['periods']} periods, front corner "
        f"{speed:.5f} mm/s ({100 * (speed / EXACT - 1):+.3f} % of exact; goal: 0.5 % in "
        f"<= 20 s)"
    )


if __name__ == "__main__":
    main()
