"""Each shipped demo's headline figure at the demo's own settings, against its exact
or converged value (within 1 %).  The demos whose headline other tests already hold
at the shipped settings: the roll-up and the end shear (test_shell_benchmarks.py,
exact), the three-link swimmer (test_three_link.py, rigid links with inertia), the
scallop study's square loop (test_hinges.py, exact rigid links).  The list with the
figures reached is docs/accuracy.md's."""

from __future__ import annotations

import tomllib

import numpy as np
import pytest
from conftest import DEMOS, run_scene

EXACT_SHEET_I = 0.49763  # docs/verification.md case F, exact RFT


@pytest.mark.long
@pytest.mark.both_stacks
def test_swimming_sheet_as_shipped_swims_at_the_exact_speed(tmp_path):
    """demos/swimming_sheet.toml as shipped (4×20, dt = T/32, until the speed is
    steady): the front corner's steady speed in summary.json within 0.5 % of the
    exact RFT speed 0.49763 (docs/verification.md case F), found steady in at most
    8 periods (reached: +0.20 % after 5, as the 62-period run's mean over periods
    54-62; see docs/accuracy.md)."""
    sim = run_scene(DEMOS / "swimming_sheet.toml", "output.fields=false", out_dir=tmp_path)
    steady = sim.summary["steady"]
    speed = steady["values"]["front_ux_rate"]
    print(
        f"sheet as shipped: U = {speed:.5f} ({100 * (speed / EXACT_SHEET_I - 1):+.2f} %) "
        f"after {steady['periods']} periods, estimated error "
        f"{steady['estimated_errors']['front_ux_rate']:.1e}"
    )
    assert steady["reached"] and steady["periods"] <= 8
    assert abs(speed / EXACT_SHEET_I - 1) < 0.005


@pytest.mark.long
def test_swimming_sheet_steady_error_estimate_bounds_the_true_error(tmp_path):
    """The steady speed's estimated error in summary.json (the Aitken extrapolation's
    last change, docs/model.md §6.13) against its true error: the shipped sheet (steady
    to 1e-3 after 5 periods) against the same run steady to 1e-7 (12 periods; its own
    estimate 5e-10).  The estimate is 1 to 10 times the true error (reached: 4.7e-6
    against 2.0e-6, 2.4 times), and so is the 1e-5 run's (4.1e-8 against 1.3e-8)."""
    runs = {}
    for tol in (1e-3, 1e-5, 1e-7):
        sim = run_scene(
            DEMOS / "swimming_sheet.toml",
            "output.fields=false",
            f"time.steady_tolerance={tol}",
            "time.end=100",
        )
        steady = sim.summary["steady"]
        assert steady["reached"]
        runs[tol] = (
            steady["values"]["front_ux_rate"],
            steady["estimated_errors"]["front_ux_rate"],
            steady["periods"],
        )
    reference = runs[1e-7][0]
    for tol in (1e-3, 1e-5):
        value, estimate, periods = runs[tol]
        true = abs(value - reference)
        print(
            f"steady to {tol:g} after {periods} periods: U = {value!r}, estimated error "
            f"{estimate:.2e}, true {true:.2e} ({estimate / true:.1f} times)"
        )
        assert true <= estimate <= 10 * true
    assert runs[1e-7][1] < 1e-2 * abs(runs[1e-3][0] - reference)


def _strip_net(out, end, period):
    body = np.genfromtxt(out / "body.csv", delimiter=",", names=True)
    t, z = body["time"], body["centroid_z"]
    return float(np.interp(end, t, z) - np.interp(end - 2 * period, t, z))


@pytest.mark.slow
def test_bidirectional_strip_as_shipped_swims_as_with_finer_steps(tmp_path):
    """demos/bidirectional_strip.toml as shipped (field along +X, 4 Hz, 125 steps a
    period): the net displacement along the rotation axis over the last two field
    periods, the demo's headline, within 1 % of the same run at 200 steps a period
    (which the strip's time study puts within 0.03 % of its converged value)."""
    scene = tomllib.loads((DEMOS / "bidirectional_strip.toml").read_text())
    end, period = scene["time"]["end"], 1.0 / scene["magnetic"]["field"]["frequency"]
    shipped = tmp_path / "shipped"
    run_scene(DEMOS / "bidirectional_strip.toml", "output.fields=false", out_dir=shipped)
    fine = tmp_path / "fine"
    run_scene(
        DEMOS / "bidirectional_strip.toml",
        "output.fields=false",
        f"time.dt={period / 200!r}",
        "time.output_every=8",
        out_dir=fine,
    )
    a, b = _strip_net(shipped, end, period), _strip_net(fine, end, period)
    print(
        f"strip, last two periods: shipped {a:+.5f} mm, 200 a period {b:+.5f} mm "
        f"({100 * (a / b - 1):+.3f} %)"
    )
    assert abs(a / b - 1) < 0.01


