"""Published shell benchmarks, run through scenes (docs/verification.md cases A, B, C, E
and the twist).

Each test prints the figure it reached, so `pytest -s` (or -rA) shows the margin.
"""

import numpy as np
import pytest
from conftest import DEMOS, rows_at, run_scene

# --- A. Cantilever under end shear (Sze, Liu & Lo 2004, 3.1) -----------------

SZE_SHEAR = {  # P/Pmax: (-u, w)
    0.10: (0.103, 1.309),
    0.25: (0.563, 3.015),
    0.50: (1.604, 4.933),
    0.75: (2.541, 6.031),
    1.00: (3.286, 6.698),
}


def test_end_shear_matches_sze_at_every_row(tmp_path):
    """Tolerance: 1 % of w at every row, and 1 % of −u or 0.001 (the table's last
    digit), whichever is larger; 16x1 quadrilaterals (docs/verification.md case A)."""
    sim = run_scene(DEMOS / "end_shear.toml", out_dir=tmp_path)
    loads = sorted(SZE_SHEAR)
    tip = rows_at(sim, loads)
    for p, (ux, _, uz) in zip(loads, tip):
        ref_u, ref_w = SZE_SHEAR[p]
        err = abs(uz - ref_w) / ref_w
        print(
            f"P/Pmax = {p:4.2f}: -u = {-ux:.4f} ({ref_u}), w = {uz:.4f} ({ref_w}), "
            f"w error {100 * err:.3f} %"
        )
        assert err < 0.01, f"P/Pmax = {p}: w = {uz:.4f}, reference {ref_w}"
        assert abs(-ux - ref_u) <= max(0.01 * ref_u, 1e-3), (
            f"P/Pmax = {p}: -u = {-ux:.4f}, reference {ref_u}"
        )
    assert sim.summary["counts"]["dt_cuts"] == 0


# --- B. Roll-up by an end moment (Sze 3.2; exact) ----------------------------


def rollup_tip(fraction, L=12.0):
    """Exact tip displacement (u, w) when M = fraction * Mmax (moment about +Y)."""
    theta = 2 * np.pi * fraction
    return np.array([L / theta * np.sin(theta) - L, -(L / theta) * (1 - np.cos(theta))])


def _rollup_errors(sim, fractions):
    errors = []
    for f, (ux, _, uz) in zip(fractions, rows_at(sim, fractions)):  # demo: M/Mmax = t
        errors.append(np.hypot(*(np.array([ux, uz]) - rollup_tip(f))) / 12.0)
        print(f"M/Mmax = {f}: tip error {100 * errors[-1]:.3f} % of L")
    return errors


def test_rollup_tip_on_the_exact_circle(tmp_path):
    """Tip within 0.5 % of L at M/Mmax = 0.25, 0.5, 0.75, 1 (demo mesh, 16x1 quadrilaterals;
    reached 0.18 %); the demo goes on to two full turns (2 Mmax), which must converge."""
    sim = run_scene(DEMOS / "rollup.toml", out_dir=tmp_path)
    errors = _rollup_errors(sim, [0.25, 0.5, 0.75, 1.0, 2.0])
    assert max(errors[:4]) < 0.005
    assert sim.t == pytest.approx(2.0) and sim.summary["status"] == "ok"
    assert sim.summary["counts"]["dt_cuts"] == 0
    assert sim.summary["director_unit_error"] < 1e-12


def test_rollup_two_full_turns_on_a_finer_mesh(tmp_path):
    """At 2 Mmax the 16x1 mesh is at 1.16 % of L (its cells subtend 0.79 rad each, and
    the normalised interpolation of the nodal directors, exact on rigid motions, is
    not exact on a circle: 0.75 % with the interpolated rotation vectors before);
    32x1 must be within 0.5 % (reached 0.073 %, 0.103 % before)."""
    sim = run_scene(DEMOS / "rollup.toml", "mesh.divisions=[32, 1]", out_dir=tmp_path)
    assert _rollup_errors(sim, [2.0])[0] < 0.005


# --- C. Elastica (exact), tip load ----------------------------------------------

ELASTICA = {
    1: (0.30172, 0.05643),
    2: (0.49346, 0.16064),
    5: (0.71379, 0.38763),
    10: (0.81061, 0.55500),
}


