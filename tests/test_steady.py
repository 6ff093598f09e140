"""Steady periodic states (``time.until = "periodic"``, rftfem/integration/steady.py): the
extrapolation of the period means, a run that stops once steady against an
exact transient and against the swimming sheet's exact speed, and bad keys."""

from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import run_scene, write_scene

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
    from rftfem.integration.steady import aitken, shanks

    k = np.arange(6.0)
    one = 3 + 2 * 0.8**k
    two = 3 - 2 * 0.8**k + 0.5 * 0.64**k
    v = np.stack([one, two, 0 * k + 3], axis=1)
    assert abs(aitken(v[-3:])[0] - 3) < 1e-12 and abs(aitken(v[-3:])[2] - 3) == 0
    assert abs(aitken(v[-3:])[1] - 3) > 1e-3  # two modes are beyond Aitken
    assert np.allclose(shanks(v[-5:]), 3, rtol=0, atol=1e-9)


def test_a_sideways_wobble_is_judged_against_the_swim():
    """A swimmer's sideways drift near zero is steady once it is still to the tolerance
    of the swim, not of its own size: rows of a body swimming along x at a speed
    settling as 1 − 0.5^k, wobbling in y with a swing of 1 % of the swim a period and
    a drift that jitters by 2e-4 of the swim.  Found steady after 12 periods at the
    settled speed; judged against the wobble alone (its swing), never."""
    from rftfem.integration.steady import SteadyWatch

    n, per = 24, 20
    t = np.linspace(0.0, n, n * per + 1)
    jitter = 2e-4 * np.sin(7.3 * np.floor(t))  # a period's drift jitters
    x = t + 0.5**t / np.log(0.5)  # x' = 1 − 0.5^t (+ a constant)
    y = 0.005 * np.sin(2 * np.pi * t) + np.cumsum(np.r_[0, np.diff(jitter)])
    rows = np.stack([x, y], axis=1)
    watch = SteadyWatch(1.0, 1e-3, ["centroid_x", "centroid_y"])
    for k in range(1, n + 1):
        sel = slice((k - 1) * per, k * per + 1)
        if watch.add_period(t[sel], rows[sel]):
            break
    print(f"steady after {k} periods: {watch.result['values']}")
    assert watch.result["reached"] and k <= 6
    assert watch.result["values"]["centroid_x_rate"] == pytest.approx(1.0, rel=1e-3)


def test_sinking_strip_stops_once_steady_at_the_terminal_speed(tmp_path):
    """A free strip falls from rest in drag: v = U (1 − e^{−t/τ}), U = ρ t g / C₃,
    τ = 5 periods. The run stops once steady, after 11 periods (running the
    transient out to the same tolerance would take over 30), with the centroid's
    rate within 1e-9 of −U (reached 3e-13) and summary.json saying so."""
    sim = run_scene(write_scene(tmp_path, SINKING), out_dir=tmp_path / "out")
    steady = json.loads((tmp_path / "out" / "summary.json").read_text())["steady"]
    rate = steady["values"]["centroid_z_rate"]
    print(
        f"steady after {steady['periods']} periods: rate {rate!r} against {-TERMINAL!r}; "
        f"estimated error {steady['estimated_errors']['centroid_z_rate']:.1e}"
    )
    assert steady["reached"] and steady["periods"] <= 15
    assert sim.t < 16 * steady["period"]
    assert abs(rate / -TERMINAL - 1) < 1e-9


@pytest.mark.parametrize(
    "text, sets, message",
    [
        (
            SINKING.replace("period = 2.0e-4\n", ""),
            [],
            'time.until = "periodic": no period in the scene (a travelling-wave motion or a '
            "rotating field); give time.period",
        ),
        (
            SINKING,
            ["time.dt=3e-5"],
            'time.dt: expected a whole fraction of the period 0.0002 (time.until = "periodic"), '
            "found 3e-05 (6.66667 steps a period)",
        ),
        (
            SINKING,
            ["time.output_every=3"],
            "time.output_every: expected a divisor of the 10 steps of a period (time.until = "
            '"periodic"), found 3',
        ),
        (SINKING, ["time.until=end"], 'time.period: only used with time.until = "periodic"'),
        (
            SINKING.replace("[fluid]\ndrag = [1.0e-7, 1.0e-7, 1.0e-7]\n", ""),
            ["time.scheme=static"],
            'time.until = "periodic" needs a run in time, found time.scheme = "static"',
        ),
    ],
)
def test_bad_periodic_settings_are_refused(tmp_path, text, sets, message):
    from rftfem.errors import SceneError
    from rftfem.scene.reading import load_scene

    with pytest.raises(SceneError) as err:
        load_scene(write_scene(tmp_path, text), sets)
    assert str(err.value) == message