@pytest.mark.slow
def test_sheet_robot_as_shipped_swims_as_with_finer_steps(tmp_path):
    """demos/sheet_robot.toml as shipped (BDF2, 128 steps a field period): the centroid's
    mean speed along X over the last second within 1 % of the same run at 256 steps
    a period (reached −0.2 %: 0.07470 against 0.07485 mm/s; backward Euler was far off,
    docs/magnetic_actuation.md)."""
    speeds = []
    for k, sets in ((1, []), (2, ["time.dt=0.0009765625"])):
        run_scene(
            DEMOS / "sheet_robot.toml", "output.fields=false", *sets, out_dir=tmp_path / f"dt{k}"
        )
        body = np.genfromtxt(tmp_path / f"dt{k}" / "body.csv", delimiter=",", names=True)
        t, x = body["time"], body["centroid_x"]
        speeds.append((np.interp(3.0, t, x) - np.interp(2.0, t, x)) / 1.0)
    print(
        f"sheet robot: {speeds[0]:.5f} mm/s as shipped, {speeds[1]:.5f} at half the step "
        f"({100 * (speeds[0] / speeds[1] - 1):+.2f} %)"
    )
    assert speeds[1] > 0.05  # it swims, along +X
    assert abs(speeds[0] / speeds[1] - 1) < 0.01


@pytest.mark.slow
def test_moving_magnet_as_shipped_follows_as_with_finer_steps(tmp_path):
    """demos/moving_magnet.toml as shipped (BDF2, 400 steps): the tip's path within 1 %
    of its range of the same run at four times the steps (reached 0.09 %)."""
    rows = []
    for k, sets in ((1, []), (4, ["time.dt=0.003125"])):
        run_scene(
            DEMOS / "moving_magnet.toml", "output.fields=false", *sets, out_dir=tmp_path / f"dt{k}"
        )
        rows.append(np.loadtxt(tmp_path / f"dt{k}" / "probes.csv", delimiter=",", skiprows=1))
    coarse, fine = rows
    fine = np.array([fine[np.argmin(abs(fine[:, 0] - t))] for t in coarse[:, 0]])
    spread = np.ptp(fine[:, 1:], axis=0)
    worst = (np.abs(coarse[:, 1:] - fine[:, 1:]) / spread).max()
    print(f"moving magnet: tip path within {100 * worst:.3f} % of its range")
    assert spread.max() > 1.0 and worst < 0.01


@pytest.mark.slow
def test_magnetic_snap_as_shipped_brackets_its_limit(tmp_path):
    """demos/magnetic_snap.py as shipped: the arc-length path's snap-through limit
    (2.716 mT) against two independent answers. Load steps of 1e-4 of the path's
    20 mT converge up to 0.99 of it and fail (exit 3, no equilibrium nearby)
    before 1.01 of it; in drag, the field held 5 % below it leaves the arch up
    and 5 % above snaps it through (the script's exit status)."""
    import sys

    sys.path.insert(0, str(DEMOS))
    import magnetic_snap

    from rftfem.errors import RunFailed

    assert magnetic_snap.main(["--out", str(tmp_path / "demo")]) == 0
    from rftfem.outputs.quantities import read_csv

    header, rows = read_csv(tmp_path / "demo" / "path" / "probes.csv")
    path = {name: rows[:, i] for i, name in enumerate(header)}
    top, bottom = magnetic_snap.limits(path)
    limit = path["load_factor"][top]
    print(
        f"snap-through limit {20 * limit:.4f} mT, "
        f"snap-back {20 * path['load_factor'][bottom]:+.4f} mT"
    )
    assert path["load_factor"][bottom] < 0  # bistable: the inverted arch needs a reversed field
    for factor, fails in ((0.99, False), (1.01, True)):
        sets = [
            "time.scheme=static",
            f"time.end={float(factor * limit)!r}",
            "time.dt=1e-4",
            "output.fields=false",
        ]
        try:
            run_scene(DEMOS / "magnetic_snap_path.toml", *sets, out_dir=tmp_path / f"lc{factor}")
            failed = False
        except RunFailed:
            failed = True
        print(f"load control to {factor} × the limit: {'fails' if failed else 'converges'}")
        assert failed == fails


#: demos/sheet_near_wall.toml's steady speeds at h = 1.5 and without the wall, extrapolated
#: to zero cell size from 10 × 2 (0.85531, 0.39084) and the shipped 20 × 4 at the layer's
#: order 1.5 (docs/stokes.md, "A sheet near a wall")
WALL_LIMIT, FREE_LIMIT = 0.85982, 0.39279


