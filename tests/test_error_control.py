"""Error-controlled time steps (``time.tolerance``, issue 16): tighter tolerances give
smaller errors against an exact solution, outputs land on their times, rejected steps
are counted apart from cuts, and a step below ``time.dt_min`` fails the run clearly.

The reference is the rigid magnetic plate of docs/verification.md case G turning
about its normal behind a field that rotates at twice its step-out rate (the angle
at a time from Adler's equation in closed form; tests/test_study.py).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from conftest import ROOT, run_scene, write_scene
from rftfem.errors import RunFailed
from rftfem.quantities import evaluate
from test_study import OMEGA, OMEGA_C, PROBES, adler_angle
from test_magnetic import PLATE

T_END = 0.5
#: the tolerance of the strip test (benchmarks/strip_tolerance.py measures its cost)
STRIP_TOL = 3e-3
SETS = ["magnetic.field.frequency=1.0", "magnetic.field.rotation_axis=[0, 0, 1]",
        f"time.end={T_END}", "output.fields=false", "time.output_every=5"]


def run_plate(tmp_path, name, *sets):
    out = tmp_path / name
    sim = run_scene(write_scene(tmp_path, PLATE + PROBES), *SETS, *sets, out_dir=out)
    rate = evaluate(f"spin(a, b, z, 0, {T_END})", out)
    exact = adler_angle(T_END, OMEGA, OMEGA_C) / T_END
    return sim, out, abs(rate - exact)


@pytest.mark.parametrize("scheme, order", [("backward-euler", 1), ("bdf2", 2)])
def test_tolerance_buys_accuracy(tmp_path, scheme, order):
    """The mean rate over [0, 0.5] at tolerances 1e-3 and 1e-5 from a first step of
    0.002, outputs every 0.1.  A local error per step of tol makes a global error of
    tol^(p/(p+1)) for a scheme of order p: 100 times tighter must buy at least 0.6 ×
    100^(p/(p+1)) times less error (6× for backward Euler, 13× for BDF2).  The
    estimate must scale as the control assumes (fewer than 10 % of the steps
    rejected), and every output lands on its time."""
    errors, steps = {}, {}
    for tol in (1e-3, 1e-5):
        sim, out, errors[tol] = run_plate(tmp_path, f"tol{tol}", f'time.scheme="{scheme}"',
                                          "time.dt=0.002", f"time.tolerance={tol}",
                                          "time.output_every=50")
        c = sim.summary["counts"]
        steps[tol] = c["steps"]
        print(f"{scheme}, tolerance {tol}: error {errors[tol]:.3e}, {c['steps']} steps, "
              f"{c['rejected_steps']} rejected, {c['dt_cuts']} cuts")
        assert c["rejected_steps"] < 0.1 * c["steps"] and c["dt_cuts"] == 0
        t = np.loadtxt(out / "probes.csv", delimiter=",", skiprows=1)[:, 0]
        assert t == pytest.approx(np.arange(6) * 0.1, abs=1e-12)
        dts = np.loadtxt(out / "steps.csv", delimiter=",", skiprows=1)[:, 1]
        assert len(dts) == c["steps"] and dts.sum() == pytest.approx(T_END, abs=1e-12)
    gain = errors[1e-3] / errors[1e-5]
    print(f"error 100 times tighter: {gain:.1f} times smaller")
    assert gain > 0.6 * 100 ** (order / (order + 1))
    assert steps[1e-5] > steps[1e-3]


def test_rejected_steps_are_counted_apart(tmp_path):
    """A first step of 0.05, 25 times what the tolerance allows there: the control
    rejects the steps it would grow from it (counted as rejections, not cuts), and
    the accepted steps (steps.csv) are the summary's count."""
    sim, out, error = run_plate(tmp_path, "big", 'time.scheme="bdf2"', "time.dt=0.05",
                                "time.tolerance=1e-5", "time.output_every=1")
    c = sim.summary["counts"]
    print(f"counts {c}, error {error:.2e}")
    assert c["rejected_steps"] > 0 and c["dt_cuts"] == 0
    dts = np.loadtxt(out / "steps.csv", delimiter=",", skiprows=1)[:, 1]
    assert len(dts) == c["steps"] and dts[0] == 0.05 and dts[1:].max() < 0.05


def test_step_below_dt_min_fails_naming_it(tmp_path):
    with pytest.raises(RunFailed, match="time.dt_min"):
        run_plate(tmp_path, "floor", 'time.scheme="bdf2"', "time.dt=0.01",
                  "time.tolerance=1e-9", "time.dt_min=0.005")


def test_fixed_steps_unchanged_without_tolerance(tmp_path):
    """No tolerance: the fixed-step loop (the rows at every nominal step)."""
    sim, out, _ = run_plate(tmp_path, "fixed", 'time.scheme="bdf2"', "time.dt=0.01",
                            "time.output_every=1")
    assert sim.summary["counts"]["steps"] == 50 and sim.summary["counts"]["rejected_steps"] == 0
    assert math.isclose(np.loadtxt(out / "steps.csv", delimiter=",", skiprows=1)[:, 1].min(),
                        0.01)


@pytest.mark.slow
def test_strip_tolerance_reaches_the_fine_step_speed(tmp_path, cli_run):
    """The bidirectional strip at 4 Hz (+X protocol), mean speed along Z over
    [0.2, 2.2] s: with time.tolerance = TOL from a first step of 1/400 s it is within
    2 % of the same run at 200 fixed steps per period (which the strip's convergence
    study puts within 0.03 % of 100 per period).  Only the accuracy is tested; what it
    costs is benchmarks/strip_tolerance.py's."""
    scene = ROOT / "demos" / "bidirectional_strip.toml"
    common = ["time.end=2.2", "output.fields=false"]
    fine = cli_run(scene, tmp_path / "fine", [*common, "time.dt=0.00125", "time.output_every=1"])
    adaptive = cli_run(scene, tmp_path / "tol", [*common, f"time.tolerance={STRIP_TOL}",
                                                 "time.dt=0.0025", "time.output_every=8"])
    speed = {name: evaluate("rate(centroid_z, 0.2, 2.2)", out)
             for name, out in (("fine", fine), ("tol", adaptive))}
    print(speed, f"{100 * (speed['tol'] / speed['fine'] - 1):+.2f} %")
    assert abs(speed["tol"] / speed["fine"] - 1) < 0.02
