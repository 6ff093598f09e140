"""Prescribed motion (docs/scenes.md [[motion]]): values reach the selected dofs at every
step, on edges and regions, for tables and travelling waves, any component."""

from __future__ import annotations

import numpy as np

from conftest import rows_at, run_scene, write_scene

BASE = """
title = "prescribed motion"
[mesh]
length = 4.0
width = 1.0
divisions = [8, 1]
[[mesh.regions]]
name = "band"
x = [1.0, 2.0]
[shell]
thickness = 0.1
E = 1.0e4
nu = 0.3
[time]
scheme = "static"
end = 1.0
dt = 0.25
[[boundary]]
where = "x=0"
fix = ["clamped"]
"""


def test_table_motion_on_an_edge(tmp_path):
    """uy and uz of the end x = L follow their tables (piecewise linear, out of and in
    plane); the rest of the cantilever follows elastically.  The in-plane motion is
    kept small: its membrane stresses stiffen this thin strip's bending noticeably
    (at 0.1 the mid-span deflection ratio drops from 0.31 to 0.26)."""
    scene = write_scene(tmp_path, BASE + """
[[motion]]
where = "x=L"
component = "uz"
kind = "table"
values = [[0.0, 0.0], [0.5, 0.4], [1.0, -0.2]]
[[motion]]
where = "x=L"
component = "uy"
kind = "table"
values = [[0.0, 0.0], [1.0, 0.001]]
[[output.probes]]
name = "tip"
at = [4.0, 0.5, 0.0]
[[output.probes]]
name = "middle"
at = [2.0, 0.5, 0.0]
""")
    sim = run_scene(scene, out_dir=tmp_path / "out")
    times = [0.25, 0.5, 0.75, 1.0]
    tip = rows_at(sim, times, probe=0)
    assert np.allclose(tip[:, 2], np.interp(times, [0, 0.5, 1.0], [0, 0.4, -0.2]), atol=1e-12)
    assert np.allclose(tip[:, 1], np.interp(times, [0, 1.0], [0, 0.001]), atol=1e-12)
    middle = rows_at(sim, times, probe=1)
    # a cantilever with an imposed end deflection w_L: w(L/2) = (5/16) w_L (beam theory)
    assert np.allclose(middle[:, 2], 5 / 16 * tip[:, 2], rtol=0.02)
    assert sim.summary["active_effects"] == ["elasticity", "prescribed-motion"]


def test_travelling_wave_on_a_region(tmp_path):
    """A wave ``b sin(k (X − X₀) + ω t + φ)`` on a region's nodes, in-plane component ux."""
    b, k, w, x0, phi = 0.01, 1.3, 2.0, 0.5, 0.4
    scene = write_scene(tmp_path, BASE + f"""
[[motion]]
where = "band"
component = "ux"
amplitude = {b}
wavenumber = {k}
angular_frequency = {w}
origin = {x0}
phase = {phi}
""" + "".join(f"""
[[output.probes]]
name = "p{i}"
at = [{x}, 0.0, 0.0]
""" for i, x in enumerate((1.0, 1.5, 2.0))))
    sim = run_scene(scene, out_dir=tmp_path / "out")
    for i, x in enumerate((1.0, 1.5, 2.0)):
        times = np.array([0.0, 0.5, 1.0])
        ux = rows_at(sim, times, probe=i)[:, 0]
        assert np.allclose(ux, b * np.sin(k * (x - x0) + w * times + phi), atol=1e-12)