def test_collect_reads_the_steady_values(tmp_path):
    """``rftfem collect`` has steady.reached and a steady.NAME column per extrapolated
    value: two sinking strips of different drag give their own terminal speeds."""
    from rftfem.outputs.collect import collect

    dirs = []
    for c3 in (1.0e-7, 2.0e-7):
        out = tmp_path / f"c{c3:g}"
        run_scene(write_scene(tmp_path, SINKING), f"fluid.drag=[1e-7, 1e-7, {c3}]", out_dir=out)
        dirs.append(out)
    header, rows, _ = collect(dirs)
    speeds = [float(r[header.index("steady.centroid_z_rate")]) for r in rows]
    print(dict(zip(header, rows[0])))
    assert [r[header.index("steady.reached")] for r in rows] == ["true", "true"]
    assert np.allclose(speeds, [-TERMINAL, -TERMINAL / 2], rtol=1e-9, atol=0)


def test_quantity_steady_reads_the_steady_values(tmp_path):
    """The quantity ``steady(NAME)`` (of collect, study and optimize) is summary.json's
    steady value: the sinking strip's terminal speed; a periodic run stopped at its
    end before it was steady has no value (Unavailable: an empty cell); a run of
    time.until = "end" or an unknown name is an error naming what is there."""
    from rftfem.outputs.quantities import Unavailable, evaluate

    scene = write_scene(tmp_path, SINKING)
    run_scene(scene, out_dir=tmp_path / "steady")
    assert evaluate("steady(centroid_z_rate)", tmp_path / "steady") == pytest.approx(
        -TERMINAL, rel=1e-9
    )
    run_scene(scene, "time.end=6e-4", out_dir=tmp_path / "short")  # 3 periods: too few
    with pytest.raises(Unavailable, match="stopped at time.end before it was steady"):
        evaluate("steady(centroid_z_rate)", tmp_path / "short")
    from rftfem.outputs.collect import collect  # there an empty cell, though the run finished
    from rftfem.outputs.quantities import parse

    header, rows, _ = collect([tmp_path / "short"], [("U", parse("steady(centroid_z_rate)"))])
    assert rows[0][header.index("status")] == "ok" and rows[0][header.index("U")] == ""
    with pytest.raises(Exception, match="no steady value 'centroid_z' .*centroid_z_rate"):
        evaluate("steady(centroid_z)", tmp_path / "steady")
    plain = write_scene(
        tmp_path, SINKING.replace('until = "periodic"\nperiod = 2.0e-4\n', ""), name="plain.toml"
    )
    run_scene(plain, "time.end=2e-4", out_dir=tmp_path / "end")
    with pytest.raises(Exception, match='not a run of time.until = "periodic"'):
        evaluate("steady(centroid_z_rate)", tmp_path / "end")


def _period_scene(**parts):
    """A scene dict with the keys scene_period reads."""
    return {"time": {"period": None, **parts.pop("time", {})}, **parts}


@pytest.mark.parametrize(
    "parts, period",
    [
        ({"motion": [{"kind": "travelling-wave", "angular_frequency": -8.0}]}, 2 * np.pi / 8.0),
        (
            {
                "motion": [
                    {"kind": "table", "values": [[0, 0], [1, 1]]},
                    {"kind": "travelling-wave", "angular_frequency": 4 * np.pi},
                ]
            },
            0.5,
        ),
        ({"magnetic": {"field": {"kind": "rotating", "frequency": 4.0}}}, 0.25),
        ({"magnetic": {"field": {"frequency": 5.0}}}, 0.2),  # rotating is the default kind
        (
            {
                "motion": [{"kind": "travelling-wave", "angular_frequency": 8 * np.pi}],
                "magnetic": {"field": {"kind": "rotating", "frequency": 4.0}},
            },
            0.25,
        ),
        ({"time": {"period": 0.3}, "magnetic": {"field": {"frequency": 4.0}}}, 0.3),
    ],
    ids=["wave", "wave-and-table", "field", "field-default-kind", "both-agree", "given"],
)
def test_period_is_read_from_the_drivers(parts, period):
    """time.until = "periodic" finds its period: a travelling wave's 2π/|ω| (a table
    motion has none), a rotating field's 1/f, both when they agree, time.period over
    both."""
    from rftfem.scene.time_rules import scene_period

    assert scene_period(_period_scene(**parts)) == pytest.approx(period, rel=1e-15)


def test_two_different_periods_are_refused():
    """A wave of period 0.5 and a field of 4 Hz: no single period; the message names
    both and asks for time.period."""
    from rftfem.errors import SceneError
    from rftfem.scene.time_rules import scene_period

    scene = _period_scene(
        motion=[{"kind": "travelling-wave", "angular_frequency": 4 * np.pi}],
        magnetic={"field": {"kind": "rotating", "frequency": 4.0}},
    )
    with pytest.raises(SceneError) as err:
        scene_period(scene)
    assert str(err.value) == (
        'time.until = "periodic": the drivers have different periods '
        "(motion.0: 0.5, magnetic.field: 0.25); give time.period"
    )
