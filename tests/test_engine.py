"""Engine behaviour: effect composition, long-run director norm, MPI invariance."""

import subprocess
import sys

import numpy as np
import pytest
from conftest import DEMOS, run_scene


def test_static_scene_compiles_no_inertia(tmp_path):
    """A static scene has exactly the effects it asks for: no inertia form exists."""
    sim = run_scene(
        DEMOS / "rollup.toml", "time.end=0.1", "load.0.value=[0, 5.0, 0]", out_dir=tmp_path
    )
    m = sim.model
    assert m.active_effects() == ["elasticity", "edge-moment"]
    assert m.inertia is None and m.inertia_form is None
    coefficients = set(m.jacobian_ufl.coefficients()) | set(m.forces_ufl.coefficients())
    assert m.a_n not in coefficients and m.v_n not in coefficients
    assert sim.summary["active_effects"] == ["elasticity", "edge-moment"]


def test_dynamic_scene_has_inertia(tmp_path):
    sim = run_scene(
        DEMOS / "rollup.toml",
        "shell.density=1e-9",
        "time.end=0.1",
        "load.0.value=[0, 5.0, 0]",
        "time.scheme=generalized-alpha",
        out_dir=tmp_path,
    )
    assert sim.model.active_effects() == ["elasticity", "inertia", "edge-moment"]
    assert sim.model.a_n in set(sim.model.jacobian_ufl.coefficients())


def test_check_prints_the_active_effects():
    out = subprocess.run(
        [sys.executable, "-m", "rftfem", "check", str(DEMOS / "end_shear.toml")],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert out.returncode == 0, out.stderr
    lines = [ln for ln in out.stdout.splitlines() if ln.startswith("active effects:")]
    assert lines == ["active effects: elasticity, edge-force"]


def test_director_stays_unit_after_1000_steps_of_a_spinning_end(tmp_path):
    """Two full turns of the free end in 1000 load steps: | |d| − 1 | < 1e-10 at every node."""
    sim = run_scene(DEMOS / "rollup.toml", "time.dt=0.002", "output.fields=false", out_dir=tmp_path)
    c = sim.summary["counts"]
    print(
        f"{c['steps']} steps, {c['newton_iterations']} Newton iterations; "
        f"max | |d| - 1 | = {sim.summary['director_unit_error']:.2e}"
    )
    assert c["steps"] == 1000 and c["dt_cuts"] == 0
    assert sim.summary["director_unit_error"] < 1e-10


def _largest_frame_angle(model) -> float:
    """The largest angle (degrees) between the a₁ of two nodes of one cell, each
    a₁ taken into the other node's tangent plane."""
    from rftfem import compat

    a1 = model.triads[0][0].x.array.reshape(-1, 3)
    dn = model.dn.x.array.reshape(-1, 3)
    worst = 0.0
    for nodes in compat.cell_dofs(model.Vu):
        for i in nodes:
            v = a1[nodes] - (a1[nodes] @ dn[i])[:, None] * dn[i]
            v /= np.linalg.norm(v, axis=1)[:, None]
            worst = max(worst, float(np.degrees(np.arccos(np.clip(v @ a1[i], -1, 1))).max()))
    return worst


def test_triad_update_realigns_drifted_frames(tmp_path):
    """After the Rodrigues rotation, update_triad turns (a₁, a₂) about dₙ onto the
    convected material axis (docs/model.md §4.4).  In-plane frames scrambled about
    dₙ, as a long spin leaves them (up to 180° apart within one cell), come back
    smooth and equal to the frames of the run, along the rolled strip's tangent;
    dₙ and the state (the force vector at θ = 0) are unchanged."""
    from rftfem.integration.simulation import Simulation
    from rftfem.model.triad import rotate
    from rftfem.scene.reading import load_scene

    scene = load_scene(DEMOS / "rollup.toml", ["time.end=0.5", "output.fields=false"])
    sim = Simulation(scene, quiet=True)
    try:
        sim.run()
        m = sim.model
        a1_run, dn_run = m.triads[0][0].x.array.copy(), m.dn.x.array.copy()
        forces = sim.solver.F_n.duplicate()
        sim.solver.assemble_forces(forces)
        before = forces.getArray().copy()
        smooth = _largest_frame_angle(m)

        dn = dn_run.reshape(-1, 3)
        spin = np.random.default_rng(4).uniform(-np.pi, np.pi, len(dn))[:, None] * dn
        for f in (m.triads[0][0], m.triads[0][1]):
            f.x.array[:] = rotate(f.x.array.reshape(-1, 3), spin).ravel()
        scrambled = _largest_frame_angle(m)
        m.update_triad()  # θ = 0: no rotation, only the realignment
        realigned = _largest_frame_angle(m)
        sim.solver.assemble_forces(forces)
        after = forces.getArray()
        print(
            f"largest a1 angle within a cell: run {smooth:.2e}°, scrambled {scrambled:.1f}°, "
            f"realigned {realigned:.2e}°; force change {np.abs(after - before).max():.1e}"
        )
        assert scrambled > 90 and smooth < 1 and realigned < 1
        assert np.array_equal(m.dn.x.array, dn_run)
        assert np.abs(m.triads[0][0].x.array - a1_run).max() < 1e-10
        a1, a2 = m.triads[0][0].x.array.reshape(-1, 3), m.triads[0][1].x.array.reshape(-1, 3)
        assert np.abs(np.sum(a1 * dn, axis=1)).max() < 1e-12
        assert np.abs(a2 - np.cross(dn, a1)).max() < 1e-12
        # the strip rolls about Y: the convected axis X stays in the XZ plane, so
        # a₁ is the tangent Y × dₙ (not merely some smooth in-plane direction)
        assert np.abs(a1 - np.cross([0.0, 1.0, 0.0], dn)).max() < 1e-8
        assert np.abs(after - before).max() <= 1e-12 * np.abs(before).max()
    finally:
        sim.close()


@pytest.mark.mpi
def test_two_processes_reproduce_the_serial_probe_history(tmp_path, cli_run):
    """Roll-up, 10 steps: `mpirun -n 2` gives the serial probes to 1e-8 relative."""
    sets = ["time.end=0.5", "output.fields=false"]
    cli_run(DEMOS / "rollup.toml", tmp_path / "serial", sets)
    cli_run(DEMOS / "rollup.toml", tmp_path / "mpi", sets, np=2)
    a = np.loadtxt(tmp_path / "serial" / "probes.csv", delimiter=",", skiprows=1)
    b = np.loadtxt(tmp_path / "mpi" / "probes.csv", delimiter=",", skiprows=1)
    assert a.shape == b.shape == (11, 5)  # time, the tip, the load factor
    rel = np.abs(a - b).max() / np.abs(a).max()
    print(f"serial vs 2 processes: max relative difference {rel:.2e}")
    assert rel < 1e-8
    import json

    assert json.loads((tmp_path / "mpi" / "summary.json").read_text())["mpi_size"] == 2
