"""``[[contact]]`` kind = "plane": a thin hoop rolling and slipping down an incline.

A hoop (radius r = 1 mm, width 0.2 mm, thickness t = 0.02 mm, stiff enough to stay
round) stands on a floor with its lower face touching it (the mid-surface's lowest
point t/2 above it); gravity tilted by α about Y (9810 [sin α, 0, −cos α] mm/s²)
makes the floor an incline. Its mass m sits on the mid-surface, so I = m r², and
friction grips its lower face, at R = r + t/2 from the axis:

- rolling without slip (R ω = v) while tan α ≤ μ_s (1 + R²/r²): the centre
  accelerates at a = g sin α R²/(R² + r²) and the hoop turns at a/R (g sin α / 2
  and a/r for t → 0; the thickness adds 1 % here);
- beyond it the hoop slips: a = g (sin α − μ_k cos α), angular acceleration
  μ_k g cos α R / r².

The accelerations are quadratic fits over the run's second half: of body.csv's
centroid_x, and of the angle turned by a probe at the hoop's top about the
centroid. The second rolling angle, α = 0.5 (tan α = 0.55), is above the kinetic
limit μ_k (1 + R²/r²) = 0.40 and below the static one, 0.61: the hoop rolls only if
static friction holds it from the start. (With the default slip_velocity, 0.14 mm/s
here, it slips for good: it starts touching the floor, not pressed into it, slips
0.5 mm/s in the first step while the barrier takes up its weight, and kinetic
friction cannot stop that.)

The hoop touches along a line: its weight rests on the arc of the lower face within
the barrier's reach δ = 0.1 t of the floor, 2 √(2 R δ) = 0.13 mm of the 6.3 mm
around. The default stiffness rests the body's weight on the area within reach at
the start, which for the hoop is that arc as its quadrature points see it; the
"line stiffness" case gives the arc's exact length instead.

Settings (about 2 s a run): 64 cells around (9-node), Δt = 0.5 ms, 40 steps,
generalized-α with ρ∞ = 0 (and the default 0.9 once), slip_velocity 1 mm/s;
μ_k = 0.2 and μ_s = 0.3 throughout. Reached: rolling −0.05 % (a) and −0.03 %
(turning) at α = 0.2 (ρ∞ = 0.9: −0.06 %, +0.03 %), −0.16 % and −0.13 % at α = 0.5;
slipping (α = 0.8) +1e-5 (a) and −0.14 % (turning). Around the hoop, at α = 0.2
(with the line stiffness): 32 cells −0.08 % and +0.15 %, 48 +0.11 % and +0.14 %,
64 to 128 cells −0.04 to −0.05 % and −0.01 to −0.02 %. Contact on the mid-surface
instead of the lower face (radius r) fails the tolerances (−1 %).

The barrier's pressure over a step is its secant plus (½ − α_f) of its change
(forms.step_pressure), which is its value at the time where generalized-α takes
the elastic forces: with the barrier's force taken at the step's end instead the
rolling hoop lagged by α_f Δt (−1.7 % at ρ∞ = 0.9, first order in Δt). The
α = 0.5 hoop, between the kinetic and the static limit, rolls only if static
friction holds from the first step; at ρ∞ = 0.9 the start's undamped transient
lets it slip once, and kinetic friction cannot stop it: that case runs at ρ∞ = 0.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import run_scene, write_scene
from contact_bodies import write_hoop

G, RHO = 9810.0, 1.0e-9
RADIUS, WIDTH, THICKNESS = 1.0, 0.2, 0.02
#: the hoop's centre: its lower face touches the floor z = 0 at the bottom
CENTRE_Z = RADIUS + THICKNESS / 2
#: the lower face's distance from the axis: the rolling radius
R_FACE = RADIUS + THICKNESS / 2
#: the barrier's reach, the default 0.1 t
REACH = 0.1 * THICKNESS
N_AROUND, DT, END = 64, 5.0e-4, 0.02

HOOP = """
title = "a hoop on an incline"
[mesh]
kind = "gmsh"
file = "hoop.msh"
[shell]
thickness = {t}
E = 1.0e4
nu = 0.0
density = {rho}
axis = [0.0, 1.0, 0.0]
[time]
scheme = "generalized-alpha"
rho_inf = {rho_inf}
end = {end}
dt = {dt}
[[load]]
kind = "gravity"
value = [{gx!r}, 0.0, {gz!r}]
ramp = "constant"
[[contact]]
kind = "plane"
point = [0.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]
friction = {mu_k}
static_friction = {mu_s}
slip_velocity = 1.0
{stiffness}
[output]
fields = false
[[output.probes]]
name = "top"
at = [0.0, {half_width!r}, {top!r}]
"""


@pytest.fixture(scope="module")
def hoop_mesh(tmp_path_factory):
    return write_hoop(
        tmp_path_factory.mktemp("hoop") / "hoop.msh", RADIUS, WIDTH, N_AROUND, centre_z=CENTRE_Z
    )


def exact(alpha, mu_k, mu_s):
    """(rolls, the centre's acceleration, the angular acceleration) of the thin hoop."""
    ratio = R_FACE**2 / RADIUS**2
    if math.tan(alpha) <= mu_s * (1 + ratio):
        a = G * math.sin(alpha) * ratio / (1 + ratio)
        return True, a, a / R_FACE
    return (
        False,
        G * (math.sin(alpha) - mu_k * math.cos(alpha)),
        mu_k * G * math.cos(alpha) * R_FACE / RADIUS**2,
    )


def line_stiffness(alpha):
    """The barrier stiffness κ that rests the weight on the arc of the lower face within
    the reach δ of the floor, 2 √(2 R δ) long: the pressure the weight makes there
    over (2 ln 2 + 1) δ, as the default makes of a flat body's weight per area."""
    arc = 2 * math.sqrt(2 * R_FACE * REACH)
    pressure = RHO * THICKNESS * G * math.cos(alpha) * 2 * math.pi * RADIUS / arc
    return pressure / ((2 * math.log(2) + 1) * REACH)


def roll(tmp_path, mesh, alpha, mu_k, mu_s, stiffness=False, rho_inf=0.0):
    """Run the hoop (at ``line_stiffness``, or the default one); its fitted
    (acceleration, angular acceleration), printed with the Newton iterations a step."""
    (tmp_path / "hoop.msh").write_bytes(mesh.read_bytes())
    text = HOOP.format(
        t=THICKNESS,
        rho=RHO,
        end=END,
        dt=DT,
        gx=G * math.sin(alpha),
        gz=-G * math.cos(alpha),
        mu_k=mu_k,
        mu_s=mu_s,
        stiffness=f"stiffness = {line_stiffness(alpha)!r}" if stiffness else "",
        half_width=WIDTH / 2,
        top=CENTRE_Z + RADIUS,
        rho_inf=rho_inf,
    )
    out = tmp_path / "out"
    sim = run_scene(write_scene(tmp_path, text), out_dir=out)
    assert sim.summary["status"] == "ok"
    body = np.genfromtxt(out / "body.csv", delimiter=",", names=True)
    probe = np.genfromtxt(out / "probes.csv", delimiter=",", names=True)
    steps = np.genfromtxt(out / "steps.csv", delimiter=",", names=True)
    assert np.allclose(body["time"], probe["time"])
    t = body["time"]
    # the angle the top has turned about +Y (forward rolling): its position from the centroid
    turned = np.unwrap(
        np.arctan2(
            probe["top_ux"] - body["centroid_x"],
            CENTRE_Z + RADIUS + probe["top_uz"] - body["centroid_z"],
        )
    )
    late = t >= END / 2 - 1e-12
    a = 2 * np.polyfit(t[late], body["centroid_x"][late], 2)[0]
    turning = 2 * np.polyfit(t[late], turned[late], 2)[0]
    its = steps["newton_its"]
    print(
        f"alpha {alpha}: a {a:.3f}, turning {turning:.3f} rad/s², final angle "
        f"{turned[-1]:.3f} rad; {len(its)} steps, Newton iterations max {its.max():.0f}, "
        f"mean {its.mean():.2f}"
    )
    return a, turning


@pytest.mark.parametrize(
    "alpha, rho_inf, stiffness",
    [(0.2, 0.0, False), (0.5, 0.0, False), (0.2, 0.9, False), (0.2, 0.0, True)],
    ids=["alpha0.2", "alpha0.5", "alpha0.2-rho0.9", "alpha0.2-line-stiffness"],
)
def test_hoop_rolls_without_slip(tmp_path, hoop_mesh, alpha, rho_inf, stiffness):
    """μ_k = 0.2, μ_s = 0.3: both angles roll, a = g sin α R²/(R² + r²) and a/R, within
    0.5 %, at the default stiffness (the weight over the area within reach at the
    start) and at the line stiffness, with ρ∞ = 0 and (α = 0.2) the default 0.9."""
    rolls, a_exact, turning_exact = exact(alpha, 0.2, 0.3)
    assert rolls
    a, turning = roll(tmp_path, hoop_mesh, alpha, 0.2, 0.3, stiffness, rho_inf)
    print(
        f"errors: a {100 * (a / a_exact - 1):+.3f} %, turning "
        f"{100 * (turning / turning_exact - 1):+.3f} %"
    )
    assert abs(a / a_exact - 1) < 5e-3
    assert abs(turning / turning_exact - 1) < 5e-3


def test_hoop_slips_beyond_static_friction(tmp_path, hoop_mesh):
    """α = 0.8, tan α = 1.03 > μ_s (1 + R²/r²) = 0.61: the hoop slips, its centre at
    g (sin α − μ_k cos α) within 2e-4 (reached 5e-6), turning at μ_k g cos α R / r²
    within 0.5 % (reached −0.10 %)."""
    rolls, a_exact, turning_exact = exact(0.8, 0.2, 0.3)
    assert not rolls
    a, turning = roll(tmp_path, hoop_mesh, 0.8, 0.2, 0.3)
    print(
        f"errors: a {100 * (a / a_exact - 1):+.4f} %, turning "
        f"{100 * (turning / turning_exact - 1):+.3f} %"
    )
    assert abs(a / a_exact - 1) < 2e-4
    assert abs(turning / turning_exact - 1) < 5e-3
