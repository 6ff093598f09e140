"""When the tangent is factorised (``solver.factorization``, docs/model.md §7.7).

"every-iteration" factorises every Newton tangent and solves directly; "every-step"
factorises a step's first tangent and solves the others by GMRES preconditioned
with its factors; "reused" keeps the factors across steps until GMRES needs more
than 20 iterations or fails.  Every policy must reach the same states (GMRES to
1e-10), and the kept factors must be renewed where the body's stiffness has
changed: the roll-up turns its strip through two full circles, so factors of the
flat strip stop working on the way.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import DEMOS, run_scene

ROLLUP = ("mesh.divisions=[8,1]", "time.dt=0.1")


def _rollup(policy: str, *extra, petsc_args=()):
    sim = run_scene(
        DEMOS / "rollup.toml",
        *ROLLUP,
        f'solver.factorization="{policy}"',
        *extra,
        petsc_args=list(petsc_args),
    )
    tips = np.array([row[1][0] for row in sim.history])
    return sim, tips


@pytest.fixture(scope="module")
def direct():
    return _rollup("every-iteration")


def test_every_policy_reaches_the_same_rollup(direct):
    """Tips equal to 1e-7 of the length along the two turns.  The roll-up's tangent
    changes between Newton iterates (static load steps of a turning strip), so "reused"
    ends up factorising nearly every tangent; it must get there without a cut step."""
    sim_d, tips_d = direct
    assert sim_d.summary["factorization"] == {
        "policy": "every-iteration",
        "lu": "petsc",
        "made": sim_d.solver.calls["jacobian"],
    }
    for policy in ("every-step", "reused"):
        sim, tips = _rollup(policy)
        assert np.abs(tips - tips_d).max() < 1e-7 * 12.0, policy
        assert sim.summary["factorization"]["policy"] == policy
        assert sim.counts["dt_cuts"] == 0
        assert sim.summary["factorization"]["made"] >= sim.counts["steps"] + 1  # t = 0 too


def test_reused_factors_serve_a_whole_sheet_run():
    """The swimming sheet (small mesh, 24 steps of its wave): a few factorisations
    serve the run (measured: 5 for 58 tangents; the shipped mesh, 1 for 108); the
    probes equal a run of direct solves to 1e-9 of their size."""
    runs = {}
    for policy in ("every-iteration", "reused"):
        sim = run_scene(
            DEMOS / "swimming_sheet.toml",
            "mesh.divisions=[10,2]",
            'time.until="end"',
            "time.end=0.0471238898038469",
            "output.fields=false",
            f'solver.factorization="{policy}"',
        )
        runs[policy] = (sim, np.array([row[1] for row in sim.history]))
    (sim_d, rows_d), (sim_r, rows_r) = runs["every-iteration"], runs["reused"]
    assert sim_r.counts["steps"] == sim_d.counts["steps"] == 24
    assert np.abs(rows_r - rows_d).max() < 1e-9 * np.abs(rows_d).max()
    assert sim_r.summary["factorization"]["made"] <= sim_r.solver.calls["jacobian"] / 8
    # (every tangent of a Newton iteration; the t = 0 state's tangent is not one)
    assert sim_d.summary["factorization"]["made"] >= sim_d.solver.calls["jacobian"] - 1


def test_a_failed_krylov_solve_is_made_again_with_new_factors(direct):
    """With GMRES limited to 3 iterations the stale factors fail as soon as the strip
    has turned; the solve is then made again from its start with the tangent's own
    factors (one iteration suffices), not given up: no load step is cut, and the tips
    are those of direct solves."""
    sim_d, tips_d = direct
    sim, tips = _rollup("reused", "solver.ksp_max_it=3")
    assert sim.counts["dt_cuts"] == 0
    assert np.abs(tips - tips_d).max() < 1e-7 * 12.0
    assert sim.summary["factorization"]["made"] > 1


def test_auto_keeps_the_factors_only_on_large_meshes():
    from rftfem.petsc_options import REUSE_ABOVE, factorization

    assert factorization({}, [], REUSE_ABOVE) == "every-iteration"
    assert factorization({}, [], REUSE_ABOVE + 1) == "reused"
    assert factorization({"factorization": "every-step"}, [], 10**6) == "every-step"
    assert (
        factorization({"factorization": "every-step"}, ["-factorization", "reused"], 10) == "reused"
    )


@pytest.mark.parametrize("where", ["scene", "command line"])
def test_an_unknown_policy_is_one_line(where):
    from rftfem.errors import SceneError
    from rftfem.petsc_options import factorization
    from rftfem.scene.reading import load_scene

    with pytest.raises(SceneError) as err:
        if where == "scene":
            load_scene(DEMOS / "rollup.toml", ['solver.factorization="sometimes"'])
        else:
            factorization({}, ["-factorization", "sometimes"])
    text = str(err.value)
    assert "\n" not in text and "factorization" in text and "'reused'" in text


def test_small_serial_runs_use_petscs_lu_and_fall_back_on_mumps(direct):
    """The roll-up (small, serial) is factorised by PETSc's own LU.  Told to count
    every pivot as zero (`pc_factor_zeropivot 1e300`, which only the point-wise
    matrix's LU reads: the block matrix's pivots within its 5 × 5 blocks), that LU
    fails at the first solve; the solve is made again with MUMPS, which the run
    keeps: no load step is cut and the tips are the same.  A package the scene
    names is kept."""
    from rftfem import compat

    sim_d, tips_d = direct
    assert sim_d.summary["factorization"]["lu"] == "petsc"
    if not compat.has_mumps():
        pytest.skip("this PETSc has no MUMPS to fall back on")
    sim = run_scene(
        DEMOS / "rollup.toml", *ROLLUP, "solver.pc_factor_zeropivot=1e300", 'solver.mat_type="aij"'
    )
    tips = np.array([row[1][0] for row in sim.history])
    assert sim.summary["status"] == "ok" and sim.counts["dt_cuts"] == 0
    assert sim.summary["factorization"]["lu"] == "mumps"
    assert np.abs(tips - tips_d).max() < 1e-7 * 12.0
    sim = run_scene(
        DEMOS / "rollup.toml", *ROLLUP, 'solver.pc_factor_mat_solver_type="mumps"', "time.end=0.2"
    )
    assert sim.summary["factorization"]["lu"] == "mumps"


def test_the_tangent_is_a_block_matrix_unless_asked(direct):
    """The tangent holds a (u, θ) block per node pair (rftfem/model/shell_model.py); ``mat_type =
    "aij"`` gives a point-wise one (for preconditioners that take no blocks) with the
    same tips to round-off.  Any other type is one line naming the key."""
    from rftfem.errors import SceneError
    from rftfem.scene.reading import load_scene

    def matrix_of(seen):
        return lambda sim: seen.add((sim.solver.A.getType(), sim.solver.A.getBlockSize()))

    _, tips_d = direct
    seen = set()
    run_scene(DEMOS / "rollup.toml", *ROLLUP, "time.end=0.2", observers=[matrix_of(seen)])
    assert seen == {("seqbaij", 5)}
    seen = set()
    sim = run_scene(
        DEMOS / "rollup.toml", *ROLLUP, 'solver.mat_type="aij"', observers=[matrix_of(seen)]
    )
    tips = np.array([row[1][0] for row in sim.history])
    assert seen == {("seqaij", 5)}
    assert np.abs(tips - tips_d).max() < 1e-7 * 12.0
    with pytest.raises(SceneError) as err:
        load_scene(DEMOS / "rollup.toml", ['solver.mat_type="dense"'])
    text = str(err.value)
    assert "\n" not in text and "solver.mat_type" in text and "'aij'" in text
