"""Stokes flow (``[fluid] model = "stokes"``, docs/stokes.md) with what the other
Stokes tests leave out: a wall under ``mpirun``, magnetic couples, hinges and the
HHT scheme, each on a small body and a few steps, against a figure that does not
come from the code under test:

- the swimming sheet over a tilted wall on two processes against one (each process
  evaluates its share of the rows of the wall's images: rftfem/model/stokeslets.py,
  rftfem/model/stokes_layer.py);
- a free strip half magnetized in a uniform field: without inertia the liquid's
  resultant balances the field's couple ``Q × b`` (Q the magnetic moment in
  body.csv), with no net force;
- a free two-link strip (a free hinge) pushed at one link: the liquid balances the
  load, and the far link's liquid and load have no moment about the hinge's line;
- a stiff strip sinking under its weight from rest under HHT: its centroid follows
  the rigid ``m ż' = m g − R ż`` (R the body's resistance), with order 2 in dt.
"""

from __future__ import annotations

import math
from contextlib import contextmanager

import numpy as np
import pytest
from conftest import write_scene

from rftfem.integration.simulation import Simulation
from rftfem.scene.reading import load_scene

#: tight Newton (as tests/test_sensitivity.py): the balances below are then round-off
TIGHT = ["-snes_atol", "1e-13", "-snes_stol", "1e-15"]


@contextmanager
def _simulated(tmp_path, text, petsc_args=TIGHT):
    """The Simulation of a scene text, run; closed when the block ends."""
    sim = Simulation(
        load_scene(write_scene(tmp_path, text)), out_dir=None, quiet=True, petsc_args=petsc_args
    )
    try:
        sim.run()
        yield sim
    finally:
        sim.close()


def _last_row(sim) -> dict:
    return dict(zip(sim.body.header(), sim.body.values(sim.t)))


def _vector(row, name) -> np.ndarray:
    return np.array([row[name.format(c)] for c in "xyz"])


# --- a wall under mpirun ----------------------------------------------------------


@pytest.mark.mpi
@pytest.mark.parametrize(
    "method, tolerance",
    [("layer", 1e-13), ("blobs", 2.5e-13), ("blobs-direct", 2.5e-13), ("blobs-fmm", 2.5e-13)],
)
def test_wall_two_processes_match_one(tmp_path, cli_run, method, tolerance):
    """Ten steps of the swimming sheet (generalized-α, inertia, a travelling wave)
    over a tilted wall (3.3 blobs below it) on two processes against one: every
    body.csv and probes.csv column within 1e-13 (layer) and 2.5e-13 (blobs) of its
    vector's scale (reached 1.1e-14 and 2.4e-14 over the two stacks).  Broke: the
    images' targets of Wall.mobility taken from the first rows (``x[:hi − lo]``, the
    first process's) → 2.2 (blobs); the layer's rows so with a wall → 1.9e2, and in
    its position derivative alone (the Newton tangent only) → 4.4e-11.  The blobs'
    matrix-free direct sums (``operator = "direct"``: each process sums its share
    of the targets, the same conjugate gradients on each) within 2.5e-13 (reached
    2.9e-14); broke: every process summing the first process's rows: the run fails.
    The fast multipoles with the wall's images (``operator = "fmm"``: on the first
    process, broadcast) within 2.5e-13 (reached 6.7e-15)."""
    from running import assert_tables_agree
    from stokes_bodies import SWIMMING_SHEET

    method, _, operator = method.partition("-")
    chosen = f'model = "stokes"\nmethod = "{method}"'
    chosen += f'\noperator = "{operator}"' if operator else ""
    text = SWIMMING_SHEET.replace('model = "stokes"', chosen)
    text = text.replace("end = 0.15707963267948966", "end = 0.03926990816987242")
    text += (
        "[fluid.wall]\npoint = [0.0, 0.0, -1.6]\nnormal = [0.05, -0.03, 1.0]\n"
        "[output]\nfields = false\n"
    )
    scene = write_scene(tmp_path, text)
    one = cli_run(scene, tmp_path / "one")
    two = cli_run(scene, tmp_path / "two", np=2)
    header = (one / "body.csv").read_text().splitlines()[0].split(",")
    assert "wall_gap_blobs" in header and "fluid_Fx" in header
    assert_tables_agree(one, two, tolerance, f"{method} over a wall, two processes against one")


# --- magnetic couples -------------------------------------------------------------

