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
    scene = write_scene(
        tmp_path,
        BASE
        + """
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
""",
    )
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
    """A wave ``s(t) b sin(k (X − X₀) + ω t + φ)`` on a region's nodes, in-plane component
    ux, ramped in over 0.8 (s = (1 − cos(π t / 0.8)) / 2, then 1)."""
    b, k, w, x0, phi, tau = 0.01, 1.3, 2.0, 0.5, 0.4, 0.8
    scene = write_scene(
        tmp_path,
        BASE
        + f"""
[[motion]]
where = "band"
component = "ux"
amplitude = {b}
wavenumber = {k}
angular_frequency = {w}
origin = {x0}
phase = {phi}
ramp_time = {tau}
"""
        + "".join(
            f"""
[[output.probes]]
name = "p{i}"
at = [{x}, 0.0, 0.0]
"""
            for i, x in enumerate((1.0, 1.5, 2.0))
        ),
    )
    sim = run_scene(scene, out_dir=tmp_path / "out")
    for i, x in enumerate((1.0, 1.5, 2.0)):
        times = np.array([0.0, 0.5, 1.0])
        ux = rows_at(sim, times, probe=i)[:, 0]
        ramp = np.where(times < tau, (1 - np.cos(np.pi * times / tau)) / 2, 1.0)
        assert np.allclose(ux, ramp * b * np.sin(k * (x - x0) + w * times + phi), atol=1e-12)


def test_a_waves_rates_are_its_derivatives():
    """The velocity and acceleration a second-order scheme imposes on driven dofs
    (Motion.rates) are the time derivatives of the prescribed value (Motion.at): central
    differences of ``at`` agree to 1e-7, inside the ramp, at its end and after it."""
    from rftfem.model.effects.motion import Motion

    spec = {
        "kind": "travelling-wave",
        "amplitude": 0.3,
        "wavenumber": 0.7,
        "angular_frequency": 5.0,
        "origin": 0.2,
        "phase": 1.1,
        "ramp_time": 0.5,
    }
    X = np.linspace(0.0, 3.0, 7)
    motion = Motion(spec, None, None, X, None)
    h = 1e-4
    for t in (0.05, 0.3, 0.499, 0.7, 2.0):
        v, a = motion.rates(t, side=-1)
        before, now, after = (motion.at(t + d, X) for d in (-h, 0.0, h))
        assert np.allclose(v, (after - before) / (2 * h), atol=1e-7 * 0.3 * 5.0)
        assert np.allclose(a, (after - 2 * now + before) / h**2, atol=1e-5 * 0.3 * 25.0)
