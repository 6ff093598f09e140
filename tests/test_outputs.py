"""What a run writes agrees with itself and with the run (docs/scenes.md "Outputs").

One coarse roll-up (two full turns in 40 load steps) is run once; then:

- steps.csv has a row per accepted step whose Newton iterations add up to the
  summary's count, and its last time is the time reached;
- summary.json has every documented entry, the scene as loaded and the active
  effects of ``rftfem check``;
- probes.csv and body.csv have a row per output time;
- fields.xdmf, read back with VTK's XDMF reader in a child process (dolfinx 0.5
  and VTK cannot share one), holds at the tip's vertex the displacement that
  probes.csv has at every output time, and unit directors.
"""

from __future__ import annotations

import json
import tomllib

import numpy as np
import pytest
from conftest import DEMOS, fields_at, run_scene

TIP = np.array(tomllib.loads((DEMOS / "rollup.toml").read_text())["output"]["probes"][0]["at"])


@pytest.fixture(scope="module")
def rollup(tmp_path_factory):
    out = tmp_path_factory.mktemp("outputs") / "rollup"
    sim = run_scene(
        DEMOS / "rollup.toml", "mesh.divisions=[16,2]", "time.output_every=2", out_dir=out
    )
    return sim, out


def _csv(path):
    return np.genfromtxt(path, delimiter=",", names=True)


def test_steps_and_summary_agree_with_the_run(rollup):
    sim, out = rollup
    summary = json.loads((out / "summary.json").read_text())
    steps = _csv(out / "steps.csv")
    for key in (
        "status",
        "scene",
        "scene_file",
        "overrides",
        "active_effects",
        "scheme",
        "versions",
        "mpi_size",
        "dofs",
        "time_reached",
        "counts",
        "director_unit_error",
        "wall_s",
    ):
        assert key in summary, key
    assert summary["status"] == "ok" and summary["time_reached"] == sim.scene["time"]["end"]
    assert summary["active_effects"] == ["elasticity", "edge-moment"]
    assert summary["scene"]["mesh"]["divisions"] == [16, 2]
    assert summary["overrides"] == ["mesh.divisions=[16,2]", "time.output_every=2"]
    counts = summary["counts"]
    assert len(steps) == counts["steps"] == 40  # no cuts: one row per load step
    assert int(steps["newton_its"].sum()) == counts["newton_iterations"]
    assert steps["time"][-1] == pytest.approx(summary["time_reached"], abs=1e-12)
    assert np.all(np.diff(steps["time"]) > 0) and np.all(steps["dt"] > 0)
    wall = summary["wall_s"]
    assert set(wall) == {"setup", "compile", "assembly", "solve", "output", "checkpoint", "total"}
    assert wall["total"] >= wall["solve"] >= 0
    assert wall["total"] >= wall["setup"] >= wall["compile"] >= 0


def test_probes_and_body_rows_at_every_output_time(rollup):
    sim, out = rollup
    probes, body = _csv(out / "probes.csv"), _csv(out / "body.csv")
    times = np.arange(0, 41, 2) * 0.05
    assert np.allclose(probes["time"], times, atol=1e-12)
    assert np.allclose(body["time"], times, atol=1e-12)
    last = sim.history[-1][1][0]
    assert np.allclose(
        [probes["tip_ux"][-1], probes["tip_uy"][-1], probes["tip_uz"][-1]], last, rtol=0, atol=1e-15
    )


def test_fields_file_holds_what_the_probes_saw(rollup):
    """At the tip's vertex the written displacement equals the probe's (the fields are
    written at the P2 dofs, so it is the dof value), at every output time, to double
    precision (reached: round-off): the file declares its real arrays as 8-byte
    floats, which dolfinx leaves out and without which VTK's XDMF reader (ParaView's
    too) reads them as float32 (an error of 1e-8 then)."""
    _, out = rollup
    distance, rows = fields_at(out, TIP)
    assert distance < 1e-9  # the probe sits on a vertex (gmsh places it to 1.3e-12)
    probes = np.loadtxt(out / "probes.csv", delimiter=",", skiprows=1)
    assert rows.shape[0] == probes.shape[0]
    assert np.allclose(rows[:, 0], probes[:, 0], atol=1e-12)
    scale = np.abs(probes[:, 1:4]).max()
    error = np.abs(rows[:, 1:4] - probes[:, 1:4]).max() / scale
    print(
        f"fields vs probes at the tip: {error:.1e} of the largest displacement; "
        f"largest | |d| - 1 | at a vertex {rows[:, 4].max():.1e}"
    )
    assert error < 1e-12
    assert rows[:, 4].max() < 1e-12
