"""The bidirectional magnetic strip (REFERENCES.md I, issue 4), on the demo scene
with short runs: the two protocols swim in opposite senses with equal speeds, a
high-frequency run keeps going and slows, and mpirun matches serial.  (The run
above step-out that issue 4 asks for is not here yet: see the README.)"""

from __future__ import annotations

import csv
import functools
import subprocess
import sys

import numpy as np
import pytest

from conftest import DEMOS, ROOT, run_scene

SCENE = DEMOS / "bidirectional_strip.toml"
RAMP = 0.1


class Track:
    """Observer: the centroid after every step."""

    def __init__(self):
        self.t, self.centroid = [], []

    def __call__(self, sim):
        m = sim.model
        self.t.append(sim.t)
        self.centroid.append(m.centroid())

    def net_z(self, t0, t1):
        t, z = np.array(self.t), np.array(self.centroid)[:, 2]
        return z[int(np.argmin(abs(t - t1)))] - z[int(np.argmin(abs(t - t0)))]


@functools.lru_cache(maxsize=None)
def swim(frequency, periods, steps_per_period, direction=(1.0, 0.0, 0.0)):
    """Run the demo scene for phase 1 and ``periods`` field periods (each distinct
    run once per test session: the 10 Hz +X run serves two tests)."""
    end = RAMP + periods / frequency
    track = Track()
    sim = run_scene(SCENE, f"magnetic.field.frequency={float(frequency)}", f"time.end={end!r}",
                    f"time.dt={1 / (frequency * steps_per_period)!r}",
                    f"magnetic.field.direction={list(direction)}", observers=[track])
    return sim, track, end


def test_opposite_protocols_swim_opposite_ways():
    """Field ramped along +X, then along −X: net displacements along the rotation
    axis over the last two field periods have opposite signs and magnitudes within
    5 % (issue 4's acceptance), and are a real swim: over 1 mm in two periods
    (reached: 3.946 mm, 0.39 body lengths).

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
    print(f"net displacement along Z, last two periods: +X {net[1.0]:+.5f} mm, "
          f"−X {net[-1.0]:+.5f} mm")
    assert net[1.0] * net[-1.0] < 0
    assert abs(abs(net[1.0]) / abs(net[-1.0]) - 1) < 0.05
    assert abs(net[1.0] + net[-1.0]) < 1e-6 * abs(net[1.0])
    assert min(abs(net[1.0]), abs(net[-1.0])) > 1.0


def test_high_frequency_keeps_running_and_slows():
    """At 40 Hz the run completes (no failed step, no NaN) and the mean speed is
    below half the speed at 10 Hz (reached: 0.80 against 19.7 mm/s).

    This is not the issue's "above step-out" case: at 40 Hz the total moment
    still follows the field (the sweep measured slip at 128 Hz, none at 64 Hz;
    the rigid-rotor estimate of the phase-1 shape is 287 Hz).  The speed drops because the strip no longer
    holds its chiral shape at this sperm number (≈ 3.2)."""
    speeds = {}
    for f, periods in ((10.0, 3), (40.0, 8)):
        sim, track, end = swim(f, periods, 50, (1.0, 0.0, 0.0))
        # dt cuts are retried steps, not failed ones; the run must reach its end
        print(f"{f} Hz: counts {sim.summary['counts']}")
        assert sim.summary["status"] == "ok" and sim.t == pytest.approx(end)
        assert np.isfinite(np.array(track.centroid)).all()
        # from 0.1 s after the ramp: the strip's last curling then is over
        # (demos/bidirectional_strip.py SETTLE); 2 periods at 10 Hz, 4 at 40 Hz
        t0 = RAMP + 0.1
        speeds[f] = track.net_z(t0, end) / (end - t0)
    print(f"mean speed along Z: {speeds}")
    assert abs(speeds[40.0]) < 0.5 * abs(speeds[10.0])


@pytest.mark.mpi
def test_strip_mpirun_matches_serial(tmp_path, cli_run):
    """`mpirun -n 2` on the strip (phase 1 and one field period at 10 Hz) gives the
    serial centroid path (body.csv) to 1e-6 mm."""
    overrides = ["magnetic.field.frequency=10.0", "time.end=0.2", "time.dt=0.002",
                 "time.output_every=5", "output.fields=false"]
    paths = {}
    for n in (1, 2):
        out = cli_run(SCENE, tmp_path / f"np{n}", overrides, np=n)

        rows = list(csv.DictReader(open(out / "body.csv", encoding="utf-8")))
        paths[n] = np.array([[float(r[f"centroid_{k}"]) for k in "xyz"] for r in rows])
    drift = np.abs(paths[1] - paths[1][0]).max()
    print(f"largest centroid excursion {drift:.4f} mm; serial vs np 2: "
          f"{np.abs(paths[2] - paths[1]).max():.2e} mm")
    assert drift > 0.3
    assert np.abs(paths[2] - paths[1]).max() < 1e-6


@pytest.mark.slow
def test_bidirectional_strip_demo(tmp_path):
    """The demo as shipped: both protocols, 8 periods at 4 Hz; it checks opposite
    senses and 5 % itself (exit status) and writes its figures."""
    done = subprocess.run([sys.executable, str(DEMOS / "bidirectional_strip.py"),
                           "--out", str(tmp_path)], cwd=ROOT, capture_output=True, text=True)
    print(done.stdout[-3000:])
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    for name in ("groups.md", "trajectory.csv", "shape_phase1.png", "trajectory.png"):
        assert (tmp_path / name).stat().st_size > 0
