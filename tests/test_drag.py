"""Resistive-force drag (docs/model.md §5.4, issue 3): terminal velocities, reactions,
frame objectivity, dissipation, and the effect switch."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import build_model, run_scene, write_scene

#: RFT coefficients (N·s/mm³) deliberately all different, so a wrong axis shows
DRAG = (1.0e-3, 2.0e-3, 4.0e-3)
FORCE = 1.0e-3  # N, total
LENGTH, WIDTH = 4.0, 1.0
#: a rigid translation is exact in the discretisation: only the Newton tolerance
#: and round-off separate it from F / (C A) (reached: ≤ 9.5e-11 relative, the normal
#: pull's nodal spread)
TOL = 5.0e-10

STRIP = f"""
title = "stiff free strip in a viscous fluid"
[mesh]
kind = "strip"
length = {LENGTH}
width = {WIDTH}
divisions = [4, 1]
[shell]
thickness = 0.1
E = 1.0e6
nu = 0.3
[time]
end = 0.3
dt = 0.1
[fluid]
drag = {list(DRAG)}
"""


def _pull(where: tuple[str, str], direction) -> str:
    """Half the total force on each end: no net moment about the centre."""
    value = [float(v) for v in 0.5 * FORCE * np.asarray(direction, dtype=float)]
    return "".join(
        f"""
[[load]]
kind = "edge-force"
where = "{w}"
value = {value}
ramp = "constant"
"""
        for w in where
    )


class MeanVelocity:
    """Observer: the mean nodal velocity after each step (rigid translation: all equal)."""

    def __init__(self):
        self.rows = []

    def __call__(self, sim):
        v = sim.model.v_n.x.array.reshape(-1, 3)
        self.rows.append((v.mean(axis=0), np.ptp(v, axis=0)))


@pytest.mark.parametrize("i", [0, 1, 2], ids=["along", "across", "normal"])
def test_terminal_velocity_along_frame_directions(tmp_path, i):
    """A free strip pulled by a constant force F along e_i moves at F / (C_i A), every
    node alike (no inertia: the balance holds at every step, to round-off)."""
    direction = np.eye(3)[i]
    scene = write_scene(tmp_path, STRIP + _pull(("x=0", "x=L"), direction))
    observe = MeanVelocity()
    sim = run_scene(scene, observers=[observe])
    assert sim.summary["active_effects"] == ["elasticity", "drag", "edge-force"]
    v, spread = observe.rows[-1]
    exact = FORCE / (DRAG[i] * LENGTH * WIDTH)
    print(f"e{i + 1}: v = {v}, exact {exact}, nodal spread {spread}")
    assert abs(v[i] / exact - 1) < TOL
    assert np.abs(np.delete(v, i)).max() < TOL * exact
    assert spread.max() < TOL * exact
    # and the drag balances the pull: ∫ C̃ v J dA₀ = F e_i
    assert np.allclose(sim.model["drag"].force(), FORCE * direction, rtol=0, atol=TOL * FORCE)


def _rotation():
    """30° about X, then 30° about Z."""
    c, s = math.cos(math.pi / 6), math.sin(math.pi / 6)
    Rx = np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    Rz = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    return Rz @ Rx


def _write_rotated_strip(path, R):
    """The 4 × 1 strip as a gmsh file, rotated by R: surface "strip", ends "head"/"tail"."""
    import gmsh

    gmsh.initialize(readConfigFiles=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("rotated-strip")
        geo = gmsh.model.geo
        corners = [
            R @ np.array(p) for p in ((0, 0, 0), (LENGTH, 0, 0), (LENGTH, WIDTH, 0), (0, WIDTH, 0))
        ]
        pts = [geo.addPoint(*p) for p in corners]
        lines = [geo.addLine(pts[k], pts[(k + 1) % 4]) for k in range(4)]
        surface = geo.addPlaneSurface([geo.addCurveLoop(lines)])
        geo.synchronize()
        for line, n in zip(lines, (5, 2, 5, 2)):
            gmsh.model.mesh.setTransfiniteCurve(line, n)
        gmsh.model.mesh.setTransfiniteSurface(surface)
        gmsh.model.mesh.setRecombine(2, surface)
        for dim, tags, tag, name in (
            (2, [surface], 1, "strip"),
            (1, [lines[1]], 2, "head"),
            (1, [lines[3]], 3, "tail"),
        ):
            gmsh.model.addPhysicalGroup(dim, tags, tag)
            gmsh.model.setPhysicalName(dim, tag, name)
        gmsh.model.mesh.generate(2)
        gmsh.write(str(path))
    finally:
        gmsh.finalize()


@pytest.mark.parametrize("i", [0, 1, 2], ids=["along", "across", "normal"])
def test_terminal_velocity_is_frame_objective(tmp_path, i):
    """The same strip rotated 30° about X and then about Z, with its material axis
    rotated alike: the terminal velocity is F / (C_i A) along the rotated e_i."""
    R = _rotation()
    _write_rotated_strip(tmp_path / "strip.msh", R)
    direction = R @ np.eye(3)[i]
    text = STRIP.replace('kind = "strip"', 'kind = "gmsh"\nfile = "strip.msh"')
    text = text.replace("nu = 0.3", f"nu = 0.3\naxis = {[float(v) for v in R[:, 0]]}")
    scene = write_scene(tmp_path, text + _pull(("head", "tail"), direction))
    observe = MeanVelocity()
    run_scene(scene, observers=[observe])
    v, _ = observe.rows[-1]
    exact = FORCE / (DRAG[i] * LENGTH * WIDTH)
    print(f"rotated e{i + 1}: v = {v}, exact {exact} along {direction}")
    assert abs(v @ direction / exact - 1) < TOL
    assert np.linalg.norm(v - (v @ direction) * direction) < TOL * exact


def test_reaction_of_a_strip_translating_at_prescribed_velocity(tmp_path):
    """Every node moves at a prescribed constant velocity: the reaction taken from
    the assembled residual (the sum of its displacement rows) is C̃ v A."""
    velocity = np.array([0.3, -0.2, 0.5])
    motions = "".join(
        f"""
