"""Magnetic body couples (docs/model.md §5.5, issue 4): the field protocol, the static
hard-magnetic elastica, and the effect switch."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import build_model, run_scene, write_scene

LENGTH, THICKNESS, E = 10.0, 0.1, 1.2e4  # EI = E w t³/12 = 1 N·mm² for w = 1

CANTILEVER = f"""
title = "hard-magnetic cantilever"
[mesh]
kind = "strip"
length = {LENGTH}
width = 1.0
divisions = [20, 1]
[[mesh.regions]]
name = "magnet"
x = [0.0, {LENGTH}]
[shell]
thickness = {THICKNESS}
E = {E}
nu = 0.0
[time]
scheme = "static"
end = 1.0
dt = 0.1
[[boundary]]
where = "x=0"
fix = ["clamped"]
[magnetic]
[[magnetic.parts]]
region = "magnet"
magnetization = 100.0
direction = [1.0, 0.0, 0.0]
[magnetic.field]
strength = 3.0e-3
ramp_time = 1.0
direction = [0.0, 0.0, 1.0]
"""


def elastica_tip(lam: float, psi: float, n: int = 4000):
    """Hard-magnetic elastica ``θ'' + λ sin(ψ − θ) = 0`` on s ∈ [0, 1], θ(0) = 0,
    θ'(1) = 0 (λ = m B t w L² / EI), by shooting on θ'(0) with RK4 and bisection.
    Returns the tip angle and the tip position (x, z)/L."""

    def shoot(kappa0):
        h = 1.0 / n
        y = np.array([0.0, kappa0, 0.0, 0.0])  # θ, θ', x, z

        def f(y):
            return np.array([y[1], -lam * math.sin(psi - y[0]), math.cos(y[0]), math.sin(y[0])])

        for _ in range(n):
            k1 = f(y)
            k2 = f(y + 0.5 * h * k1)
            k3 = f(y + 0.5 * h * k2)
            k4 = f(y + h * k3)
            y = y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        return y

    lo, hi = 0.0, lam * 2  # θ'(1) > 0 at κ₀ = 0 ... < 0 at a large κ₀
    assert shoot(lo)[1] < 0 < shoot(hi)[1] or shoot(lo)[1] > 0 > shoot(hi)[1]
    sign_lo = math.copysign(1, shoot(lo)[1])
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if math.copysign(1, shoot(mid)[1]) == sign_lo:
            lo = mid
        else:
            hi = mid
    y = shoot(0.5 * (lo + hi))
    return y[0], y[2], y[3]


class TipDirector:
    """Observer: director and displacement at the middle of the tip edge (serial)."""

    def __init__(self):
        self.rows = []

    def __call__(self, sim):
        m = sim.model
        X = m.Vu.tabulate_dof_coordinates()
        i = int(np.argmin(np.linalg.norm(X - [LENGTH, 0.5, 0.0], axis=1)))
        self.rows.append(
            (
                sim.t,
                m.dn.x.array.reshape(-1, 3)[i].copy(),
                m.displacement.x.array.reshape(-1, 3)[i].copy(),
            )
        )


@pytest.mark.parametrize("psi_deg", [90.0, 135.0])
def test_static_hard_magnetic_elastica(tmp_path, psi_deg):
    """A cantilever magnetized along its axis, in a uniform field at ψ to it, bends
    towards alignment; tip angle and tip position match the hard-magnetic elastica
    (shooting, independent of the FE code) within 0.06 % (issue 4 asks 1 %), each
    coordinate relative to its own value (20×1 quadrilaterals; reached ≤ 6.2e-5,
    0.006 %: x at ψ = 135°)."""
    psi = math.radians(psi_deg)
    direction = [math.cos(psi), 0.0, math.sin(psi)]
    observe = TipDirector()
    sim = run_scene(
        write_scene(tmp_path, CANTILEVER),
        f"magnetic.field.direction={direction}",
        observers=[observe],
        out_dir=tmp_path / "out",
    )
    assert sim.summary["active_effects"] == ["elasticity", "magnetic"]
    lam = 100.0 * 3.0e-3 * THICKNESS * 1.0 * LENGTH**2 / 1.0
    theta, x, z = elastica_tip(lam, psi)
    t, d, u = observe.rows[-1]
    # director d = (−sin θ, 0, cos θ) for a strip bent in the XZ plane
    theta_fe = math.atan2(-d[0], d[2])
    x_fe, z_fe = (LENGTH + u[0]) / LENGTH, u[2] / LENGTH
    print(
        f"ψ = {psi_deg}°, λ = {lam}: tip angle FE {math.degrees(theta_fe):.3f}° vs "
        f"elastica {math.degrees(theta):.3f}°; tip (x, z)/L FE ({x_fe:.4f}, {z_fe:.4f}) vs "
        f"({x:.4f}, {z:.4f}); relative errors {abs(theta_fe / theta - 1):.1e}, "
        f"{abs(x_fe / x - 1):.1e}, {abs(z_fe / z - 1):.1e}"
    )
    assert abs(theta_fe / theta - 1) < 6e-4
    assert abs(x_fe / x - 1) < 6e-4 and abs(z_fe / z - 1) < 6e-4
    assert 0 < theta < psi


def test_field_protocol():
    """b(t): linear ramp along `direction`, then right-handed rotation about the axis."""
    from rftfem.model.magnetic_sources import UniformField

    field_at = UniformField(
        {
            "kind": "rotating",
            "strength": 2.0,
            "ramp_time": 0.5,
            "direction": [2.0, 0.0, 0.0],
            "frequency": 4.0,
            "rotation_axis": [0.0, 0.0, 3.0],
        }
    ).at
    assert np.allclose(field_at(0.25), [1.0, 0, 0])
    assert np.allclose(field_at(0.5), [2.0, 0, 0])
    assert np.allclose(field_at(0.5 + 1 / 16), [0, 2.0, 0], atol=1e-12)  # quarter turn: +Y
    assert np.allclose(field_at(0.5 + 1 / 4), [2.0, 0, 0], atol=1e-12)


def test_magnetic_form_absent_without_magnetic(tmp_path):
    """Without [magnetic] nothing magnetic is built or compiled; with it, the
    remanence field enters the compiled forces."""
    dry = build_model(CANTILEVER.split("[magnetic]")[0], tmp_path)
    assert "magnetic" not in dry.effects and dry.get("magnetic") is None
    names = [c.name for c in dry.forces_ufl.coefficients()]
    assert "remanent_magnetization" not in names
    wet = build_model(CANTILEVER, tmp_path)
    assert wet.active_effects() == ["elasticity", "magnetic"]
    assert "remanent_magnetization" in [c.name for c in wet.forces_ufl.coefficients()]


# --- docs/verification.md case G: a rigid magnetic plate in a rotating field (Adler)

PLATE_L, PLATE_W, PLATE_T = 2.0, 1.0, 0.1
# C₃ (N·s/mm³); C₁ = C₂ = 2 C₃, so that a coefficient used for the wrong spin
# shows.  Not the other way round: with C₃ = 2 C₁ the planar slipping about the
# in-plane axis is unstable (tilting out of the plane grows from round-off,
# 1e-14 to 5e-5 in three slip cycles) and after ~8 turns the plate no longer
# moves as Adler's planar solution (+51 % mean rate at ω/ω_c = 1.2): that is
# three-dimensional physics, outside docs/verification.md case G.
DRAG = 1.0e-3
MB = 2 * math.pi * DRAG / 0.24  # m B: spin about the normal has ω_c = π rad/s

PLATE = f"""
title = "rigid magnetic plate in a rotating field"
[mesh]
kind = "strip"
length = {PLATE_L}
width = {PLATE_W}
divisions = [4, 2]
[[mesh.regions]]
name = "plate"
x = [0.0, {PLATE_L}]
[shell]
thickness = {PLATE_T}
E = 1.0e7
nu = 0.3
[time]
scheme = "backward-euler"
[fluid]
drag = [{2 * DRAG}, {2 * DRAG}, {DRAG}]
[magnetic]
[[magnetic.parts]]
region = "plate"
magnetization = {MB / 1.0e-3}
direction = [1.0, 0.0, 0.0]
[magnetic.field]
strength = 1.0e-3
ramp_time = 0.0
direction = [1.0, 0.0, 0.0]
"""

#: axis -> (rotation axis, ζ = rotational drag about it through the centre)
AXES = {
    "normal": (
        [0.0, 0.0, 1.0],  # C₁ ∫ r² dA
        2 * DRAG * PLATE_L * PLATE_W * (PLATE_L**2 + PLATE_W**2) / 12,
    ),
    "in-plane": ([0.0, 1.0, 0.0], DRAG * PLATE_W * PLATE_L**3 / 12),  # C₃ ∫ r⊥² dA
}


class PlateAngle:
    """Observer: the rotation angle about ``axis`` of the material line y = W/2 (unwrapped)."""

    def __init__(self, axis):
        self.axis = np.asarray(axis, dtype=float)
        self.times, self.angles = [0.0], [0.0]
        self.nodes = None

    def __call__(self, sim):
        m = sim.model
        if self.nodes is None:
            X = m.Vu.tabulate_dof_coordinates()
            self.nodes = [
                int(np.argmin(np.linalg.norm(X - p, axis=1)))
                for p in ([0.0, PLATE_W / 2, 0], [PLATE_L, PLATE_W / 2, 0])
            ]
            self.X = X
        x = self.X + m.displacement.x.array.reshape(-1, 3)
        v = x[self.nodes[1]] - x[self.nodes[0]]
        angle = math.atan2(np.cross([1.0, 0, 0], v) @ self.axis, v[0])
        previous = self.angles[-1]
        angle += 2 * math.pi * round((previous - angle) / (2 * math.pi))
        self.times.append(sim.t)
        self.angles.append(angle)


#: ω/ω_c -> relative tolerance on the lag or the mean rate (about 10 times the larger
#: of the two axes' errors: backward Euler at 100 steps per period, 4×2)
STEP_OUT_TOLERANCE = {0.5: 0.015, 0.9: 0.015, 1.2: 0.02, 2.0: 5e-4}


@pytest.mark.parametrize("axis_name", list(AXES))
@pytest.mark.parametrize("ratio", list(STEP_OUT_TOLERANCE))
def test_rigid_plate_step_out(tmp_path, axis_name, ratio):
    """docs/verification.md case G: below ω_c the plate follows the field with lag
    sin α = ω/ω_c; above, its mean rate is ω − √(ω² − ω_c²).  Case G publishes 2 %;
    asserted per ratio (4×2 quadrilaterals, normal / in-plane axis): lag at 0.5 and
    0.9 within 1.5 % (reached −0.11 % / −0.07 %, −0.14 % / −0.12 %), mean rate at
    1.2 within 2 % (+0.18 % / +0.18 %) and at 2 within 0.05 % (−0.004 % / +0.003 %).
    About the in-plane axis the plate (and its director) turns at least 5 times, with
    no failed step and | |d| − 1 | < 1e-10 at the end."""
    axis, zeta = AXES[axis_name]
    omega_c = MB * PLATE_T * PLATE_L * PLATE_W / zeta
    omega = ratio * omega_c
    # the in-plane axis spins the director without bound: at least 5 turns there
    turns = 5 if axis_name == "in-plane" else 0
    if ratio < 1:
        lag = math.asin(ratio)
        settle = 8 / (omega_c * math.cos(lag))  # 8 time constants of the lag
        end = max(settle, (turns + 0.5) * 2 * math.pi / omega if turns else 0.0)
        dt = 2 * math.pi / omega / 100
    else:
        slip = 2 * math.pi / math.sqrt(omega**2 - omega_c**2)
        rate = omega - math.sqrt(omega**2 - omega_c**2)
        end = slip * max(3, math.ceil(turns * 2 * math.pi / rate / slip))
        dt = min(2 * math.pi / omega, slip) / 100
    observe = PlateAngle(axis)
    sim = run_scene(
        write_scene(tmp_path, PLATE),
        f"magnetic.field.frequency={omega / (2 * math.pi)!r}",
        f"magnetic.field.rotation_axis={axis}",
        f"time.end={end!r}",
        f"time.dt={dt!r}",
        "output.fields=false",
        observers=[observe],
        out_dir=tmp_path / "out",
    )
    t, phi = np.array(observe.times), np.array(observe.angles)
    assert sim.summary["counts"]["dt_cuts"] == 0
    if ratio < 1:
        measured = omega * t[-1] - phi[-1]
        print(
            f"{axis_name}, ω/ω_c = {ratio}: lag {math.degrees(measured):.3f}° vs Adler "
            f"{math.degrees(lag):.3f}° ({100 * (measured / lag - 1):+.4f} %)"
        )
        assert abs(measured / lag - 1) < STEP_OUT_TOLERANCE[ratio]
    else:
        rate = phi[-1] / t[-1]  # whole slip cycles from t = 0
        exact = omega - math.sqrt(omega**2 - omega_c**2)
        print(
            f"{axis_name}, ω/ω_c = {ratio}: mean rate {rate:.4f} vs Adler {exact:.4f} "
            f"({100 * (rate / exact - 1):+.4f} %), {phi[-1] / (2 * math.pi):.2f} turns"
        )
        assert abs(rate / exact - 1) < STEP_OUT_TOLERANCE[ratio]
    assert phi[-1] >= turns * 2 * math.pi * 0.999
    assert sim.summary["director_unit_error"] < 1e-10


@pytest.mark.mpi
def test_magnetic_plate_mpirun_matches_serial(tmp_path, cli_run):
    """`mpirun -n 2` on the magnetic plate in a rotating field (above step-out, with a
    probe) gives the serial probe history to 1e-8."""
    scene = write_scene(
        tmp_path,
        PLATE.replace("divisions = [4, 2]", "divisions = [8, 4]")
        + """
