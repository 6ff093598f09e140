"""Steady periodic states (``time.until = "periodic"``, rftfem/steady.py): the
extrapolation of the period means, a run that stops once steady against an
exact transient and against the swimming sheet's exact speed, and bad keys."""

from __future__ import annotations

import json

import numpy as np
import pytest

from conftest import DEMOS, run_scene, write_scene

SINKING = """
title = "a free strip sinking in drag"
[mesh]
length = 2.0
width = 0.5
divisions = [4, 1]
[shell]
thickness = 0.1
E = 1.2e6
nu = 0.3
density = 1.0e-9
[fluid]
drag = [1.0e-7, 1.0e-7, 1.0e-7]
[time]
end = 2.0e-2
dt = 2.0e-5
until = "periodic"
period = 2.0e-4
[[load]]
kind = "gravity"
value = [0.0, 0.0, -9810.0]
ramp = "constant"
"""
#: (ρ t g / C₃): the terminal speed; ρ t / C₃: the time constant of the approach
TERMINAL, TAU = 1.0e-9 * 0.1 * 9810.0 / 1.0e-7, 1.0e-9 * 0.1 / 1.0e-7


def test_extrapolations_are_exact_for_their_modes():
    """Aitken's Δ² is exact for one geometric mode, Shanks' e₂ for two (r and r²), and
    a constant column stays itself."""
    from rftfem.steady import aitken, shanks

    k = np.arange(6.0)
    one = 3 + 2 * 0.8**k
    two = 3 - 2 * 0.8**k + 0.5 * 0.64**k
    v = np.stack([one, two, 0 * k + 3], axis=1)
    assert abs(aitken(v[-3:])[0] - 3) < 1e-12 and abs(aitken(v[-3:])[2] - 3) == 0
    assert abs(aitken(v[-3:])[1] - 3) > 1e-3  # two modes are beyond Aitken
    assert np.allclose(shanks(v[-5:]), 3, rtol=0, atol=1e-9)


def test_sinking_strip_stops_once_steady_at_the_terminal_speed(tmp_path):
    """A free strip falls from rest in drag: v = U (1 − e^{−t/τ}), U = ρ t g / C₃,
    τ = 5 periods. The run stops once steady, after 11 periods (running the
    transient out to the same tolerance would take over 30), with the centroid's
    rate within 1e-9 of −U (reached 3e-13) and summary.json saying so."""
    sim = run_scene(write_scene(tmp_path, SINKING), out_dir=tmp_path / "out")
    steady = json.loads((tmp_path / "out" / "summary.json").read_text())["steady"]
    rate = steady["values"]["centroid_z_rate"]
    print(f"steady after {steady['periods']} periods: rate {rate!r} against {-TERMINAL!r}; "
          f"estimated error {steady['estimated_errors']['centroid_z_rate']:.1e}")
    assert steady["reached"] and steady["periods"] <= 15
    assert sim.t < 16 * steady["period"]
    assert abs(rate / -TERMINAL - 1) < 1e-9


@pytest.mark.long
def test_swimming_sheet_case_I_steady_in_a_few_periods(tmp_path):
    """demos/swimming_sheet.toml (case I as shipped, 4×20, 32 steps a period) with
    time.until = "periodic": steady after 5 periods (the shipped run measures
    periods 54-62), its speed within 0.5 % of the exact RFT speed 0.49763 mm/s
    (reached +0.197 %, as the 62-period run's +0.20 %)."""
    run_scene(DEMOS / "swimming_sheet.toml", "time.until=periodic", "output.fields=false",
              out_dir=tmp_path / "out")
    steady = json.loads((tmp_path / "out" / "summary.json").read_text())["steady"]
    speed = steady["values"]["centroid_x_rate"]
    print(f"steady after {steady['periods']} periods: {speed:.5f} mm/s, "
          f"{100 * (speed / 0.49763 - 1):+.3f} % of exact")
    assert steady["reached"] and steady["periods"] <= 10
    assert abs(speed / 0.49763 - 1) < 0.005


@pytest.mark.parametrize("text, sets, message", [
    (SINKING.replace("period = 2.0e-4\n", ""), [],
     'time.until = "periodic": no period in the scene (a travelling-wave motion or a '
     "rotating field); give time.period"),
    (SINKING, ["time.dt=3e-5"],
     'time.dt: expected a whole fraction of the period 0.0002 (time.until = "periodic"), '
     "found 3e-05 (6.66667 steps a period)"),
    (SINKING, ["time.output_every=3"],
     "time.output_every: expected a divisor of the 10 steps of a period (time.until = "
     '"periodic"), found 3'),
    (SINKING, ["time.until=end"], 'time.period: only used with time.until = "periodic"'),
    (SINKING.replace("[fluid]\ndrag = [1.0e-7, 1.0e-7, 1.0e-7]\n", ""), ["time.scheme=static"],
     'time.until = "periodic" needs a run in time, found time.scheme = "static"'),
])
def test_bad_periodic_settings_are_refused(tmp_path, text, sets, message):
    from rftfem.errors import SceneError
    from rftfem.scene import load_scene

    with pytest.raises(SceneError) as err:
        load_scene(write_scene(tmp_path, text), sets)
    assert str(err.value) == message


def test_collect_reads_the_steady_values(tmp_path):
    """``rftfem collect`` has steady.reached and a steady.NAME column per extrapolated
    value: two sinking strips of different drag give their own terminal speeds."""
    from rftfem.collect import collect

    dirs = []
    for c3 in (1.0e-7, 2.0e-7):
        out = tmp_path / f"c{c3:g}"
        run_scene(write_scene(tmp_path, SINKING), f"fluid.drag=[1e-7, 1e-7, {c3}]",
                  out_dir=out)
        dirs.append(out)
    header, rows, _ = collect(dirs)
    speeds = [float(r[header.index("steady.centroid_z_rate")]) for r in rows]
    print(dict(zip(header, rows[0])))
    assert [r[header.index("steady.reached")] for r in rows] == ["true", "true"]
    assert np.allclose(speeds, [-TERMINAL, -TERMINAL / 2], rtol=1e-9, atol=0)