MAGNET = """
title = "a half-magnetized free strip turning in Stokes flow"
[mesh]
length = 6.0
width = 1.0
divisions = [6, 1]
[[mesh.regions]]
name = "magnet"
x = [3.0, 6.0]
[shell]
thickness = 0.1
E = 1.0e3
nu = 0.3
density = 0.0
[time]
scheme = "backward-euler"
end = 0.5
dt = 0.1
[fluid]
model = "stokes"
viscosity = 1.0
[magnetic]
[[magnetic.parts]]
region = "magnet"
magnetization = 100.0
direction = [1.0, 0.0, 0.0]
[magnetic.field]
strength = 0.1
direction = [0.0, 0.3, 1.0]
ramp_time = 0.0
"""


def test_magnetic_couple_balances_the_fluid_moment(tmp_path):
    """A free strip magnetized along X on its half X ≥ 3, in a uniform field across it,
    without inertia: the field exerts the couple Q × b alone (Q = ∫ t m q J dA₀,
    body.csv's moment_*; b its field_*), so the liquid's moment is −Q × b, within
    5e-13 of |Q × b|, and its force 0, within 1.5e-13 (reached 4.1e-14 and 1.3e-14 on
    both stacks); the strip has turned (Q 0.066 rad off X).  Broke: the liquid's
    moment taken about the nodes' reference positions → 6.1e-3; the field's virtual
    work without the area change J (forms/magnetic.py) → 4.1e-4."""
    with _simulated(tmp_path, MAGNET) as sim:
        row = _last_row(sim)
    couple = np.cross(_vector(row, "moment_{}"), _vector(row, "field_{}"))
    F, M = _vector(row, "fluid_F{}"), _vector(row, "fluid_M{}")
    size = np.linalg.norm(couple)
    Q = _vector(row, "moment_{}")
    turned = math.atan2(np.linalg.norm(Q[1:]), Q[0])
    print(
        f"magnetic strip: |F|/|Q×b| {np.abs(F).max() / size:.2e}, "
        f"|M + Q×b|/|Q×b| {np.abs(M + couple).max() / size:.2e}, turned {turned:.3f} rad"
    )
    assert turned > 0.03
    assert np.abs(F).max() < 1.5e-13 * size
    assert np.abs(M + couple).max() < 5e-13 * size


# --- hinges -----------------------------------------------------------------------

HINGED = """
title = "a free two-link strip folding in Stokes flow"
[mesh]
length = 6.0
width = 1.0
divisions = [6, 2]
[shell]
thickness = 0.1
E = 1.0e6
nu = 0.3
density = 0.0
[[hinge]]
where = "x=3.0"
stiffness = 0.0
[time]
scheme = "backward-euler"
end = 1.0
dt = 0.2
[fluid]
model = "stokes"
viscosity = 1.0
[[load]]
kind = "point-force"
at = [5.0, 0.0, 0.0]
value = [1.0, -0.5, 5.0]
ramp = "constant"
"""


def _nearest(X, u, point):
    i = int(np.argmin(np.linalg.norm(X - point, axis=1)))
    assert np.linalg.norm(X[i] - point) < 1e-9
    return X[i] + u[i]


