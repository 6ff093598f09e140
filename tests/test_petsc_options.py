"""Solver options reach PETSc's SNES in the documented order (docs/model.md §7.3):
rftfem's defaults, then the scene's ``[solver]``, then the command line; and the
absolute tolerance is 1e-7 of the scene's driving force."""

from __future__ import annotations

import pytest
from conftest import DEMOS


def _tolerances(*overrides, petsc_args=()):
    """(rtol, atol, stol, max_it) of the SNES a Simulation of the roll-up builds."""
    from rftfem.integration.simulation import Simulation
    from rftfem.scene.reading import load_scene

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
        f"load.0.value=[0.0, {scale * 104.71975511965977!r}, 0.0]"
    )
    shell, mesh = scene["shell"], scene["mesh"]
    moment = abs(scene["load"][0]["value"][1]) / mesh["length"]
    bending = (
        shell["E"]
        * shell["thickness"] ** 3
        / (12 * (1 - shell["nu"] ** 2))
        * mesh["width"]
        / mesh["length"] ** 2
    )
    assert (moment > bending) == (scale == 1.0)
    assert atol == pytest.approx(1e-7 * moment, rel=1e-12)
    assert (rtol, stol, max_it) == (0.0, 1e-10, 25)


def test_scene_replaces_defaults_and_command_line_replaces_scene():
    """[solver] snes_max_it = 7 beats the default 25; -snes_max_it 9 beats the scene;
    snes_stol = false removes rftfem's 1e-10, leaving PETSc's own 1e-8."""
    (_, _, _, max_it), _ = _tolerances("solver.snes_max_it=7")
    assert max_it == 7
    (_, _, _, max_it), _ = _tolerances("solver.snes_max_it=7", petsc_args=["-snes_max_it", "9"])
    assert max_it == 9
    (_, _, stol, _), _ = _tolerances("solver.snes_stol=false")
    assert stol == pytest.approx(1e-8)


def test_negative_values_on_the_command_line_are_values():
    """`-snes_lag_preconditioner -2` is an option and its value (a number starting
    with a minus was once read as a second option, silently dropping the value)."""
    from rftfem.petsc_options import parse_command_line

    assert parse_command_line(
        [
            "-snes_lag_preconditioner",
            "-2",
            "-snes_monitor",
            "-rftfem_mat_mumps_cntl_1",
            "-1e-3",
            "-ksp_view",
        ]
    ) == {
        "snes_lag_preconditioner": "-2",
        "snes_monitor": "",
        "mat_mumps_cntl_1": "-1e-3",
        "ksp_view": "",
    }


def _saddle_point(n: int = 400, delta: float = 1e-12, seed: int = 0):
    """[[δ I, B], [Bᵀ, 0]] with a banded, diagonally dominant B (so regular): LU
    must pivot off the near-zero diagonal, which makes more fill than MUMPS's
    analysis foresees."""
    import numpy as np
    from petsc4py import PETSc

    rng = np.random.default_rng(seed)
    A = PETSc.Mat().createAIJ([2 * n, 2 * n], nnz=12, comm=PETSc.COMM_SELF)
    for i in range(n):
        A[i, i] = delta
        for k in (-2, -1, 0, 1, 2):
            v = 4.0 + rng.uniform() if k == 0 else rng.uniform(-1, 1)
            A[i, n + (i + k) % n] = v
            A[n + (i + k) % n, i] = v
    A.assemble()
    return A


def test_mumps_workspace_grows_after_a_workspace_error():
    """A factorisation that outgrows MUMPS's estimated workspace (INFOG(1) = −9; the
    Debian stack's MUMPS on this saddle point at 20, 40 and 80 % extra) is repeated
    with twice the extra workspace until it fits (160 %), and the solution is then
    exact; a solve that did not fail leaves the option alone (the current stack's
    MUMPS factors it at the default)."""
    from petsc4py import PETSc

    from rftfem import compat, petsc_options

    if not compat.has_mumps():
        pytest.skip("this PETSc has no MUMPS")
    A = _saddle_point()
    opts = {"ksp_type": "preonly", "pc_type": "lu", "pc_factor_mat_solver_type": "mumps"}
    prefix = "workspace_test_"
    petsc_options.apply(opts, prefix)
    ksp = PETSc.KSP().create(PETSc.COMM_SELF)
    ksp.setOptionsPrefix(prefix)
    ksp.setOperators(A)
    ksp.setFromOptions()
    b = A.createVecLeft()
    b.set(1.0)
    x = b.duplicate()
    tried = []
    try:
        for _ in range(8):
            ksp.setOperators(A)  # as SNES does before every solve (a reset drops them)
            ksp.solve(b, x)
            info = ksp.getPC().getFactorMatrix().getMumpsInfog(1)
            tried.append((opts.get("mat_mumps_icntl_14", 20), ksp.getConvergedReason(), info))
            if ksp.getConvergedReason() > 0:
                break
            assert info in petsc_options.MUMPS_WORKSPACE_ERRORS, tried
            assert petsc_options.grow_factor_workspace(ksp, opts, prefix), tried
        print(f"(ICNTL(14), KSP reason, INFOG(1)) per attempt: {tried}")
        assert ksp.getConvergedReason() > 0, tried
        r = A.createVecLeft()
        A.mult(x, r)
        r.axpy(-1.0, b)
        assert r.norm() < 1e-10 * b.norm(), r.norm()
        if len(tried) == 1:  # nothing failed: nothing to grow
            assert not petsc_options.grow_factor_workspace(ksp, opts, prefix)
            assert "mat_mumps_icntl_14" not in opts
        else:
            assert [t[0] for t in tried] == [20 * 2**k for k in range(len(tried))]
    finally:
        petsc_options.clear(opts, prefix)
        ksp.destroy()
        A.destroy()