[[motion]]
where = "all"
component = "{c}"
kind = "table"
values = [[0.0, 0.0], [1.0, {vc}]]
"""
        for c, vc in zip(("ux", "uy", "uz"), velocity)
    )
    reactions = []

    def reaction(sim):
        F = sim.solver.F_n.getArray()  # forces at the converged state; serial run
        reactions.append(F[sim.model.u_dofs].reshape(-1, 3).sum(axis=0))

    sim = run_scene(write_scene(tmp_path, STRIP + motions), observers=[reaction])
    exact = np.asarray(DRAG) * velocity * LENGTH * WIDTH
    print(f"reaction {reactions[-1]}, exact {exact}")
    for r in reactions:
        assert np.allclose(r, exact, rtol=TOL, atol=0)
    assert np.allclose(sim.model["drag"].force(), exact, rtol=TOL, atol=0)


def test_drag_residual_vanishes_at_rest(tmp_path):
    """For a deformed, rotated body at rest (u = u_n, v_n = a_n = 0) the drag term
    assembles to zero (to round-off, 1e-13 of the term's value once the body moves
    by 1e-3 in one step); moving it makes the term non-zero."""
    from rftfem import compat
    from rftfem.integration.schemes import make_scheme

    model = build_model(STRIP.replace("E = 1.0e6", "E = 1.0e6\ndensity = 1.0e-6"), tmp_path)
    model.set_coefficients(make_scheme(model.scene["time"]).coefficients(0.1))
    drag = model.mapped(model.effects["drag"])  # on z, assembled into w (directors.py)
    rng = np.random.default_rng(3)
    for _ in range(2):  # rotate the triad far from the reference
        model.w.x.array[:] = rng.uniform(-1, 1, len(model.w.x.array))
        model.update_triad()
    u = rng.uniform(-0.5, 0.5, len(model.u_dofs))
    model.u_n.x.array[:] = u
    model.w.x.array[model.u_dofs] = u

    def norm():
        b = compat.create_vector(drag, model.W)
        compat.assemble_vector(b, drag)
        value = b.norm()
        b.destroy()
        return value

    rest = norm()
    model.w.x.array[model.u_dofs] += 1e-3
    moved = norm()
    # zero but for round-off: the compiler may reassociate (u - u_n) with the
    # scheme's other terms (rftfem/compat/compilation.py's flags)
    assert moved > 0.0 and rest <= 1e-13 * moved


def test_drag_form_absent_without_fluid(tmp_path):
    """Without [fluid] the drag is neither built nor compiled (no drag coefficients
    among the compiled forces' constants); with it, it is."""

    def constants(text):
        model = build_model(text, tmp_path)
        values = [np.atleast_1d(c.value) for c in model.forces_ufl.constants()]
        return model, values

    dry, values = constants(STRIP.split("[fluid]")[0] + _pull(("x=L",), [1, 0, 0]))
    assert "drag" not in dry.effects and "drag" not in dry.active_effects()
    assert not hasattr(dry, "drag_coefficients")
    assert not any(len(v) == 3 and np.allclose(v, DRAG) for v in values)
    wet, values = constants(STRIP + _pull(("x=L",), [1, 0, 0]))
    assert wet.active_effects() == ["elasticity", "drag", "edge-force"]
    assert any(len(v) == 3 and np.allclose(v, DRAG) for v in values)


def _deformed_drag_force(model, F, R, v):
    """The drag force ``∫ C̃ v J dA₀`` of the strip deformed by ``x = R F X`` and moving at
    the uniform velocity ``v`` (set as the stored state; no solve)."""
    X = model.Vu.tabulate_dof_coordinates()
    u = X @ (R @ F).T - X
    model.u_n.x.array[:] = u.ravel()
    model.w.x.array[model.u_dofs] = u.ravel()
    model.v_n.x.array[:] = np.tile(v, len(X))
    return model["drag"].force()


def _exact_drag_force(F, R, v, area):
    """C̃ v J A with the frame of docs/model.md §5.4 built by hand from x = R F X: e₁ the
    pushed-forward material axis (X), e₃ the normal of the deformed plane."""
    g1, g2 = R @ F[:, 0], R @ F[:, 1]
    e1 = g1 / np.linalg.norm(g1)
    n = np.cross(g1, g2)
    J = np.linalg.norm(n)  # |g₁ × g₂| / |G₁ × G₂| with G₁ × G₂ = e_z
    e3 = n / J
    e2 = np.cross(e3, e1)
    C = sum(c * np.outer(e, e) for c, e in zip(DRAG, (e1, e2, e3)))
    return C @ v * J * area


@pytest.mark.parametrize("case", ["stretched", "sheared"])
def test_drag_on_a_deformed_translating_strip(tmp_path, case):
    """A strip stretched 1.4 × 0.7 (or sheared 0.5 in plane and 0.3 out of it) and
    moving at a uniform velocity: the drag force is C̃ v J A with the pushed-forward
    axis and the current area, to round-off; and with the whole state turned by a
    rotation R (configuration and velocity), the force turns with it (objectivity)."""
    model = build_model(STRIP, tmp_path)
    F = (
        np.diag([1.4, 0.7, 1.0])
        if case == "stretched"
        else np.array([[1.0, 0.5, 0.0], [0.0, 1.0, 0.0], [0.0, 0.3, 1.0]])
    )
    v = np.array([0.3, -0.2, 0.5])
    a = 0.9
    axis = np.array([1.0, 2.0, 2.0]) / 3.0
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    R = np.eye(3) + np.sin(a) * K + (1 - np.cos(a)) * K @ K
    for rotation, velocity in ((np.eye(3), v), (R, R @ v)):
        got = _deformed_drag_force(model, F, rotation, velocity)
        exact = _exact_drag_force(F, rotation, velocity, LENGTH * WIDTH)
        print(f"{case}: drag force {got}, exact {exact}")
        assert np.allclose(got, exact, rtol=0, atol=1e-12 * np.linalg.norm(exact))


@pytest.mark.parametrize("start", ["rest", "equilibrium"])
def test_free_body_start(tmp_path, start):
    """A free strip in drag under a force on at t = 0.  By default the run starts at
    rest in the reference state (docs/model.md §6.7): z = F t / (C A) at every row,
    t = 0 included.  With time.start = "equilibrium" a free body has no static
    equilibrium under the force, and the t = 0 solve is one backward-Euler step dt from
    the reference: the first row already has the strip moved F dt / (C A), and then it
    moves at F / (C A).  To 5e-10 of the travel from rest (reached 2.3e-11), 5e-9 from
    the equilibrium start, whose t = 0 solve stops at Newton's tolerance without a
    forced update (reached 6.5e-10)."""
    direction = np.eye(3)[2]
    scene = write_scene(tmp_path, STRIP + _pull(("x=0", "x=L"), direction))
    sim = run_scene(scene, f'time.start="{start}"', out_dir=tmp_path / "out")
    body = np.genfromtxt(tmp_path / "out" / "body.csv", delimiter=",", names=True)
    speed = FORCE / (DRAG[2] * LENGTH * WIDTH)
    dt = sim.scene["time"]["dt"]
    ahead = dt if start == "equilibrium" else 0.0
    print(f"{start}: z at t = 0: {body['centroid_z'][0]:.6e}; then z = {body['centroid_z']}")
    assert body["time"][0] == 0.0
    travel = speed * (body["time"][-1] + ahead)
    err = np.abs(body["centroid_z"] - speed * (body["time"] + ahead)).max() / travel
    print(f"error {err:.1e} of the travel")
    assert err < (TOL if start == "rest" else 5e-9)
