"""The start of a run (docs/model.md §6.7): a run in time starts in its initial state,
at rest, whatever loads are already on at t = 0, and its t = 0 row is that state.

Exact checks on a free plate, whose centroid obeys the resultant alone: in isotropic
drag C (no inertia) the drag on the body is C A v̄ (to the plate's strain, 1e-12
here), so under a constant force F the centroid moves at F / (C A) from the first
instant: u(t) = F t / (C A) at every row for backward Euler and BDF2, both exact for
motion at constant speed.  With mass m and no fluid it moves as u = F t² / (2 m),
which generalized-α and HHT integrate exactly when they start from the consistent
acceleration F / m (the elastic forces have no resultant).  A nonuniform field and a
dipole drive a plate through their resultant force in the same way.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import run_scene, write_scene

SIDE, C, FORCE, RHO, THICK = 2.0, 1.0e-3, 1.0e-6, 1.0e-6, 0.1
AREA = SIDE * SIDE
DT, STEPS = 0.1, 4
#: the force's direction as written in PLATE (its size is FORCE × |DIRECTION|)
DIRECTION = np.array([1.0, 0.0, 2.0])

PLATE = f"""
title = "free plate under a constant point force"
[mesh]
length = {SIDE}
width = {SIDE}
divisions = [2, 2]
[shell]
thickness = {THICK}
E = 1.0e6
nu = 0.3
[time]
end = {DT * STEPS}
dt = {DT}
[[load]]
kind = "point-force"
at = [{SIDE / 2}, {SIDE / 2}, 0.0]
value = {[float(v) for v in FORCE * DIRECTION]}
ramp = "constant"
"""


def _centroid_moves(tmp_path, text, *overrides):
    """(times, centroid displacement from the reference) of a run's body.csv rows."""
    run_scene(
        write_scene(tmp_path, text), *overrides, "output.fields=false", out_dir=tmp_path / "out"
    )
    body = np.genfromtxt(tmp_path / "out" / "body.csv", delimiter=",", names=True)
    centroid = np.stack([body[f"centroid_{c}"] for c in "xyz"], axis=1)
    return body["time"], centroid - [SIDE / 2, SIDE / 2, 0.0]


@pytest.mark.parametrize("scheme", ["backward-euler", "bdf2"])
def test_free_plate_in_drag_moves_at_force_over_drag_from_the_first_row(tmp_path, scheme):
    """u(t) = F t / (C A) at every row, u(0) = 0 (reached: 3e-12 of the travel, the
    centroid's round-off; the old start, which let the t = 0 solve drift one step, is off by
    F dt / (C A) at every row)."""
    text = PLATE + f"[fluid]\ndrag = [{C}, {C}, {C}]\n"
    t, u = _centroid_moves(tmp_path, text, f'time.scheme="{scheme}"')
    exact = np.outer(t, FORCE * DIRECTION / (C * AREA))
    err = np.abs(u - exact).max() / np.abs(exact).max()
    print(f"{scheme}: rows at {t}; u_x {u[:, 0]} against {exact[:, 0]}; error {err:.1e}")
    assert len(t) == STEPS + 1 and t[0] == 0.0
    assert np.abs(u[0]).max() < 1e-14 * SIDE
    assert err < 5e-11


@pytest.mark.parametrize("scheme", ["generalized-alpha", "hht"])
def test_free_plate_with_mass_accelerates_at_force_over_mass_from_rest(tmp_path, scheme):
    """u(t) = F t² / (2 m) at every row, m = ρ t A (reached: 1.5e-11 of the travel;
    started from a = 0 instead of the consistent F / m, generalized-α is 4.3 % off
    at the first row and 1.3 % at the last, HHT 45 % and 20 %)."""
    text = PLATE.replace("nu = 0.3", f"nu = 0.3\ndensity = {RHO}")
    t, u = _centroid_moves(tmp_path, text, f'time.scheme="{scheme}"')
    mass = RHO * THICK * AREA
    exact = np.outer(t**2, FORCE * DIRECTION / (2 * mass))
    err = np.abs(u - exact).max() / np.abs(exact).max()
    first = np.abs(u[1] - exact[1]).max() / np.abs(exact[1]).max()
    print(f"{scheme}: u_x {u[:, 0]} against {exact[:, 0]}; error {err:.1e} (first row {first:.1e})")
    assert np.abs(u[0]).max() < 1e-14 * SIDE
    assert err < 2e-10 and first < 2e-10