def test_elastica_tip_load(tmp_path):
    """(w/L, 1 - x/L) within 0.15 % for PL²/EI = 1, 2, 5, 10 (EI = 100, L = 10: P = PL²/EI),
    32x1 quadrilaterals; reached ≤ 0.015 % (the table's five digits alone are up to
    0.009 % of 1 - x/L at PL²/EI = 1). Case C publishes 0.5 %."""
    sim = run_scene(
        DEMOS / "end_shear.toml",
        "load.0.value=[0.0, 0.0, 10.0]",
        "time.end=10.0",
        "time.dt=0.25",
        "mesh.divisions=[32, 1]",
        out_dir=tmp_path,
    )
    for k, (ux, _, uz) in zip(ELASTICA, rows_at(sim, list(ELASTICA))):
        w_ref, u_ref = ELASTICA[k]
        ew, eu = abs(uz / 10 - w_ref) / w_ref, abs(-ux / 10 - u_ref) / u_ref
        print(
            f"PL²/EI = {k}: w/L = {uz / 10:.5f} ({w_ref}), 1 - x/L = {-ux / 10:.5f} ({u_ref}); "
            f"errors {100 * ew:.4f} %, {100 * eu:.4f} %"
        )
        assert ew < 0.0015 and eu < 0.0015


# --- E. Locking ---------------------------------------------------------------------


@pytest.mark.parametrize("slenderness", [100, 1000])
def test_no_shear_or_membrane_locking(tmp_path, slenderness):
    """Linear tip deflection PL³/(3EI) within 0.04 % for L/t = 100 and 1000 on one mesh
    (16x1 quadrilaterals); reached 0.004 % and 0.002 %. Case E publishes 1 %."""
    L, E, w = 10.0, 1.2e6, 1.0
    t = L / slenderness
    EI = E * w * t**3 / 12
    P = 1e-4 * 3 * EI / L**2  # deflection 1e-4 L: linear regime
    sim = run_scene(
        DEMOS / "end_shear.toml",
        f"shell.thickness={t}",
        f"load.0.value=[0, 0, {P}]",
        "load.0.ramp=constant",
        "time.end=1.0",
        "time.dt=1.0",
        out_dir=tmp_path,
    )
    uz = sim.history[-1][1][0][2]
    exact = P * L**3 / (3 * EI)
    err = abs(uz - exact) / exact
    print(f"L/t = {slenderness}: w = {uz:.6e}, PL³/3EI = {exact:.6e}, error {100 * err:.4f} %")
    assert err < 4e-4


# --- Twist ---------------------------------------------------------------------------


def end_rotation(sim):
    """Unwrapped rotation (rad) of the free end about X, from its two corner probes."""
    d = np.array([row[1][1] - row[1][0] for row in sim.history]) + np.array([0.0, 1.0, 0.0])
    return np.unwrap(np.arctan2(d[:, 2], d[:, 1]))


def test_small_twist_rate_matches_saint_venant_torsion(tmp_path):
    """Away from the ends, a small torque T twists the strip at the rate T/(G J) of
    Saint-Venant's torsion of a thin rectangle, J = w t³/3 (1 − 0.630 t/w)
    (Timoshenko & Goodier, Theory of Elasticity, §109; the (t/w)⁵ term is 1e-6 here).
    The Reissner–Mindlin shell's own value, J = w t³/3 (1 − 2t/(√10 w) tanh(√10 w/2t))
    with k_s = 5/6 (its free-edge shear layer), is 0.03 % from it. Rate from the
    sections at X = 4 and 8 (the clamped end stiffens the first width or so, and the
    end rotation is 2.3 % below T L/(G J)): within 0.5 %, reached 0.11 % (20x4)."""
    text = (DEMOS / "twist.toml").read_text() + "".join(
        f"""
[[output.probes]]
name = "{name}"
at = [{x}, {y}, 0.0]
"""
        for name, x, y in (("a0", 4.0, 0.0), ("a1", 4.0, 1.0), ("b0", 8.0, 0.0), ("b1", 8.0, 1.0))
    )
    scene = tmp_path / "twist.toml"
    scene.write_text(text)
    torque = 1.0
    sim = run_scene(scene, f"load.0.value=[{torque}, 0, 0]", "time.dt=0.5", out_dir=tmp_path)
    shell, mesh = sim.scene["shell"], sim.scene["mesh"]
    t, w = shell["thickness"], mesh["width"]
    G = shell["E"] / (2 * (1 + shell["nu"]))
    u = sim.history[-1][1]  # probes: corner0, corner1, a0, a1, b0, b1

    def section_rotation(i, j):
        d = u[j] - u[i] + np.array([0.0, w, 0.0])
        return np.arctan2(d[2], d[1])

    rate = (section_rotation(4, 5) - section_rotation(2, 3)) / 4.0
    J = w * t**3 / 3 * (1 - 0.630 * t / w)
    exact = torque / (G * J)
    err = abs(rate - exact) / exact
    print(f"twist rate {rate:.6e} rad/mm, T/(G J) = {exact:.6e}, error {100 * err:.3f} %")
    assert err < 0.005


