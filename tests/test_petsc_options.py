"""Solver options reach PETSc's SNES in the documented order (docs/model.md §7.3):
rftfem's defaults, then the scene's ``[solver]``, then the command line; and the
absolute tolerance is 1e-7 of the scene's driving force."""

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


@pytest.mark.parametrize("scale", [1.0, 1e-6])
def test_atol_is_scaled_by_the_driving_force(scale):
    """The roll-up's driving force is its end moment over the length, |M| / L:
    atol = 1e-7 |M| / L, at the demo's moment (above the bending force D W / L²)
    and at a millionth of it (far below: a tolerance in bending-force units would
    accept any state the moment had not yet moved). No relative tolerance."""
    (rtol, atol, stol, max_it), scene = _tolerances(
        f"load.0.value=[0.0, {scale * 104.71975511965977!r}, 0.0]")
    shell, mesh = scene["shell"], scene["mesh"]
    moment = abs(scene["load"][0]["value"][1]) / mesh["length"]
    bending = (shell["E"] * shell["thickness"]**3 / (12 * (1 - shell["nu"]**2))
               * mesh["width"] / mesh["length"]**2)
    assert (moment > bending) == (scale == 1.0)
    assert atol == pytest.approx(1e-7 * moment, rel=1e-12)
    assert (rtol, stol, max_it) == (0.0, 1e-10, 25)


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


def test_negative_values_on_the_command_line_are_values():
    """`-snes_lag_preconditioner -2` is an option and its value (a number starting
    with a minus was once read as a second option, silently dropping the value)."""
    from rftfem.petsc_options import parse_command_line

    assert parse_command_line(["-snes_lag_preconditioner", "-2", "-snes_monitor",
                               "-rftfem_mat_mumps_cntl_1", "-1e-3", "-ksp_view"]) == {
        "snes_lag_preconditioner": "-2", "snes_monitor": "", "mat_mumps_cntl_1": "-1e-3",
        "ksp_view": ""}
