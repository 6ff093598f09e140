"""Solver options reach PETSc's SNES in the documented order (docs/model.md §7.3):
rftfem's defaults, then the scene's ``[solver]``, then the command line; and the
absolute tolerance is 1e-10 of the scene's reference force."""

from __future__ import annotations

import pytest

from conftest import DEMOS


def _tolerances(*overrides, petsc_args=()):
    """(rtol, atol, stol, max_it) of the SNES a Simulation of the roll-up builds."""
    from rftfem.scene import load_scene
    from rftfem.simulation import Simulation

    scene = load_scene(DEMOS / "rollup.toml", ["mesh.divisions=[4,1]", *overrides])
    sim = Simulation(scene, quiet=True, petsc_args=list(petsc_args))
    try:
        return sim.solver.snes.getTolerances(), scene
    finally:
        sim.close()


def test_atol_is_scaled_by_the_reference_force():
    """The roll-up's largest force scale is its end moment over the length,
    |M| / L (the bending force D W / L² is smaller): atol = 1e-10 |M| / L."""
    (rtol, atol, stol, max_it), scene = _tolerances()
    shell, mesh = scene["shell"], scene["mesh"]
    moment = abs(scene["load"][0]["value"][1]) / mesh["length"]
    bending = (shell["E"] * shell["thickness"]**3 / (12 * (1 - shell["nu"]**2))
               * mesh["width"] / mesh["length"]**2)
    assert moment > bending
    assert atol == pytest.approx(1e-10 * moment, rel=1e-12)
    assert (rtol, stol, max_it) == (1e-8, 1e-10, 25)


def test_scene_replaces_defaults_and_command_line_replaces_scene():
    """[solver] snes_max_it = 7 beats the default 25; -snes_max_it 9 beats the scene;
    snes_stol = false removes rftfem's 1e-10, leaving PETSc's own 1e-8."""
    (_, _, _, max_it), _ = _tolerances("solver.snes_max_it=7")
    assert max_it == 7
    (_, _, _, max_it), _ = _tolerances("solver.snes_max_it=7",
                                       petsc_args=["-snes_max_it", "9"])
    assert max_it == 9
    (_, _, stol, _), _ = _tolerances("solver.snes_stol=false")
    assert stol == pytest.approx(1e-8)
