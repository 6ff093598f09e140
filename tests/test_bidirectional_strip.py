"""The bidirectional magnetic strip (docs/verification.md case I, issue 4), on the demo scene
with short runs: the two protocols swim in opposite senses with equal speeds, the
strip steps out above a frequency and its run keeps going and slows, and mpirun
matches serial."""

from __future__ import annotations

import csv
import importlib.util
import subprocess
import sys
import tomllib

import numpy as np
import pytest
from conftest import DEMOS, ROOT, run_scene

SCENE = DEMOS / "bidirectional_strip.toml"
RAMP = tomllib.loads(SCENE.read_text())["magnetic"]["field"]["ramp_time"]
#: just under and above step-out on the demo scene (demos/strip_sweep.sh, docs/magnetic_strip.md)
F_UNDER, F_OVER = 64.0, 128.0


class Track:
    """Observer: the centroid after every step."""

    def __init__(self):
        self.t, self.centroid = [], []

    def __call__(self, sim):
        m = sim.model
        self.t.append(sim.t)
        self.centroid.append(m.centroid())

    def net_z(self, t0, t1):
        """z(t1) − z(t0) of the centroid; both must be step times."""
        t, z = np.array(self.t), np.array(self.centroid)[:, 2]
        i0, i1 = int(np.argmin(abs(t - t0))), int(np.argmin(abs(t - t1)))
        assert abs(t[i0] - t0) < 1e-9 and abs(t[i1] - t1) < 1e-9, "no step at the times asked"
        return z[i1] - z[i0]


def swim(frequency, periods, steps_per_period, direction=(1.0, 0.0, 0.0)):
    """Run the demo scene for phase 1 and ``periods`` field periods."""
    end = RAMP + periods / frequency
    track = Track()
    sim = run_scene(
        SCENE,
        f"magnetic.field.frequency={float(frequency)}",
        f"time.end={end!r}",
        f"time.dt={1 / (frequency * steps_per_period)!r}",
        f"magnetic.field.direction={list(direction)}",
        observers=[track],
    )
    return sim, track, end


@pytest.mark.long
def test_opposite_protocols_swim_opposite_ways():
    """Field ramped along +X, then along −X: net displacements along the rotation
    axis over the last two field periods have opposite signs and magnitudes within
    5 % (issue 4's acceptance), and are a real swim: over 1 mm in two periods
    (reached: 3.816 mm, 0.38 body lengths). The +X protocol swims towards −Z and
    the −X one towards +Z: the out-of-plane tilt of the ends decides which way the
    end flips and so the hand of the folded shape (docs/magnetic_strip.md), and the field turns
    right-handedly about +Z.

    With q₀(end2) = −q₀(end1) the −X protocol is the +X one inverted through the
    strip's centre, so here the magnitudes agree to round-off, and that is
    asserted too (1e-6): a term that breaks the symmetry (a sign, a frame that
    depends on the normal's orientation) would show.  What the physics has to
    get right is that there is a swim at all."""
    f = 10.0
    net = {}
    for direction in ((1.0, 0.0, 0.0), (-1.0, 0.0, 0.0)):
        sim, track, end = swim(f, 3, 50, direction)
        # cuts resolve the ends' fast flips (time.max_rotation); none may fail
        print(f"field along {direction}: counts {sim.summary['counts']}")
        assert sim.summary["status"] == "ok"
        assert sim.summary["director_unit_error"] < 1e-10
        net[direction[0]] = track.net_z(end - 2 / f, end)
    print(
        f"net displacement along Z, last two periods: +X {net[1.0]:+.5f} mm, −X {net[-1.0]:+.5f} mm"
    )
    assert net[1.0] < 0 < net[-1.0]
    assert abs(abs(net[1.0]) / abs(net[-1.0]) - 1) < 0.05
    assert abs(net[1.0] + net[-1.0]) < 1e-6 * abs(net[1.0])
    assert min(abs(net[1.0]), abs(net[-1.0])) > 1.0


