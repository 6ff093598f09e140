"""``[[contact]]`` kind = "plane": a strip on a floor, against exact answers.

A stiff strip 2 × 0.5 × 0.1 mm (density 1e-9 t/mm³, so m = 1e-10 t) lies on the
plane z = −0.05 with its lower face, and moves as a rigid block:

- at rest under its weight the plane carries the weight, whatever the strip's
  density pattern, and no point sinks deeper than the barrier's reach δ;
- on an incline (gravity tilted by α) it sticks while tan α < μ_s, else slides
  at a = g (sin α − μ_k cos α); with anisotropic coefficients each direction
  meets its own (REFERENCES K, adapted from PyElastica's friction cases);
- pushed by an edge force F it stays for F < μ_s m g, else its kinetic energy
  is t² (F − μ_k m g)² / (2m);
- the friction's work (∫ friction_power dt) is the mechanical energy lost;
- a dropped strip bounces without gaining energy (keeps it exactly with ρ∞ = 1),
  and the hard steps (impact, lift-off, the onset of sliding) take at most six
  Newton iterations.

A strip sliding at constant friction meets its exact acceleration to 3e-8 on both
stacks; the tolerances are about ten times what both stacks reach.  The rolling hoop
is tests/test_contact_rolling.py.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import run_scene, write_scene

G, RHO, T, AREA = 9810.0, 1.0e-9, 0.1, 1.0
MASS = RHO * T * AREA
FLOOR = -0.05  # the strip's mid-surface at z = 0 rests its lower face on it

STRIP = """
title = "a strip on a floor"
[mesh]
length = 2.0
width = 0.5
divisions = [4, 1]
[shell]
thickness = 0.1
E = 1.2e6
nu = 0.3
density = 1.0e-9
[time]
end = {end}
dt = {dt}
rho_inf = {rho_inf}
[[load]]
kind = "gravity"
value = {gravity}
ramp = "constant"
[[contact]]
kind = "plane"
point = [0.0, 0.0, -0.05]
normal = [0.0, 0.0, 1.0]
friction = {mu_k}
static_friction = {mu_s}
{extra}
"""


def strip(
    tmp_path,
    name,
    gravity=(0.0, 0.0, -G),
    mu_k=0.3,
    mu_s=0.4,
    end=0.05,
    dt=1e-3,
    rho_inf=0.0,
    extra="",
    sets=(),
):
    text = STRIP.format(
        end=end,
        dt=dt,
        rho_inf=rho_inf,
        gravity=[float(g) for g in gravity],
        mu_k=mu_k,
        mu_s=mu_s,
        extra=extra,
    )
    out = tmp_path / name
    sim = run_scene(write_scene(tmp_path, text, name=f"{name}.toml"), *sets, out_dir=out)
    body = np.genfromtxt(out / "body.csv", delimiter=",", names=True)
    steps = np.genfromtxt(out / "steps.csv", delimiter=",", names=True)
    return sim, body, steps


def tilted(alpha, direction=(1.0, 0.0)):
    """Gravity tilted by α: its part along the floor along ``direction``."""
    s = G * math.sin(alpha)
    return (s * direction[0], s * direction[1], -G * math.cos(alpha))


def fitted_acceleration(body, axis="x"):
    """Twice the leading coefficient of a quadratic through the second half."""
    t, x = body["time"], body[f"centroid_{axis}"]
    half = len(t) // 2
    return 2.0 * np.polyfit(t[half:], x[half:], 2)[0]


def test_strip_rests_on_the_floor_with_its_weight(tmp_path):
    """Static load steps; the left half three times as dense: the plane's resultant
    equals the weight to 2e-15 (reached 2.2e-16 on both stacks) and has no part along
    the plane (within 3e-13 of the weight, reached 2.4e-15 and 2.8e-14), the lower
    face stays above −δ everywhere (the heavy end sinks, the light end floats),
    nothing slides.  Broke: the resultant (body.csv) on a degree-2 rule, the work on
    degree 4 → weight off by −6.2e-6."""
    extra = """