[[output.probes]]
name = "corner"
at = [2.0, 1.0, 0.0]
""",
    )
    sets = [
        "magnetic.field.frequency=2.0",
        "magnetic.field.rotation_axis=[0.0,1.0,0.0]",
        "time.end=0.4",
        "time.dt=0.005",
        "output.fields=false",
    ]
    histories = {}
    for n in (1, 2):
        out = cli_run(scene, tmp_path / f"np{n}", sets, np=n)
        histories[n] = np.loadtxt(out / "probes.csv", delimiter=",", skiprows=1)
    scale = np.abs(histories[1][:, 1:]).max()
    assert scale > 0.5
    assert np.abs(histories[2] - histories[1]).max() < 1e-8 * scale


def test_part_switched_off(tmp_path):
    """A part with magnetization 0 (as a sweep may set) feels nothing and the run
    stays finite: the cantilever in the field stays straight."""
    sim = run_scene(
        write_scene(tmp_path, CANTILEVER),
        "magnetic.parts.0.magnetization=0.0",
        "time.end=0.2",
        out_dir=tmp_path / "out",
    )
    assert sim.summary["status"] == "ok"
    assert np.abs(sim.model.displacement.x.array).max() == 0.0


# --- energy bookkeeping in a rotating field ------------------------------------------

ENERGY = f"""
title = "magnetic cantilever in a rotating field: energy bookkeeping"
[mesh]
kind = "strip"
length = {LENGTH}
width = 1.0
divisions = [20, 1]
[[mesh.regions]]
name = "tip"
x = [7.0, {LENGTH}]
[shell]
thickness = {THICKNESS}
E = {E}
nu = 0.0
density = 1.0e-3
[fluid]
drag = [5.0e-4, 5.0e-4, 1.0e-3]
[time]
scheme = "generalized-alpha"
rho_inf = 1.0
end = 12.0
dt = 0.025
[[boundary]]
where = "x=0"
fix = ["clamped"]
[magnetic]
[[magnetic.parts]]
region = "tip"
magnetization = 100.0
direction = [1.0, 0.0, 0.0]
[magnetic.field]
strength = 3.0e-3
ramp_time = 2.0
direction = [0.0, 0.0, 1.0]
frequency = 0.1
rotation_axis = [0.0, 1.0, 0.0]
"""


class EnergyBook:
    """Observer: the field's work ``Σ ½(b_n + b_{n+1})·(Q_{n+1} − Q_n)`` (Q the total
    moment ∫ t m q J dA₀), the drag dissipation ``Σ ½(P_n + P_{n+1}) Δt`` and the
    elastic and kinetic energies, step by step."""

    def __init__(self, model):
        self.t, self.Q, self.P = 0.0, model["magnetic"].moment(), 0.0
        self.E0 = model.elastic_energy() + model["inertia"].kinetic_energy()
        self.work = self.dissipation = 0.0
        self.rows = []

    def __call__(self, sim):
        m = sim.model
        Q, P = m["magnetic"].moment(), m["drag"].power()
        field = m["magnetic"].field_at
        self.work += 0.5 * (field(self.t) + field(sim.t)) @ (Q - self.Q)
        self.dissipation += 0.5 * (self.P + P) * (sim.t - self.t)
        kinetic = m["inertia"].kinetic_energy()
        stored = m.elastic_energy() + kinetic - self.E0
        self.rows.append((sim.t, self.work, self.dissipation, stored, kinetic))
        self.t, self.Q, self.P = sim.t, Q, P


def test_energy_bookkeeping_in_rotating_field(tmp_path):
    """Over a run in a rotating field, the work of the magnetic couple equals the
    drag dissipation plus the change of elastic and kinetic energy: within 1e-3 of
    the work at the end, and within 2e-3 of the work done so far at every step
    after the ramp (20×1, generalized-α ρ∞ = 1, dt = 0.025; reached 9.4e-5 and
    2.3e-4 on both stacks; a magnetic couple 0.5 % too strong in the residual,
    not in the moment, fails both, which 1 % did not see).  Each term carries
    weight: dissipation over half the work, stored elastic energy over a tenth,
    kinetic energy at its peak over a hundredth (reached 0.79, 0.21, 0.018)."""
    from rftfem.integration.simulation import Simulation
    from rftfem.scene.reading import load_scene

    sim = Simulation(load_scene(write_scene(tmp_path, ENERGY)), quiet=True)
    book = EnergyBook(sim.model)
    sim.observers.append(book)
    try:
        sim.run()
    finally:
        sim.close()
    t, work, dissipated, stored, kinetic = np.array(book.rows).T
    balance = dissipated + stored
    later = t > 2.0
    along = np.max(np.abs(work[later] - balance[later]) / work[later])
    print(
        f"field work {work[-1]:.6e}, drag dissipation {dissipated[-1]:.6e}, "
        f"Δ(elastic + kinetic) {stored[-1]:.6e}; max kinetic {kinetic.max():.3e}; "
        f"imbalance {abs(work[-1] - balance[-1]) / work[-1]:.2e} at the end, "
        f"at most {along:.2e} after the ramp"
    )
    assert work[-1] > 0 and dissipated[-1] > 0.5 * work[-1]
    assert stored[-1] > 0.1 * work[-1] and kinetic.max() > 0.01 * work[-1]
    assert abs(work[-1] - balance[-1]) < 1e-3 * work[-1]
    # and all along the run, relative to the work done so far
    assert along < 2e-3


def test_rigid_rotor_diagnostics(tmp_path):
    """The diagnostics behind the demo's step-out estimate, on the flat plate:
    ``rotational_drag`` is ζ of docs/verification.md case G about both axes, ``centroid`` the
    plate's centre, and ``magnetic_moment`` is t m A q₀."""
    from mpi4py import MPI

    model = build_model(
        PLATE, tmp_path, ["time.end=1.0", "time.dt=0.1"], comm=MPI.COMM_WORLD, compile_forms=True
    )
    assert np.allclose(model.centroid(), [PLATE_L / 2, PLATE_W / 2, 0.0], atol=1e-12)
    for axis, zeta in AXES.values():
        assert abs(model["drag"].rotational(axis) / zeta - 1) < 1e-10
    moment = model["magnetic"].moment()
    assert np.allclose(moment, [MB / 1.0e-3 * PLATE_T * PLATE_L * PLATE_W, 0, 0], rtol=1e-12)