def _sweep_run(tmp_path, demo, frequency, steps_per_period=100):
    """One run as demos/strip_sweep.sh makes it (settle 0.1 s after the ramp, then
    8 periods but at least 0.1 s), measured by the demo's own sweep code."""
    end = RAMP + demo.SETTLE + max(8 / frequency, 0.1)
    out = tmp_path / f"f{frequency:g}"
    sim = run_scene(
        SCENE,
        f"magnetic.field.frequency={float(frequency)}",
        f"time.end={end!r}",
        f"time.dt={1 / (frequency * steps_per_period)!r}",
        "time.output_every=1",
        "output.fields=false",
        out_dir=out,
    )
    return sim, demo.sweep_row(out)


def _demo_module():
    spec = importlib.util.spec_from_file_location(
        "bidirectional_strip", DEMOS / "bidirectional_strip.py"
    )
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.long
def test_above_step_out_completes_and_slows(tmp_path):
    """Issue 4's step-out acceptance on the demo scene, runs as the sweep makes
    them: at F_UNDER the total moment follows the field (|slip| < 0.05 turn per
    field turn, the demo's STEPPED_OUT_SLIP), at F_OVER it loses turns (slip > 0.3).  The
    stepped-out run completes (status ok, finite, |d| = 1) and its mean speed is
    below the speed at F_UNDER.

    Reached at the sweep's 100 steps per period: 64 Hz slip −0.0003, +3.318 mm/s
    (no cut); 128 Hz slip 1.558, +0.008 mm/s (at 50 per period: −0.0008, +3.33 with
    70 cuts; 1.55, +0.012).  Before the triads' in-plane frames were realigned
    (docs/magnetic_strip.md) the 64 Hz run failed at t = 0.3186 s."""
    demo = _demo_module()
    rows = {}
    for f in (F_UNDER, F_OVER):
        sim, row = _sweep_run(tmp_path, demo, f)
        print(f"{f} Hz: {row}, counts {sim.summary['counts']}")
        assert sim.summary["status"] == "ok"
        assert sim.summary["director_unit_error"] < 1e-10
        assert np.isfinite([row["speed"], row["slip"]]).all()
        rows[f] = row
    assert demo.STEPPED_OUT_SLIP == 0.05
    assert abs(rows[F_UNDER]["slip"]) < demo.STEPPED_OUT_SLIP
    assert rows[F_OVER]["slip"] > 0.3
    assert abs(rows[F_OVER]["speed"]) < abs(rows[F_UNDER]["speed"])


@pytest.mark.long
@pytest.mark.mpi
def test_strip_mpirun_matches_serial(tmp_path, cli_run):
    """`mpirun -n 2` on the strip (phase 1 and one field period at 10 Hz) gives the
    serial centroid path (body.csv) to 1e-10 mm (reached 1e-13 mm)."""
    overrides = [
        "magnetic.field.frequency=10.0",
        "time.end=0.2",
        "time.dt=0.002",
        "time.output_every=5",
        "output.fields=false",
    ]
    paths = {}
    for n in (1, 2):
        out = cli_run(SCENE, tmp_path / f"np{n}", overrides, np=n)

        rows = list(csv.DictReader(open(out / "body.csv", encoding="utf-8")))
        paths[n] = np.array([[float(r[f"centroid_{k}"]) for k in "xyz"] for r in rows])
    drift = np.abs(paths[1] - paths[1][0]).max()
    print(
        f"largest centroid excursion {drift:.4f} mm; serial vs np 2: "
        f"{np.abs(paths[2] - paths[1]).max():.2e} mm"
    )
    assert drift > 0.3
    assert np.abs(paths[2] - paths[1]).max() < 1e-10


@pytest.mark.slow
def test_bidirectional_strip_demo(tmp_path):
    """The demo as shipped: both protocols, 8 periods at 4 Hz; it checks opposite
    senses and 5 % itself (exit status) and writes its figures."""
    done = subprocess.run(
        [sys.executable, str(DEMOS / "bidirectional_strip.py"), "--out", str(tmp_path)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=3 * 3600,
    )  # slow: both protocols, about an hour
    print(done.stdout[-3000:])
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    for name in ("groups.md", "trajectory.csv", "shape_phase1.png", "trajectory.png"):
        assert (tmp_path / name).stat().st_size > 0
