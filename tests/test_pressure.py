"""``[[load]]`` kind = "pressure": a follower pressure on a surface region.

Exact checks: a cantilever strip under a small uniform pressure bends as
Euler–Bernoulli says (ν = 0); on a rotated and stretched strip the total force
is p times the current area along the current normal (a dead load would keep
both); a free flat strip in RFT drag moves at p / C₃; and the load stiffness
from ``ufl.derivative`` is the exact derivative of the term (Taylor test).
"""

import numpy as np
import ufl
from conftest import build_model, run_scene, write_scene

from rftfem import compat

L, B, T, E = 10.0, 1.0, 0.1, 1.2e6
CANTILEVER = f"""
title = "cantilever strip under a uniform pressure"
[mesh]
length = {L}
width = {B}
divisions = [20, 1]
[shell]
thickness = {T}
E = {E}
nu = 0.0
[time]
end = 1.0
dt = 1.0
[[boundary]]
where = "x=0"
fix = ["clamped"]
[[load]]
kind = "pressure"
value = -1.0e-6
[[output.probes]]
name = "tip"
at = [{L}, {B / 2}, 0.0]
"""


def _vector(model, form):
    """An assembled vector of a UFL form on z, as one on w, on the local dofs (serial)."""
    compiled = model.mapped(form)
    b = compat.create_vector(compiled, model.W)
    compat.assemble_vector(b, compiled)
    out = b.getArray().copy()
    b.destroy()
    return out


def test_cantilever_under_pressure_matches_beam_theory(tmp_path):
    """Tip deflection within 0.07 % of q b L⁴ / 8EI, I = b t³ / 12 (w/L ≈ 1e-6), on
    20×1 Q2 cells in one load step: reached 0.0066 % on both stacks.  0.07 % is about
    ten times that; a pressure 0.5 % too strong fails it (1 % did not see it)."""
    sim = run_scene(write_scene(tmp_path, CANTILEVER))
    exact = 1.0e-6 * B * L**4 / (8 * E * B * T**3 / 12)
    w = -sim.history[-1][1][0, 2]
    print(f"tip deflection {w:.6e}, beam theory {exact:.6e}: error {w / exact - 1:+.2e}")
    assert abs(w / exact - 1) < 7e-4


def test_two_pressures_one_on_a_region_superpose(tmp_path):
    """q₁ on all of the cantilever and q₂ on its outer half (5 ≤ X ≤ 10), each with its
    own ramp, at half time: tip deflection within 0.06 % of the beam's
    q₁ b L⁴/8EI + q₂ b (3L⁴ − 4a³L + a⁴)/24EI with a = 5 (20×1, one step): reached
    0.0061 % on both stacks; a pressure 0.5 % too strong fails it."""
    scene = (
        CANTILEVER
        + """
[[mesh.regions]]
name = "outer"
x = [5.0, 10.0]
[[load]]
kind = "pressure"
where = "outer"
value = -3.0e-6
ramp = "table"
table = [[0.0, 0.0], [0.5, 1.0]]
"""
    )
    sim = run_scene(
        write_scene(tmp_path, scene), "time.end=0.5", "time.dt=0.5", "load.0.ramp=constant"
    )
    EI, a = E * B * T**3 / 12, 5.0
    exact = 1.0e-6 * B * L**4 / (8 * EI) + 3.0e-6 * B * (3 * L**4 - 4 * a**3 * L + a**4) / (24 * EI)
    w = -sim.history[-1][1][0, 2]
    print(f"tip deflection {w:.6e}, beam theory {exact:.6e}: error {w / exact - 1:+.2e}")
    assert abs(w / exact - 1) < 6e-4


def test_pressure_and_magnetic_parts_share_one_form(tmp_path):
    """A pressure with [magnetic] (whose parts have their own cell measure) builds,
    compiles and runs: the pressure's region enters as a 0/1 field, not as tags."""
    scene = (
        CANTILEVER.replace("divisions = [20, 1]", "divisions = [4, 1]")
        + """
[[mesh.regions]]
name = "tip"
x = [7.5, 10.0]
[magnetic]
[[magnetic.parts]]
region = "tip"
magnetization = 0.0
direction = [1.0, 0.0, 0.0]
"""
    )
    sim = run_scene(write_scene(tmp_path, scene))
    assert sim.summary["status"] == "ok" and "magnetic" in sim.summary["active_effects"]