TILTED = """
title = "a stretched, turned plate with an out-of-plane magnetization"
[mesh]
length = 2.0
width = 1.0
divisions = [2, 1]
[[mesh.regions]]
name = "plate"
x = [0.0, 2.0]
[shell]
thickness = 0.1
E = 1.0e3
[time]
end = 1.0
dt = 1.0
[magnetic]
[[magnetic.parts]]
region = "plate"
magnetization = 3.0
direction = [{q0x}, 0.0, {q0z}]
[magnetic.field]
strength = 0.7
direction = [0.3, -0.5, 0.8]
"""


def turned_plate_works(model, stretch, tilt):
    """The plate of TILTED (a model with its time set) turned by ``tilt`` about X
    (θ = (ψ, 0) about the triads' a₁ = X, then the triad update) and stretched by
    ``stretch`` along X: the magnetic residual's work on a virtual rigid rotation δφ
    of the whole plate (δu = δφ × x, δd = δφ × d) for δφ along X, Y, Z, and R."""
    from rftfem import compat

    model.w.x.array[:] = 0.0
    model.w.x.array[model.theta_dofs.reshape(-1, 2)[:, 0]] = tilt
    model.update_triad()
    R = np.array(
        [[1, 0, 0], [0, math.cos(tilt), -math.sin(tilt)], [0, math.sin(tilt), math.cos(tilt)]]
    )
    d = model.triads[0][2].x.array.reshape(-1, 3)
    assert np.abs(d - R[:, 2]).max() < 1e-14
    X = model.Vu.tabulate_dof_coordinates()[:, :3]
    x = X @ (R @ np.diag([stretch, 1.0, 1.0])).T
    model.w.x.array[model.u_dofs] = (x - X).ravel()
    F = model.mapped(model.effects["magnetic"])
    vec = compat.create_vector(F, model.W)
    compat.assemble_vector(vec, F)
    residual = vec.getArray().copy()
    vec.destroy()
    a1, a2 = (f.x.array.reshape(-1, 3) for f in model.triads[0][:2])
    node = model.triad.node_maps[0]
    works = []
    for axis in np.eye(3):
        virtual = np.zeros_like(model.w.x.array)
        virtual[model.u_dofs] = np.cross(axis, x).ravel()
        theta = virtual[model.theta_dofs].reshape(-1, 2)
        theta[:, 0], theta[:, 1] = a1[node] @ axis, a2[node] @ axis
        virtual[model.theta_dofs] = theta.ravel()
        works.append(residual @ virtual)
    return works, R