def _gradient_plate():
    """test_magnetic_fields.py's stiff plate magnetized along X, in drag, under
    B = G (x, −(y − ½), 0) with G = 0.5 at full strength from t = 0."""
    from test_magnetic_fields import GRADIENT_PLATE

    return (
        GRADIENT_PLATE
        + """
[time]
dt = 0.1
end = 1.0
[fluid]
drag = [0.4, 0.7, 1.3]
[magnetic.field]
kind = "expression"
B = ["0.5*x", "-0.5*(y - 0.5)", "0"]
[solver]
snes_atol = 1e-14
"""
    )


def test_gradient_field_on_at_t0_drifts_at_the_resultant_speed_from_the_start(tmp_path):
    """B = G (x, −(y − ½), 0) at full strength from t = 0 pulls the plate magnetized
    along X with t m G A along X: it drifts at t m G / C₁ from the t = 0 row on, u(t)/t
    at every row (reached: 2e-9, the plate's strain at E = 1e8; the old start gave
    +10 % over ten steps)."""
    t, u = _centroid_moves(tmp_path, _gradient_plate())
    u = u + [SIDE / 2 - 0.5, SIDE / 2 - 0.5, 0.0]  # this plate is 1 × 1
    speed = 0.1 * 2.0 * 0.5 / 0.4
    err = np.abs(u[1:, 0] / t[1:] / speed - 1).max()
    print(f"gradient drift: u(t)/t {u[1:, 0] / t[1:]} against {speed}; error {err:.1e}")
    assert np.abs(u[0]).max() < 1e-14
    assert err < 2e-8
    assert np.abs(u[:, 1:]).max() < 1e-9 * speed * t[-1]


DIPOLE_PLATE = """
title = "a small magnetized plate near a point dipole, in drag"
[mesh]
length = 0.01
width = 0.01
divisions = [2, 2]
[shell]
thickness = 0.001
E = 1.0e3
nu = 0.3
[time]
scheme = "backward-euler"
dt = 1.0e-4
end = 1.0e-4
[fluid]
drag = [1.0e-3, 1.0e-3, 1.0e-3]
[[magnetic.parts]]
region = "all"
magnetization = 50.0
direction = [1.0, 0.0, 0.0]
[magnetic.field]
kind = "dipole"
moment = [0.3, -0.5, 1.2]
position = [0.605, 0.005, 0.8]
[solver]
snes_atol = 1e-20
"""


def test_dipole_first_step_moves_at_the_resultant_speed(tmp_path):
    """A plate (a = 0.01, moment m₁ = t m a² along X) at distance 1 from a source
    dipole, in isotropic drag C: its first step's speed is the closed-form dipole
    force ∇(m₁·B) over C a² at t = 0 (the plate's size makes the two differ by at
    most 1.3 (a/d)² = 1.3e-4).  The couple m₁ × B tilts the plate at about 0.9 rad/s
    and its moment with it, so the step is short: 1e-4 s (at 0.01 s the step's force
    is already 0.9 % off the start's; reached 2.8e-5).  The old start, which moved the
    plate one step before the t = 0 row, gave twice the speed."""
    from test_magnetic_fields import dipole_force

    t, u = _centroid_moves(tmp_path, DIPOLE_PLATE)
    u = u + [SIDE / 2 - 0.005, SIDE / 2 - 0.005, 0.0]
    c = np.array([0.005, 0.005, 0.0])
    m1 = 0.001 * 50.0 * 0.01**2 * np.array([1.0, 0.0, 0.0])
    force = dipole_force(m1, c, np.array([0.3, -0.5, 1.2]), np.array([0.605, 0.005, 0.8]))
    exact = force / (1.0e-3 * 0.01**2)
    speed = u[1] / t[1]
    err = np.linalg.norm(speed - exact) / np.linalg.norm(exact)
    print(f"dipole: first-step speed {speed} against {exact}; error {err:.1e}")
    assert np.abs(u[0]).max() < 1e-14
    assert err < 3e-4