[[mesh.regions]]
name = "heavy"
x = [0.0, 1.0]
[[shell.parts]]
region = "heavy"
density = 3.0e-9
[[output.probes]]
name = "heavy_end"
at = [0.0, 0.25, 0.0]
[[output.probes]]
name = "light_end"
at = [2.0, 0.25, 0.0]
"""
    sim, body, _ = strip(
        tmp_path, "rest", end=1.0, dt=0.5, extra=extra, sets=["time.scheme=static"]
    )
    weight = (3.0 + 1.0) / 2 * MASS * G
    last = body[-1]
    print(
        f"weight {last['contact_Fz'] / weight - 1:.1e}, sideways "
        f"{max(abs(last['contact_Fx']), abs(last['contact_Fy'])) / weight:.1e}"
    )
    assert abs(last["contact_Fz"] - weight) < 2e-15 * weight, last["contact_Fz"] / weight - 1
    assert abs(last["contact_Fx"]) < 3e-13 * weight and abs(last["contact_Fy"]) < 3e-13 * weight
    reach = sim.model.get("contact").planes[0].reach
    assert reach == pytest.approx(0.1 * T)
    probes = np.genfromtxt(tmp_path / "rest" / "probes.csv", delimiter=",", names=True)
    heavy, light = probes["heavy_end_uz"][-1], probes["light_end_uz"][-1]
    print(
        f"weight {last['contact_Fz'] / weight - 1:.1e}; ends at {heavy:.4g}, {light:.4g} "
        f"(δ = {reach:g})"
    )
    assert -reach < heavy < 0.0 < light < reach  # lower faces within ±δ of the plane
    # it tilts about its lower face, which friction holds: the mid-surface shifts by
    # (t/2) × the tilt
    tilt = (light - heavy) / 2.0
    assert 0.0 < abs(last["centroid_x"] - 1.0) < 1.01 * T / 2 * tilt


@pytest.mark.parametrize(
    "direction, mu, slides, scheme, within",
    [
        # forward (+shell.axis): μ_s 0.25 < tan α
        ((1.0, 0.0), 0.2, True, "generalized-alpha", 4e-8),
        ((-1.0, 0.0), 0.3, True, "generalized-alpha", 3e-7),  # backward: μ_s 0.35 < tan α
        ((0.0, 1.0), 0.5, False, "generalized-alpha", None),  # sideways: μ_s 0.6 > tan α, sticks
        # HHT damps the start's transient (the first step's mean acceleration against the
        # kinetic one) less than generalized-α at ρ∞ = 0: reached 3.5e-5
        ((-1.0, 0.0), 0.3, True, "hht", 1e-4),
    ],
    ids=["forward", "backward", "sideways", "backward-hht"],
)
def test_incline_with_anisotropic_friction(tmp_path, direction, mu, slides, scheme, within):
    """tan α = 0.4 with friction [0.2, 0.3, 0.5] and static [0.25, 0.35, 0.6] along
    the strip's axis (X): slides down along ±X at g (sin α − μ_k cos α), forward
    within 4e-8 (reached 3.9e-9), backward within 3e-7 (reached 2.7e-8), both stacks
    alike; sticks across (creeps below the slip velocity ε_v, friction = m g sin α
    within 4e-5, reached 3.8e-6); also with HHT-α.  Broke: the forward and backward
    coefficients swapped → forward −0.50, backward +1.0."""
    alpha = math.atan(0.4)
    sim, body, _ = strip(
        tmp_path,
        "incline",
        gravity=tilted(alpha, direction),
        mu_k=[0.2, 0.3, 0.5],
        mu_s=[0.25, 0.35, 0.6],
        sets=[f"time.scheme={scheme}"],
    )
    axis = "x" if direction[0] else "y"
    sign = direction[0] + direction[1]
    if slides:
        exact = G * (math.sin(alpha) - mu * math.cos(alpha))
        a = sign * fitted_acceleration(body, axis)
        print(f"{direction}: a = {a:.6g}, exact {exact:.6g}, error {a / exact - 1:.1e}")
        assert abs(a / exact - 1) < within
    else:
        creep = abs(body[f"centroid_{axis}"][-1] - body[f"centroid_{axis}"][0])
        v_scale = sim.model.get("contact").planes[0].slip_velocity
        friction = -sign * body[f"contact_F{axis}"][-1]
        print(
            f"sticks: crept {creep:.3g} (ε_v t = {v_scale * 0.05:.3g}), friction / "
            f"m g sin α - 1 = {friction / (MASS * G * math.sin(alpha)) - 1:.1e}"
        )
        assert creep < v_scale * 0.05
        assert abs(friction / (MASS * G * math.sin(alpha)) - 1) < 4e-5


def test_sticks_below_the_static_coefficient(tmp_path):
    """Isotropic μ_s = 0.4 > tan α = 0.35 > μ_k = 0.3: a body started sliding would
    go on sliding, so this checks that it starts sticking (its t = 0 acceleration
    comes from the first step with friction, not from the frictionless forces)."""
    alpha = math.atan(0.35)
    sim, body, _ = strip(tmp_path, "stick", gravity=tilted(alpha))
    v_scale = sim.model.get("contact").planes[0].slip_velocity
    creep = body["centroid_x"][-1] - body["centroid_x"][0]
    print(f"crept {creep:.3g} in 0.05 (ε_v t = {v_scale * 0.05:.3g})")
    assert 0.0 <= creep < v_scale * 0.05


@pytest.mark.parametrize("push", [0.8, 2.0])
def test_pushed_strip(tmp_path, push):
    """An edge force F = push · μ_s m g on the edge x = 0 along +X: below μ_s m g the
    strip stays (creeps below ε_v); above it its kinetic energy is
    t² (F − μ_k m g)² / (2m) (within 1e-9 at the end of the run, reached 5e-11)."""
    F = push * 0.4 * MASS * G
    extra = f"""