@pytest.mark.slow
def test_sheet_near_wall_as_shipped_has_the_refined_ratio(tmp_path):
    """demos/sheet_near_wall.toml as shipped (20 × 4) and the same without its wall:
    the speeds are those docs/stokes.md states (0.8582 and 0.3921, to 1e-3), each
    within 1 % of its extrapolated limit (reached −0.19 %, −0.18 %), and their ratio,
    the demo's headline, within 0.5 % of the limits' (reached 2.1888 against 2.1890;
    10 × 2 gives 2.1884)."""
    text = (DEMOS / "sheet_near_wall.toml").read_text()
    free = tmp_path / "free.toml"
    free.write_text(text[: text.index("[fluid.wall]")] + text[text.index("[time]") :])
    speeds = {}
    for name, scene in (("wall", DEMOS / "sheet_near_wall.toml"), ("free", free)):
        sim = run_scene(scene, "output.fields=false")
        steady = sim.summary["steady"]
        assert steady["reached"], name
        speeds[name] = steady["values"]["front_ux_rate"]
    ratio = speeds["wall"] / speeds["free"]
    print(f"near a wall: {speeds}, ratio {ratio:.4f} (limits: {WALL_LIMIT / FREE_LIMIT:.4f})")
    assert speeds["wall"] == pytest.approx(0.8582, rel=1e-3)
    assert speeds["free"] == pytest.approx(0.3921, rel=1e-3)
    assert speeds["wall"] == pytest.approx(WALL_LIMIT, rel=0.01)
    assert speeds["free"] == pytest.approx(FREE_LIMIT, rel=0.01)
    assert ratio == pytest.approx(WALL_LIMIT / FREE_LIMIT, rel=0.005)


#: demos/python_study.py: the difference from exact RFT at each amplitude, in percent
#: (docs/python.md)
STUDY_DIFFERENCES = {0.05: 0.011, 0.1: 0.081, 0.15: 0.197, 0.2: 0.358, 0.3: 0.807}


@pytest.mark.slow
def test_python_study_meets_exact_rft(tmp_path):
    """demos/python_study.py as shipped: each amplitude's steady speed within 1 % of
    the exact RFT speed and at the documented difference (to 0.02 points), which
    grows with the wave's slope as the sheet's points also move along X."""
    import csv
    import subprocess
    import sys

    done = subprocess.run(
        [sys.executable, str(DEMOS / "python_study.py"), "--out", str(tmp_path), "--jobs", "2"],
        capture_output=True,
        text=True,
        timeout=1200,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    with open(tmp_path / "study.csv", encoding="utf-8") as fh:
        rows = {float(r["b"]): r for r in csv.DictReader(fh)}
    assert sorted(rows) == sorted(STUDY_DIFFERENCES)
    for b, expected in STUDY_DIFFERENCES.items():
        difference = float(rows[b]["difference_percent"])
        assert abs(difference) < 1.0 and difference == pytest.approx(expected, abs=0.02), b
    assert (tmp_path / "study.png").stat().st_size > 10_000


def _pair_headline(folder):
    """Each strip's speed along Z over the last field period and the change of the
    two centroids' spacing (demos/magnetic_pair.py's table)."""
    import pandas as pd

    b = pd.read_csv(folder / "body.csv")
    last = b[b["time"] >= b["time"].iloc[-1] - 0.25 - 1e-9]
    span = last["time"].iloc[-1] - last["time"].iloc[0]
    speeds = [
        (last[f"{n}_centroid_z"].iloc[-1] - last[f"{n}_centroid_z"].iloc[0]) / span
        for n in ("left", "right")
    ]
    gap = np.hypot(
        b["right_centroid_x"] - b["left_centroid_x"], b["right_centroid_y"] - b["left_centroid_y"]
    )
    return np.array([*speeds, gap.iloc[-1] - gap.iloc[0]])


@pytest.mark.slow
def test_magnetic_pair_as_shipped_as_with_finer_steps(tmp_path):
    """demos/magnetic_pair.toml as shipped (two interacting strips in Stokes flow,
    100 steps a field period): each strip's speed over the last period and the
    spacing's growth, the demo's headline, within 1 % of the same run at 200 steps a
    period."""
    scene = DEMOS / "magnetic_pair.toml"
    shipped, fine = tmp_path / "shipped", tmp_path / "fine"
    run_scene(scene, "output.fields=false", "time.output_every=1", out_dir=shipped)
    run_scene(scene, "output.fields=false", "time.dt=0.00125", "time.output_every=2", out_dir=fine)
    a, b = _pair_headline(shipped), _pair_headline(fine)
    print(f"pair: shipped {a}, 200 a period {b}, off {a / b - 1}")
    assert np.abs(a / b - 1).max() < 0.01