def test_twist_passes_180_and_360_degrees_without_failed_step(tmp_path):
    sim = run_scene(DEMOS / "twist.toml", out_dir=tmp_path)
    phi = np.degrees(end_rotation(sim))
    print(f"end rotation at t = 1: {phi[-1]:.1f} deg; steps {sim.summary['counts']}")
    assert phi.max() > 360.0
    assert np.all(np.diff(phi) > 0), "the twist must grow monotonically with the torque"
    assert sim.summary["counts"]["dt_cuts"] == 0
    assert sim.summary["director_unit_error"] < 1e-12


# --- A and B on P2 triangles -------------------------------------------------------


def test_end_shear_on_triangles(tmp_path):
    """Sze 3.1 on 16x1 strips cut into P2 triangles: w within 1 % at every row
    (reached ≤ 0.06 %), −u within 1 % or the table's last digit."""
    sim = run_scene(DEMOS / "end_shear.toml", "mesh.cell=triangle", out_dir=tmp_path)
    loads = sorted(SZE_SHEAR)
    for p, (ux, _, uz) in zip(loads, rows_at(sim, loads)):
        ref_u, ref_w = SZE_SHEAR[p]
        print(f"triangles, P/Pmax = {p:4.2f}: -u = {-ux:.4f} ({ref_u}), w = {uz:.4f} ({ref_w})")
        assert abs(uz - ref_w) / ref_w < 0.01
        assert abs(-ux - ref_u) <= max(0.01 * ref_u, 1e-3)


def _rollup_until(fraction):
    """Overrides that stop the roll-up demo at M = fraction Mmax with M/Mmax = t still
    (the demo ramps to 2 Mmax at t = 2)."""
    import tomllib

    two_mmax = tomllib.loads((DEMOS / "rollup.toml").read_text())["load"][0]["value"][1]
    return (f"time.end={fraction}", f"load.0.value=[0.0, {two_mmax / 2 * fraction!r}, 0.0]")


def test_rollup_on_triangles_to_three_quarters(tmp_path):
    """Sze 3.2 on 32x1 P2 triangles: the tip on the exact circle within 0.5 % of L up
    to M/Mmax = 0.75 (reached ≤ 0.03 %)."""
    sim = run_scene(
        DEMOS / "rollup.toml",
        "mesh.cell=triangle",
        "mesh.divisions=[32, 1]",
        *_rollup_until(0.75),
        out_dir=tmp_path,
    )
    errors = _rollup_errors(sim, [0.25, 0.5, 0.75])
    assert max(errors) < 0.005


def test_rollup_leaves_its_plane_near_closure_once_symmetry_is_broken(tmp_path):
    """Under a dead end moment the planar roll-up is unstable in 3-D near closure:
    past M/Mmax ≈ 0.8 the strip leaves its plane when something breaks the
    symmetry. A side moment of 1e-3 M (about X and Z) sends the tip at Mmax 1.5 mm
    off the plane, to the same place on 32x1 P2 triangles and on 32x1
    quadrilaterals (within 5 % of the tip's travel; 0.8 % reached). So Sze 3.2
    beyond 0.75 Mmax is a check of a symmetric path, not of the shell.
    Load steps know no stability: which branch a step lands on is where its Newton
    iterations lead. Without the side moment both meshes stay on the planar branch
    (tip on the exact circle, x = −12, within 1 % of L): static steps start from
    the predicted state, which follows the branch they are on. (Started from the
    last state, as they were before, the triangles' diagonals alone were enough to
    leave it; with 1e-4 M neither mesh leaves it now.)"""
    end, load = _rollup_until(1.0)
    m = float(load.split("[")[1].split(",")[1])
    tips = {}
    for cell in ("triangle", "quadrilateral"):
        for side in (0.0, 1e-3):
            tips[cell, side] = run_scene(
                DEMOS / "rollup.toml",
                f"mesh.cell={cell}",
                "mesh.divisions=[32, 1]",
                end,
                f"load.0.value=[{side * m!r}, {m!r}, {side * m!r}]",
                out_dir=tmp_path / f"{cell}-{side}",
            ).history[-1][1][0]
            print(f"tip at Mmax, {cell}, side moment {side:g} M: {tips[cell, side]}")
    tri, quad = tips["triangle", 1e-3], tips["quadrilateral", 1e-3]
    travel = np.linalg.norm(tri)
    assert abs(tri[1]) > 1.0 and abs(quad[1]) > 1.0
    assert np.linalg.norm(tri - quad) < 0.05 * travel
    for cell in ("triangle", "quadrilateral"):
        planar = tips[cell, 0.0]
        assert abs(planar[0] + 12.0) < 0.01 * 12.0 and np.abs(planar[1:]).max() < 0.01 * 12.0