def test_total_force_follows_the_current_area_and_normal(tmp_path):
    """u = R S X − X (S stretches X by 1.3 and Y by 0.8, R turns 0.7 rad about X):
    the pressure's total force is p (1.3 · 0.8 A) R e_z to round-off."""
    model = build_model(CANTILEVER, tmp_path, ["load.0.value=2.5", "load.0.ramp=constant"])
    model.set_time(1.0)
    a = 0.7
    R = np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])
    S = np.diag([1.3, 0.8, 1.0])
    X = model.Vu.tabulate_dof_coordinates()
    model.w.x.array[model.u_dofs] = (X @ (R @ S - np.eye(3)).T).ravel()
    F = -_vector(model, model.effects["pressure"])[model.u_dofs].reshape(-1, 3)
    expected = 2.5 * 1.3 * 0.8 * L * B * R[:, 2]
    print(f"total force {F.sum(axis=0)}, expected {expected}")
    assert np.allclose(F.sum(axis=0), expected, rtol=0, atol=1e-12 * np.abs(expected).max())


def test_free_strip_in_drag_moves_at_p_over_c3(tmp_path):
    """No inertia: C₃ v = p on a flat free strip, so the centroid moves along the
    normal at p / C₃ from the first step (backward Euler is exact here)."""
    scene = CANTILEVER.replace('[[boundary]]\nwhere = "x=0"\nfix = ["clamped"]\n', "")
    scene += "[fluid]\ndrag = [1.0e-6, 2.0e-6, 4.0e-6]\n"
    run_scene(
        write_scene(tmp_path, scene),
        "time.dt=0.25",
        "load.0.value=2.0e-6",
        "load.0.ramp=constant",
        out_dir=tmp_path / "out",
    )
    body = np.genfromtxt(tmp_path / "out" / "body.csv", delimiter=",", names=True)
    v = np.diff(body["centroid_z"]) / np.diff(body["time"])
    print(f"centroid speeds {v}, p / C3 = {2.0e-6 / 4.0e-6}")
    assert np.allclose(v[1:], 0.5, rtol=1e-6, atol=0)
    assert (
        abs(body["centroid_x"] - L / 2).max() < 1e-9
        and abs(body["centroid_y"] - B / 2).max() < 1e-9
    )


def test_load_stiffness_is_the_exact_derivative(tmp_path):
    """|R(w + εδ) − R(w) − ε J δ| falls as ε² for the pressure term alone, at a random
    curved and stretched state (J from ufl.derivative: the follower's load stiffness)."""
    model = build_model(CANTILEVER, tmp_path, ["load.0.value=3.0", "load.0.ramp=constant"])
    model.set_time(1.0)
    term = model.effects["pressure"]
    rng = np.random.default_rng(3)
    model.w.x.array[:] = rng.uniform(-0.3, 0.3, len(model.w.x.array))
    from rftfem.model.mapped_forms import MappedForm

    term_z = model.compile(term)

    def residual_z():  # the term's z rows, for the directors' curvature G
        b = compat.petsc_vec(model.z).duplicate()
        with b.localForm() as local:
            local.set(0.0)
        compat.assemble_vector(b, term_z)
        b.ghostUpdate(addv=2, mode=1)  # ADD, REVERSE
        return b.array_r.copy()

    J = MappedForm(
        model.compile(ufl.derivative(term, model.z, ufl.TrialFunction(model.Z))),
        model.directors,
        residual=residual_z,
    )
    A = compat.create_matrix(J)
    compat.assemble_matrix(A, J, [])
    A.assemble()
    dense = A.convert("dense").getDenseArray().copy()
    A.destroy()
    assert np.abs(dense).max() > 0, "a follower pressure has a load stiffness"
    w0, delta = model.w.x.array.copy(), rng.uniform(-1, 1, len(model.w.x.array))
    r0, jd = _vector(model, term), dense @ delta
    remainders = []
    for e in (1e-2, 5e-3, 2.5e-3):
        model.w.x.array[:] = w0 + e * delta
        remainders.append(np.linalg.norm(_vector(model, term) - r0 - e * jd))
    orders = np.log(np.array(remainders[:-1]) / remainders[1:]) / np.log(2)
    print(f"remainders {remainders}, orders {orders}")
    assert orders.min() >= 1.9