[[load]]
kind = "edge-force"
where = "x=0"
value = [{F!r}, 0.0, 0.0]
ramp = "constant"
"""
    sim, body, _ = strip(tmp_path, "push", extra=extra)
    t, x = body["time"], body["centroid_x"] - 1.0
    v_scale = sim.model.get("contact").planes[0].slip_velocity
    if push < 1.0:
        print(f"F < μ_s m g: moved {x[-1]:.3g} (ε_v t = {v_scale * t[-1]:.3g})")
        assert 0.0 <= x[-1] < v_scale * t[-1]
        return
    exact = t[-1] ** 2 * (F - 0.3 * MASS * G) ** 2 / (2 * MASS)
    kinetic = body["kinetic_energy"][-1]
    print(f"kinetic energy {kinetic:.6g}, exact {exact:.6g}: {kinetic / exact - 1:.1e}")
    assert abs(kinetic / exact - 1) < 1e-9


def test_friction_work_is_the_energy_lost(tmp_path):
    """Sliding down tan α = 0.5 with the trapezoidal rule (ρ∞ = 1, no numerical
    dissipation): the kinetic energy gained falls short of the weight's work by
    the friction's work, to 1e-4 of it.  A row's friction_power is the mean over
    the step that ended there, so the work is the sum of power × dt (within 5e-7,
    reached 4e-8)."""
    alpha = math.atan(0.5)
    g = np.array(tilted(alpha))
    _, body, _ = strip(tmp_path, "energy", gravity=g, rho_inf=1.0)
    centroid = np.stack([body["centroid_x"], body["centroid_y"], body["centroid_z"]], axis=1)
    weight_work = MASS * (centroid - centroid[0]) @ g
    stored = body["kinetic_energy"] + body["elastic_energy"] + body["contact_energy"]
    lost = weight_work - (stored - stored[0])
    power = body["friction_power"]
    work = np.concatenate([[0.0], np.cumsum(np.diff(body["time"]) * power[1:])])
    print(f"lost {lost[-1]:.6g}, friction work {work[-1]:.6g}: {lost[-1] / work[-1] - 1:.1e}")
    assert work[-1] > 0.1 * weight_work[-1]  # friction takes a good part of it
    assert abs(lost[-1] / work[-1] - 1) < 5e-7


@pytest.mark.parametrize(
    "rho_inf",
    [
        1.0,
        pytest.param(
            0.5,
            marks=pytest.mark.xfail(
                strict=True,
                reason="open (issue 59 note): since the nodal directors the free fall's "
                "first three steps gain 2.4e-9 of m g h with the mixed-point tangent (1.2e-10 with "
                "the exact one, -2.7e-10 before); each step stops after one update at the force "
                "tolerance, and the mixed-point update lands 1e-7 off",
            ),
        ),
    ],
)
def test_dropped_strip_bounces_without_gaining_energy(tmp_path, rho_inf):
    """Dropped from 0.1 mm (a thickness) above the floor, it hits it at 44 mm/s (an
    impact the default barrier takes within its reach).  The barrier's pressure over
    a step is its secant (forms.step_pressure): with the trapezoidal rule (ρ∞ = 1)
    the energy is kept to 1e-9 of m g h through every bounce and the strip rebounds
    to its height (restitution 1 within 1e-3); with ρ∞ = 0.5 impacts only lose
    energy (restitution 0.81).  No point goes deeper than the reach δ, and no step
    takes more than 6 Newton iterations (reached 5 and 6)."""
    fall = 0.1
    _, body, steps = strip(
        tmp_path,
        "drop",
        rho_inf=rho_inf,
        end=0.03,
        dt=2.5e-4,
        mu_k=0.0,
        mu_s=0.0,
        sets=[f"contact.0.point=[0, 0, {-0.05 - fall}]"],
    )
    energy = (
        body["kinetic_energy"]
        + body["elastic_energy"]
        + body["contact_energy"]
        + MASS * G * body["centroid_z"]
    )
    z = body["centroid_z"] + fall  # the mid-surface over its height resting on the floor
    lowest = np.flatnonzero(np.diff(np.sign(np.diff(z))) > 0) + 1
    peaks = np.flatnonzero(np.diff(np.sign(np.diff(z))) < 0) + 1
    restitution = np.sqrt(z[peaks[0]] / fall)
    growth = (energy - energy[0]).max() / (MASS * G * fall)
    print(
        f"ρ∞ = {rho_inf}: energy growth {growth:.1e}; lowest {z[lowest]} (reach 0.01); "
        f"restitution {restitution:.4f}; Newton iterations max {steps['newton_its'].max():.0f}"
    )
    assert len(lowest) >= 2 and len(peaks) >= 1  # down, up, down again
    assert growth < 1e-9
    if rho_inf == 1.0:
        assert abs(restitution - 1.0) < 1e-3
    else:
        assert 0.5 < restitution < 0.95 and energy[-1] < energy[0] - 0.1 * MASS * G * fall
    assert (z[lowest] > -0.01).all()  # never deeper than the barrier's reach
    assert steps["newton_its"].max() <= 6


def test_onset_of_sliding_converges_in_six_iterations(tmp_path):
    """An edge force ramped from 0 to 1.5 μ_s m g over the run: the strip sticks,
    then breaks loose near μ_s m g and slides; no step takes more than 6 Newton
    iterations."""
    F = 1.5 * 0.4 * MASS * G
    extra = f"""