@pytest.mark.parametrize("stretch, tilt", [(1.0, 0.0), (1.3, 0.0), (1.3, 0.7)])
def test_couple_of_a_stretched_turned_plate_with_out_of_plane_magnetization(
    tmp_path, stretch, tilt
):
    """Exact: a flat plate (normal N = Z) stretched by λ along X and turned rigidly by
    ψ = 0.7 about X, magnetized along q₀ = (cos φ, 0, sin φ) with φ = 40° (out of its
    plane), in a uniform field b.  With F = F_s + d ⊗ N = R (S + N ⊗ N) the fibre is
    q = R (λ cos φ, 0, sin φ) / |·| and J = λ, so a virtual rigid rotation δφ of the
    whole plate (δu = δφ × x, δd = δφ × d) takes the magnetic virtual work
    −t m J A (q × b)·δφ from the residual, and the total moment is t m J A q.
    Checked to 1e-12 for δφ along X, Y, Z.  The d ⊗ N part (its out-of-plane
    component turns with the director, not with N), the J factor and the unit |F q₀|
    each show: with N ⊗ N in place of d ⊗ N the turned case fails, without J the
    stretched ones."""
    phi = math.radians(40.0)
    model = build_model(TILTED.format(q0x=math.cos(phi), q0z=math.sin(phi)), tmp_path)
    model.set_time(1.0)
    b = model["magnetic"].field_at(1.0)
    works, R = turned_plate_works(model, stretch, tilt)
    q = R @ np.array([stretch * math.cos(phi), 0.0, math.sin(phi)])
    q /= np.linalg.norm(q)
    t, m, area = 0.1, 3.0, 2.0
    for axis, work in zip(np.eye(3), works):
        exact = -t * m * stretch * area * np.cross(q, b) @ axis
        print(f"λ = {stretch}, ψ = {tilt}, δφ = {axis}: {work:+.15e} exact {exact:+.15e}")
        assert work == pytest.approx(exact, rel=1e-12, abs=1e-14 * t * m * area * 0.7)
    moment = model["magnetic"].moment()
    assert moment == pytest.approx(t * m * stretch * area * q, rel=1e-12, abs=1e-15)
