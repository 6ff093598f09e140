"""``[[load]]`` kind = "point-force": a dead force at a material point.

Exact checks: the nodal force vector carries the force and its first moment
exactly (at a point inside a cell, not on a node), a cantilever strip under a
tip point load bends as Euler–Bernoulli says (ν = 0, linear range), and two
processes give what one gives.
"""

import numpy as np
import pytest
from conftest import build_model, run_scene, write_scene

CANTILEVER = """
title = "cantilever strip under a tip point load"
[mesh]
length = 10.0
width = 1.0
divisions = [20, 2]
[shell]
thickness = 0.1
E = 1.2e6
nu = 0.0
[time]
end = 1.0
dt = 1.0
[[boundary]]
where = "x=0"
fix = ["clamped"]
[[load]]
kind = "point-force"
at = [10.0, 0.5, 0.0]
value = [0.0, 0.0, -1.0e-4]
[[output.probes]]
name = "left"
at = [10.0, 0.0, 0.0]
[[output.probes]]
name = "middle"
at = [10.0, 0.5, 0.0]
[[output.probes]]
name = "right"
at = [10.0, 1.0, 0.0]
"""

#: Euler–Bernoulli tip deflection P L³ / (3 E I), I = b t³ / 12
EXACT_TIP = 1.0e-4 * 10.0**3 / (3 * 1.2e6 * 1.0 * 0.1**3 / 12)


def test_nodal_vector_carries_the_force_and_its_moment(tmp_path):
    """Σ f_i = P and Σ X_i f_i = X_p P to round-off at a point inside a cell (the shape
    functions are a partition of unity and reproduce linear fields)."""
    at, force = [3.3, 0.37, 0.0], np.array([0.2, -0.7, 1.3])
    model = build_model(
        CANTILEVER,
        tmp_path,
        [f"load.0.at={at}", f"load.0.value={force.tolist()}", "load.0.ramp=constant"],
    )
    model.set_time(0.5)
    F = np.zeros(len(model.w.x.array))
    model["point-force"].add_nodal_forces(F)
    f = -F[model.u_dofs].reshape(-1, 3)  # F is internal minus external
    X = model.Vu.tabulate_dof_coordinates()
    assert np.count_nonzero(np.abs(f).sum(axis=1)) == 9  # the nodes of one Q2 cell
    assert np.allclose(f.sum(axis=0), force, rtol=0, atol=1e-14)
    assert np.allclose(X.T @ f, np.outer(at, force), rtol=0, atol=1e-13)


def test_cantilever_tip_point_load_matches_beam_theory(tmp_path):
    """Mean tip deflection within 0.03 % of P L³ / 3EI (ν = 0, w/L = 3e-5; 20x2
    quadrilaterals, reached +0.003 %)."""
    sim = run_scene(write_scene(tmp_path, CANTILEVER))
    w = -sim.history[-1][1][:, 2]
    print(
        f"tip deflections {w} (left, middle, right); beam theory {EXACT_TIP:.6e}; "
        f"mean {100 * (w.mean() / EXACT_TIP - 1):+.4f} %"
    )
    assert abs(w.mean() / EXACT_TIP - 1) < 3e-4
    assert abs(w[0] - w[2]) < 1e-12 * EXACT_TIP  # symmetric: no twist


def test_ramp_scales_the_force(tmp_path):
    """A linear ramp at half time gives half the deflection (linear range)."""
    sim = run_scene(write_scene(tmp_path, CANTILEVER), "time.dt=0.5")
    (t0, half), (t1, full) = sim.history[-2][0:2], sim.history[-1][0:2]
    assert (t0, t1) == (0.5, 1.0)
    assert half[1, 2] / full[1, 2] == pytest.approx(0.5, rel=1e-6)


def test_free_strip_pushed_at_a_point_moves_its_centre_of_mass(tmp_path):
    """A free strip in vacuum pushed at a point by a force ramped f t / T: its centre
    of mass (the centroid: uniform ρ t) moves f t³ / (6 T M) whatever the strip does
    locally, as a rigid body (generalized-α keeps the momentum balance; the averaged
    forces α_f F_n carry the point force too): within 3e-4 of the travel, reached
    1.45e-4 on both stacks.  The force acts off the centre, so the strip also tumbles
    (about 0.2 rad per 2 ms step): time.max_rotation cuts dt to 1 ms three times, and
    the run takes 70 steps (30 of 2 ms, 40 of 1 ms) instead of 50."""
    scene = """
title = "a free strip pushed at a point"
[mesh]
length = 2.0
width = 0.5
divisions = [4, 1]
[shell]
thickness = 0.1
E = 1.2e6
density = 1.0e-9
[time]
end = 0.1
dt = 0.002
[solver]
snes_atol = 1.0e-18
[[load]]
kind = "point-force"
at = [1.3, 0.2, 0.0]
value = [0.0, 0.0, 1.0e-6]
"""
    out = tmp_path / "out"
    run_scene(write_scene(tmp_path, scene), out_dir=out)
    body = np.genfromtxt(out / "body.csv", delimiter=",", names=True)
    mass = 1.0e-9 * 0.1 * 2.0 * 0.5
    exact = 1.0e-6 * body["time"] ** 3 / (6 * 0.1 * mass)
    error = np.abs(body["centroid_z"] - exact).max() / exact[-1]
    print(
        f"centre of mass moved {body['centroid_z'][-1]:.6f}, exact {exact[-1]:.6f}; "
        f"largest error {error:.2e} of the travel"
    )
    assert error < 3e-4


@pytest.mark.mpi
def test_two_processes_give_the_serial_deflection(tmp_path, cli_run):
    """One process adds the force, into its local vector before the ghost sums: the
    load sits inside a cell next to where the two processes meet (on the reference
    stack that cell's nodes at x = 5 belong to the other process)."""
    scene = write_scene(
        tmp_path, CANTILEVER.replace("at = [10.0, 0.5, 0.0]\nvalue", "at = [5.1, 0.3, 0.0]\nvalue")
    )
    serial = run_scene(scene).history[-1][1]
    out = cli_run(scene, tmp_path / "mpi", np=2)
    row = np.loadtxt(out / "probes.csv", delimiter=",", skiprows=1)[-1]
    # time, the probes, then the load factor of a static run
    assert np.allclose(row[1:-1].reshape(-1, 3), serial, rtol=0, atol=1e-10 * EXACT_TIP)