[[load]]
kind = "edge-force"
where = "x=0"
value = [{F!r}, 0.0, 0.0]
"""
    _, body, steps = strip(tmp_path, "onset", extra=extra, end=0.1, dt=1e-3)
    x, t = body["centroid_x"] - 1.0, body["time"]
    moving = t[np.flatnonzero(np.gradient(x, t) > 10 * 0.4 * 2.06e-3 / 0.1)]
    print(
        f"breaks loose at t = {moving[0]:.3g} (F/(μ_s m g) = {1.5 * moving[0] / 0.1:.3f}); "
        f"Newton iterations max {steps['newton_its'].max():.0f}, mean "
        f"{steps['newton_its'].mean():.2f}"
    )
    assert 0.97 <= 1.5 * moving[0] / 0.1 < 1.1
    assert steps["newton_its"].max() <= 6


def test_lift_off_and_landing_converge_in_six_iterations(tmp_path):
    """Gravity turned upwards for a while (a table ramp: 1, then −1 from 5 ms to 7 ms,
    then 1 again) on a frictionless floor, with a constant pull g/10 along +X besides
    (a second gravity load): the strip leaves the floor, flies up and lands again; the
    plane lets go of it entirely (no force while it is more than δ above), and no step
    takes more than 6 Newton iterations.  A frictionless plane pushes only along its
    normal (Z), on the floor as in flight, so the centroid moves along X as a free
    particle, x − x₀ = g t²/20 at every row; the time scheme, started from the
    consistent acceleration, integrates a constant force exactly: within 5e-8 of the
    final distance (reached 6.7e-11, and 5.0e-9 on the current stack: a speed the
    first steps leave at the solver's tolerance, constant through every landing).
    Broke: no initial acceleration (a(0) = 0) → 2.8e-3; friction 1e-6 on the floor
    (the scene's) → 8.0e-6."""
    extra = "table = [[0.0, 1.0], [0.005, 1.0], [0.0051, -1.0], [0.007, -1.0], [0.0071, 1.0]]"
    pull = G / 10
    text = STRIP.format(
        end=0.03, dt=2.5e-4, rho_inf=0.5, gravity=[0.0, 0.0, -G], mu_k=0.0, mu_s=0.0, extra=""
    ).replace('ramp = "constant"', 'ramp = "table"\n' + extra)
    text += f'[[load]]\nkind = "gravity"\nvalue = [{pull!r}, 0.0, 0.0]\nramp = "constant"\n'
    out = tmp_path / "lift"
    run_scene(write_scene(tmp_path, text, name="lift.toml"), out_dir=out)
    body = np.genfromtxt(out / "body.csv", delimiter=",", names=True)
    steps = np.genfromtxt(out / "steps.csv", delimiter=",", names=True)
    airborne = body["contact_Fz"] == 0.0
    t, x = body["time"], body["centroid_x"] - body["centroid_x"][0]
    ballistic = 0.5 * pull * t**2
    drift = np.abs(x - ballistic).max() / ballistic[-1]
    print(
        f"airborne {airborne.sum()} of {len(body)} rows, highest "
        f"{body['centroid_z'].max():.3g}; x against g t²/20: {drift:.1e} of "
        f"{ballistic[-1]:.3g}; Newton iterations max {steps['newton_its'].max():.0f}, "
        f"mean {steps['newton_its'].mean():.2f}"
    )
    lifted = np.flatnonzero(airborne & (t > 0.006))
    assert len(lifted) and (~airborne[lifted[0] :]).any()  # up, and down again
    assert body["centroid_z"].max() > 0.03  # well off the floor
    assert drift < 5e-8
    assert steps["newton_its"].max() <= 6


@pytest.mark.mpi
def test_two_processes_slide_as_one(tmp_path, cli_run):
    """The anisotropic slope of test_incline_with_anisotropic_friction (backward) under
    mpirun -n 2: body.csv as in serial to 1e-9 of the sliding distance, contact forces
    to 1e-9 of the weight."""
    alpha = math.atan(0.4)
    text = STRIP.format(
        end=0.02,
        dt=1e-3,
        rho_inf=0.0,
        gravity=list(tilted(alpha, (-1, 0))),
        mu_k=[0.2, 0.3, 0.5],
        mu_s=[0.25, 0.35, 0.6],
        extra="",
    )
    scene = write_scene(tmp_path, text.replace("divisions = [4, 1]", "divisions = [8, 2]"))
    tables = [
        np.genfromtxt(
            cli_run(scene, tmp_path / f"np{n}", np=n) / "body.csv", delimiter=",", names=True
        )
        for n in (1, 2)
    ]
    serial, two = tables
    slid = abs(serial["centroid_x"][-1] - serial["centroid_x"][0])
    assert slid > 0.1
    assert np.abs(two["centroid_x"] - serial["centroid_x"]).max() < 1e-9 * slid
    for c in ("contact_Fx", "contact_Fz", "friction_power"):
        scale = np.abs(serial[c]).max()
        assert np.abs(two[c] - serial[c]).max() < 1e-9 * scale, c


@pytest.mark.parametrize("fluid", ["rft", "stokes"])
def test_slides_through_a_liquid_at_the_force_balance(tmp_path, fluid):
    """Without inertia (backward Euler) in a liquid, on a slope tan α = 0.5 with
    μ = 0.3: the weight's slope part, friction and the liquid's force balance at
    every step (to 5e-14 of the weight, reached 4.4e-15), and friction is μ times the
    pressure's resultant (within 1e-15, reached 5.6e-17).  The strip slides at the
    speed at which the liquid's resistance R along X takes the weight's slope part
    less friction.  With RFT drag R = C₁ A and U = (sin α − μ cos α) m g / (C₁ A)
    exactly (within 6e-13, reached 6.1e-14).  With Stokes flow (the liquid seeing the
    whole strip, no wall) R is the strip's discrete rigid resistance R₁₁
    (stokes_report.rigid_resistance: the force on the liquid of the layer's operator,
    factorised afresh here, for the strip where it ends moving at unit speed; the
    discretisation's own 7.7 % cancels), and U = (m g sin α − friction) / R₁₁ within
    3e-14 (reached 2.9e-15).  The friction there is μ times the measured pressure:
    the strip tilts by 1e-4 rad on the friction at its lower face, and the liquid
    lifts it by 2e-5 of the pressure, so the closed form (sin α − μ cos α) m g / R₁₁
    is 3.1e-5 off; R₁₁ of the reference shape is 1.8e-8 off.  Broke: the liquid seeing the
    reference shape carried along rigidly
    (in the run's forces and body.csv's) → speed +1.8e-8 (the balance held, 7.6e-16);
    kinetic and static coefficients swapped → friction/pressure − μ = 0.1 (rft)."""
    alpha = math.atan(0.5)
    g = tilted(alpha)
    viscosity = 1.0e-9
    # equal coefficients: friction on the lower face tilts the strip by 1e-4 rad, which
    # unequal ones would turn into a lift of that order
    liquid = (
        "[fluid]\ndrag = [2.0e-8, 2.0e-8, 2.0e-8]\n"
        if fluid == "rft"
        else f'[fluid]\nmodel = "stokes"\nviscosity = {viscosity!r}\n'
    )
    sim, body, _ = strip(
        tmp_path,
        fluid,
        gravity=g,
        extra=liquid,
        end=0.02,
        dt=2e-3,
        sets=["time.scheme=backward-euler"],
    )
    weight = MASS * np.asarray(g)
    last = body[-1]
    pressure = last["contact_Fz"]
    balance = [last[f"contact_F{c}"] + last[f"fluid_F{c}"] + weight[i] for i, c in enumerate("xyz")]
    print(
        f"{fluid}: friction/pressure - μ {-last['contact_Fx'] / pressure - 0.3:.1e}, "
        f"balance {np.abs(balance).max() / (MASS * G):.1e} of the weight"
    )
    assert abs(-last["contact_Fx"] / pressure - 0.3) < 1e-15
    assert np.abs(balance).max() < 5e-14 * MASS * G, balance
    if fluid == "rft":
        resistance = 2.0e-8 * AREA
    else:
        from rftfem.model import stokes_layer, stokes_report

        stokes = sim.model["stokes"]  # (serial: its layer has every row)
        x = stokes.X + sim.model.u_n.x.array.reshape(-1, 3)[: len(stokes.X)]
        fresh = stokes_layer.LayerResistance(
            stokes.layer, x, viscosity, interpolation=stokes.interpolation
        )
        resistance = stokes_report.rigid_resistance(fresh, x)[0, 0]
    speed = (body["centroid_x"][-1] - body["centroid_x"][-2]) / (
        body["time"][-1] - body["time"][-2]
    )
    if fluid == "rft":
        exact = (math.sin(alpha) - 0.3 * math.cos(alpha)) * MASS * G / resistance
    else:
        exact = (weight[0] + last["contact_Fx"]) / resistance
    print(
        f"{fluid}: speed {speed:.6g} against the driving force over R, {exact:.6g}: "
        f"{speed / exact - 1:.1e}"
    )
    assert abs(speed / exact - 1) < (6e-13 if fluid == "rft" else 3e-14), speed / exact - 1


PUSHED_TO_AND_FRO = """
title = "a plate on a rough floor in a liquid, pushed to and fro"
[mesh]
length = 2.0
width = 0.5
divisions = [4, 1]
[shell]
thickness = 0.1
E = 100.0
nu = 0.3
density = 2.0e-9
[fluid]
drag = [4.0e-8, 4.0e-8, 7.5e-8]
[time]
scheme = "bdf2"
dt = 0.01
end = 2.0
[[load]]
kind = "gravity"
ramp = "constant"
value = [0.0, 0.0, -9810.0]
fluid_density = 1.0e-9
[[load]]
kind = "point-force"
at = [1.0, 0.25, 0.0]
value = [6.0e-7, 0.0, 0.0]
ramp = "table"
table = [[0.0, 0.0], [0.25, 1.0], [0.75, -1.0], [1.25, 1.0], [1.75, -1.0], [2.0, 0.0]]
[[contact]]
kind = "plane"
point = [0.0, 0.0, -0.05]
normal = [0.0, 0.0, 1.0]
friction = 0.3
slip_velocity = 0.01
"""


def test_slip_turning_round_converges_without_cuts(tmp_path):
    """A soft plate in a liquid, pushed to and fro by a force twice the friction it
    can take: it slides, sticks as the push falls below μ W, and slides back, four
    times.  Friction there is 1e3 times what drag and bending resist across the
    band of slip ε_v dt, and plain Newton went from sliding one way to sliding the
    other and back until its iteration limit (the run failed at t = 0.38 s);
    updates that would turn a fast slip round stop where it has halved
    (docs/contact.md §3): no step cut, at most 12 Newton iterations a step (a
    reversal; reached 12, mean 2.0)."""
    out = tmp_path / "to_and_fro"
    run_scene(write_scene(tmp_path, PUSHED_TO_AND_FRO), out_dir=out)
    body = np.genfromtxt(out / "body.csv", delimiter=",", names=True)
    steps = np.genfromtxt(out / "steps.csv", delimiter=",", names=True)
    v = np.gradient(body["centroid_x"], body["time"])
    turns = np.flatnonzero(np.diff(np.sign(body["contact_Fx"][np.abs(v) > 0.1])) != 0)
    print(
        f"friction turned round {len(turns)} times; Newton iterations max "
        f"{steps['newton_its'].max():.0f}, mean {steps['newton_its'].mean():.2f}"
    )
    assert len(turns) >= 3
    assert len(steps) == 200  # no step cut
    assert steps["newton_its"].max() <= 12 and steps["newton_its"].mean() < 2.5


def test_a_slip_velocity_too_large_for_sticking_warns(tmp_path):
    """slip_velocity = 10 mm/s on the 2 mm strip over a 0.05 s run lets a sticking body
    creep 24 % of its size: the run warns (log and summary.json) that friction then
    acts as a drag; the default (0.1 %) does not."""
    sim, _, _ = strip(
        tmp_path,
        "creep",
        gravity=tilted(math.atan(0.35)),
        dt=0.01,
        sets=["contact.0.slip_velocity=10"],
    )
    warnings = [w for w in sim.summary["warnings"] if "contact.0.slip_velocity" in w]
    assert len(warnings) == 1 and "creep 0.24 of its size" in warnings[0], warnings
    sim, _, _ = strip(tmp_path, "no_creep", gravity=tilted(math.atan(0.35)), dt=0.01)
    assert not [w for w in sim.summary["warnings"] if "slip_velocity" in w]