def test_free_hinge_in_stokes_flow(tmp_path):
    """A free strip of two stiff links joined by a free hinge at X = 3, pushed at a
    corner of the far link, without inertia: the liquid's resultant is −P within
    1.5e-13 of |P| and its moment −x × P (x the loaded point where it has moved)
    within 3e-12 (reached 1.3e-14 and 2.9e-13 on both stacks); the links fold (0.064
    rad between their chords; 0.0099 without the hinge), and a free hinge carries
    no moment about its line: the liquid's forces on the far link's nodes and the
    load have no moment about the hinge's axis (the line fitted through its moved
    nodes), within 1e-5 of the load's moment about it (reached 1.35e-6, the line's
    bow of 2.4e-4; 6.4e-2 without the hinge).  Broke: the liquid's moment taken
    about the nodes' reference positions → 7.8e-3; the hinge given stiffness = 0.5
    → 3.2e-3 about its axis."""
    with _simulated(tmp_path, HINGED) as sim:
        row = _last_row(sim)
        X = sim.model.Vu.tabulate_dof_coordinates()
        u = sim.model.u_n.x.array.reshape(-1, 3).copy()
        stokes = sim.model["stokes"]
        x, _, nodal = stokes._stored()  # the forces the body exerts on the liquid
    P, at = np.array([1.0, -0.5, 5.0]), np.array([5.0, 0.0, 0.0])
    moved = _nearest(X, u, at)
    F, M = _vector(row, "fluid_F{}"), _vector(row, "fluid_M{}")
    force = np.abs(F + P).max() / np.linalg.norm(P)
    moment = np.abs(M + np.cross(moved, P)).max() / np.linalg.norm(np.cross(at, P))
    a, h, b = (_nearest(X, u, [x, 0.5, 0.0]) for x in (1.0, 3.0, 5.0))
    fold = math.acos((h - a) @ (b - h) / np.linalg.norm(h - a) / np.linalg.norm(b - h))
    # the hinge's axis: the line fitted through its moved nodes (bowed by 2.4e-4)
    line = x[np.abs(stokes.X[:, 0] - 3.0) < 1e-9]
    centre = line.mean(axis=0)
    axis = np.linalg.svd(line - centre)[2][0]
    far = stokes.X[:, 0] > 3.0 - 1e-9
    about = axis @ (
        np.cross(x[far] - centre, -nodal[far]).sum(axis=0) + np.cross(moved - centre, P)
    )
    hinge = abs(about) / np.linalg.norm(np.cross(moved - centre, P))
    print(
        f"hinged strip: force {force:.2e}, moment {moment:.2e}, fold {fold:.4f} rad, "
        f"moment about the hinge {hinge:.2e}"
    )
    assert force < 1.5e-13 and moment < 3e-12
    assert fold > 0.03
    assert hinge < 1e-5


# --- HHT --------------------------------------------------------------------------

SINKING = """
title = "a stiff strip sinking from rest in Stokes flow"
[mesh]
length = 4.0
width = 1.0
divisions = [4, 1]
[shell]
thickness = 0.1
E = 1.0e10
nu = 0.3
density = {rho}
[time]
scheme = "hht"
alpha = -0.05
end = 0.2
dt = {dt}
[fluid]
model = "stokes"
viscosity = 1.0
[[load]]
kind = "gravity"
value = [0.0, 0.0, -1.0]
ramp = "constant"
"""

RHO = 5.0  # the mass m = ρ t L W = 2; the relaxation time m/R about 0.1


def test_hht_sinking_strip_follows_the_rigid_solution(tmp_path):
    """A flat strip, so stiff it stays flat, falls broadside from rest under its weight
    m g in Stokes flow (inertia, HHT α = −0.05): its centroid is the rigid body's
    z(t) = −U (t − τ (1 − e^(−t/τ))), U = m g/R, τ = m/R, R the strip's resistance
    to translation along Z (its resistance at rest, unchanged as it translates), and
    the liquid's force R U (1 − e^(−t/τ)).  At t = 0.2 (2 τ) with dt = 0.04 and 0.02:
    the errors of both fall with order 2 (within 1.8–2.2; reached 2.03 and 2.01 on
    both stacks) and are at most 1e-2 at dt = 0.02 (reached 1.0e-3 and 1.2e-3).
    Broke: the forces not weighted at the α point (``(1 − α_f) F + α_f F_n`` made
    ``F``, rftfem/integration/solver.py) → orders 1.18 and −0.06."""
    errors = []
    for dt in (0.04, 0.02):
        with _simulated(tmp_path, SINKING.format(rho=RHO, dt=dt)) as sim:
            row = _last_row(sim)
            stokes = sim.model["stokes"]
            # the force a unit translation along Z exerts on the liquid, at rest: R
            rigid = np.tile([0.0, 0.0, 1.0], len(stokes.X))
            R = stokes.resistance(stokes.X).solve(rigid).reshape(-1, 3)[:, 2].sum()
        mass = RHO * 0.1 * 4.0 * 1.0
        tau, U, t = mass / R, mass * 1.0 / R, sim.t
        assert t == pytest.approx(0.2, rel=1e-12)
        z = -U * (t - tau * (1 - math.exp(-t / tau)))
        force = R * U * (1 - math.exp(-t / tau))
        errors.append([row["centroid_z"] / z - 1, row["fluid_Fz"] / force - 1])
        print(
            f"HHT dt = {dt}: τ = {tau:.5f}, centroid {row['centroid_z']:.9g} against "
            f"{z:.9g}, force {row['fluid_Fz']:.9g} against {force:.9g}"
        )
    errors = np.abs(np.array(errors))
    orders = np.log2(errors[0] / errors[1])
    print(f"errors {errors.tolist()}, orders {orders}")
    assert (1.8 < orders).all() and (orders < 2.2).all()
    assert errors[1].max() < 1e-2
