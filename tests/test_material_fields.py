"""Material fields and the orthotropic law against exact solutions.

A thickness or modulus given as a formula of X, Y, Z, as a profile file or as a
part's formula (tapered cantilevers, small and large deflection); the orthotropic
law (equal to the isotropic one with isotropic moduli, E1 I along the fibre and
E2 I across it, the bending-twisting coupling of an off-axis fibre, a clamped
orthotropic plate); malformed material values (one line, exit status 2; the
fixtures are tests/scenes_bad/material_*.toml, run by test_scene, test_cli and
test_api).

The references are independent of the code: tests/material_references.py and
tests/plate_references.py (numpy/scipy; tests/test_material_references.py checks
them against the literature).  Every small-deflection run is one static step;
every run is on quadrilaterals of the same degree, so the few forms here
(thickness field, modulus field, orthotropic with an edge force or with a
pressure) are compiled once.  Each test prints the figure it reached (pytest -s).
"""

from __future__ import annotations

import io
import re
from contextlib import redirect_stderr

import material_references as mr
import numpy as np
import plate_references as pr
import pytest
from conftest import rows_at, run_scene, write_scene
from scipy import integrate

#: the cantilever strip of the small-deflection tests: clamped at X = 0, a tip force
#: P along Z spread over the edge X = L; ν = 0, so its EI is E W t³/12
L, W, E, P = 10.0, 1.0, 1.2e6, 1.0e-5
#: 40 x 1 quadrilaterals along L = 10 (20 x 1 reaches the figures below within 2e-5)
DIVISIONS = "[40, 1]"
#: the shear correction of the shell (forms/elasticity.py)
K_S = 5.0 / 6.0
#: an orthotropic layer: E1/E2 = 4, G13 = G23 = G12 (their default)
E1, E2, G12, NU12 = 2.4e6, 0.6e6, 0.4e6, 0.3
ORTHOTROPIC = f"""material = "orthotropic"
E1 = {E1}
E2 = {E2}
G12 = {G12}
nu12 = {NU12}"""


def strip(
    shell: str,
    *,
    length=L,
    width=W,
    divisions=DIVISIONS,
    load=(0.0, 0.0, P),
    end=1.0,
    dt=1.0,
    ramp="constant",
    probes=None,
    extra="",
) -> str:
    """A cantilever scene: ``shell`` is the body of [shell]; probes (name, point), by
    default the middle of the tip edge."""
    probes = probes or [("tip", (length, width / 2, 0.0))]
    return f"""
title = "material field strip"
[mesh]
length = {length}
width = {width}
divisions = {divisions}
{extra}
[shell]
{shell}
[time]
end = {end}
dt = {dt}
[[boundary]]
where = "x=0"
fix = ["clamped"]
[[load]]
kind = "edge-force"
where = "x=L"
value = [{load[0]}, {load[1]}, {load[2]}]
ramp = "{ramp}"
""" + "".join(
        f"""
[[output.probes]]
name = "{name}"
at = [{at[0]}, {at[1]}, {at[2]}]
"""
        for name, at in probes
    )


def shear_deflection(P, L, width, G, thickness, points=None) -> float:
    """The Timoshenko part of the tip deflection, ∫₀ᴸ P / (k_s G(x) W t(x)) dx (the
    shell's transverse shear; Euler-Bernoulli leaves it out)."""
    G, t = (f if callable(f) else (lambda x, c=f: c) for f in (G, thickness))
    value, _ = integrate.quad(
        lambda x: P / (K_S * G(x) * width * t(x)),
        0.0,
        L,
        points=points,
        epsabs=0.0,
        epsrel=1e-12,
        limit=200,
    )
    return value


def tip_director(sim, point=(L, W / 2, 0.0)) -> np.ndarray:
    """The director at the node at ``point`` after the run (serial)."""
    model = sim.model
    director = model.nodal_director()
    nodes = model.Vu.tabulate_dof_coordinates()
    i = int(np.argmin(np.linalg.norm(nodes - np.asarray(point), axis=1)))
    assert np.linalg.norm(nodes[i] - np.asarray(point)) < 1e-12
    return director.x.array.reshape(-1, 3)[i]


def bending_rotation(director) -> float:
    """The director's rotation about −Y from +Z (that of the tip of a strip bent
    toward +Z): atan2(−d_x, d_z)."""
    return float(np.arctan2(-director[0], director[2]))


def tip_deflection(sim) -> float:
    return float(sim.history[-1][1][0][2])


# ------------------------------------------------------- tapered cantilevers


def _check_tapered(sim, E_of_x, t_of_x, label, tolerance=1e-5, points=None):
    """Tip deflection against Euler-Bernoulli + Timoshenko shear, tip rotation (the
    director's, which shear does not turn) against ∫ P (L − x)/EI dx."""
    w = tip_deflection(sim)
    bending = mr.tapered_tip_deflection(P, L, W, E_of_x, t_of_x, points=points)
    G_of_x = (lambda x: E_of_x(x) / 2) if callable(E_of_x) else E_of_x / 2  # ν = 0
    exact = bending + shear_deflection(P, L, W, G_of_x, t_of_x, points=points)
    theta = bending_rotation(tip_director(sim))
    theta_exact = mr.tapered_tip_rotation(P, L, W, E_of_x, t_of_x, points=points)
    print(
        f"{label}: tip deflection {w:.9e}, exact {exact:.9e} (error {w / exact - 1:+.2e}; "
        f"Euler-Bernoulli alone {w / bending - 1:+.2e}); tip rotation {theta:.9e}, exact "
        f"{theta_exact:.9e} (error {theta / theta_exact - 1:+.2e})"
    )
    assert abs(w / exact - 1) < tolerance
    assert abs(theta / theta_exact - 1) < tolerance
    return w


def thickness_taper(x):
    return 0.15 - 0.01 * x


def test_thickness_formula_tapered_cantilever(tmp_path):
    """thickness = "0.15 - 0.01*X" (0.15 at the clamp, 0.05 at the tip): the tip
    deflection is ∫₀ᴸ P (L − x)²/EI(x) dx (tapered_tip_deflection, EI = E W t³/12) plus
    the shear's ∫₀ᴸ P/(k_s G W t(x)) dx (1.05e-4 of it), and the director's tip rotation
    ∫₀ᴸ P (L − x)/EI(x) dx (tapered_tip_rotation), each within 1e-5: reached −8.9e-7 and
    +1.7e-6 on both stacks (a uniform 0.1, the taper's mean, deflects 1.59 times as
    much)."""
    sim = run_scene(write_scene(tmp_path, strip(f'thickness = "0.15 - 0.01*X"\nE = {E}')))
    _check_tapered(sim, E, thickness_taper, "thickness formula")


def test_modulus_formula_tapered_cantilever(tmp_path):
    """E = "1.2e6*(1 + 0.1*X)" (twice as stiff at the tip), t = 0.1: the same closed
    forms with EI(x) = E(x) W t³/12 and G = E(x)/2, within 1e-5: reached −1.4e-6 and
    −5e-7 on both stacks (E of the clamp everywhere deflects 1.22 times as much)."""
    sim = run_scene(write_scene(tmp_path, strip('thickness = 0.1\nE = "1.2e6*(1 + 0.1*X)"')))
    _check_tapered(sim, lambda x: E * (1 + 0.1 * x), 0.1, "modulus formula")


def test_thickness_profile_matches_the_formula(tmp_path):
    """The taper of test_thickness_formula_tapered_cantilever as a profile (11 rows
    X = 0, 1, …, 10 at Y = 0.5, Z = 0, with a header; the single Y and Z values are
    not interpolated along): its multilinear interpolation of a linear function is
    exact, so the tip deflection equals the formula run's within 1.5e-14 (reached
    1.6e-15 on both stacks, ≤ 1e-15 under the other OpenBLAS kernels) and the closed
    forms within 1e-5 (as the formula's).  The bare file name reads as the same
    profile.  Broke: the file's X written 1e-12 off → −2.8e-13 (the earlier bound,
    1e-12, let it pass)."""
    from rftfem.scene.reading import load_scene

    rows = "".join(f"{x},0.5,0,{thickness_taper(x)!r}\n" for x in map(float, range(11)))
    (tmp_path / "taper.csv").write_text("X,Y,Z,thickness\n" + rows, encoding="utf-8")
    profile = write_scene(
        tmp_path, strip(f'thickness = {{ profile = "taper.csv" }}\nE = {E}'), "profile.toml"
    )
    bare = write_scene(tmp_path, strip(f'thickness = "taper.csv"\nE = {E}'), "bare.toml")
    assert load_scene(bare)["shell"]["thickness"] == {"profile": "taper.csv"}
    assert load_scene(profile)["shell"]["thickness"] == {"profile": "taper.csv"}

    by_profile = run_scene(profile)
    w = _check_tapered(by_profile, E, thickness_taper, "thickness profile")
    by_formula = run_scene(
        write_scene(tmp_path, strip(f'thickness = "0.15 - 0.01*X"\nE = {E}'), "formula.toml")
    )
    w_formula = tip_deflection(by_formula)
    print(f"profile vs formula: {w / w_formula - 1:+.2e}")
    assert abs(w / w_formula - 1) < 1.5e-14


def test_part_thickness_formula_on_a_region(tmp_path):
    """[shell] thickness 0.1 with a part on the region X ≤ 4 whose thickness is
    "0.16 - 0.01*X" (0.16 down to 0.12, then a jump to 0.1): the piecewise closed forms
    (tapered_tip_deflection and tapered_tip_rotation with a break at X = 4, plus the
    shear) within 1e-5: reached −1.0e-6 and −1.9e-7 on both stacks ([shell]'s 0.1 on
    the part too deflects twice as much)."""
    scene = strip(
        f'thickness = 0.1\nE = {E}\n[[shell.parts]]\nregion = "root"\nthickness = "0.16 - 0.01*X"',
        extra='[[mesh.regions]]\nname = "root"\nx = [0.0, 4.0]',
    )
    sim = run_scene(write_scene(tmp_path, scene))

    def thickness(x):
        return 0.16 - 0.01 * x if x < 4.0 else 0.1

    _check_tapered(sim, E, thickness, "part thickness formula", points=[4.0])


def test_tapered_cantilever_large_deflection_is_the_nonuniform_elastica(tmp_path):
    """thickness = "0.12 - 0.004*X" (EI falls by 3.4 from the clamp to the tip) under a
    dead tip force P = 2 EI(0)/L² along Z in four load steps of a linear ramp: the tip's
    axial and transverse displacements at P/2 and P and the director's tip rotation at
    P against the inextensible, unshearable elastica with EI(x) (nonuniform_elastica),
    within 0.1 %: reached 1.1e-4 (the shell's shear and stretch, which the elastica
    leaves out) on both stacks; the tip turns by 1.0 rad and moves in to 0.78 L."""

    def thickness(x):
        return 0.12 - 0.004 * x

    def EI(x):
        return E * W * thickness(x) ** 3 / 12

    force = 2 * EI(0.0) / L**2
    sim = run_scene(
        write_scene(
            tmp_path,
            strip(
                f'thickness = "0.12 - 0.004*X"\nE = {E}',
                load=(0.0, 0.0, force),
                dt=0.25,
                ramp="linear",
            ),
        )
    )
    assert sim.summary["status"] == "ok"
    worst = 0.0
    for scale, (ux, _, uz) in zip((0.5, 1.0), rows_at(sim, [0.5, 1.0])):
        dx, dz, theta = mr.nonuniform_elastica(scale * force, L, EI, 8)
        errors = (ux / dx - 1, uz / dz - 1)
        print(
            f"P = {scale} x 2EI(0)/L²: tip (ux, uz) = ({ux:.6f}, {uz:.6f}), elastica "
            f"({dx:.6f}, {dz:.6f}), errors {errors[0]:+.2e}, {errors[1]:+.2e}"
        )
        worst = max(worst, *map(abs, errors))
    rotation = bending_rotation(tip_director(sim))
    print(
        f"tip rotation {rotation:.6f} rad, elastica {theta:.6f} rad, "
        f"error {rotation / theta - 1:+.2e}"
    )
    worst = max(worst, abs(rotation / theta - 1))
    assert worst < 1e-3


# ------------------------------------------------------------------ orthotropic


def test_orthotropic_law_with_isotropic_moduli_is_the_isotropic_law(tmp_path):
    """E1 = E2 = E, G12 = G13 = G23 = E/(2(1 + ν)), ν12 = ν = 0.3 with the fibre at 30°
    from X, against the isotropic shell: a tip force (0, 0.3 P, P) with P L²/EI = 1 in
    two steps bends the strip out of its plane and in it and twists it (the ends of the
    tip edge differ by 0.013 in Z): every term of the law works.  Every probe's
    displacement at every step equal within 1e-14 of the largest (reached 7.4e-16 and
    3.0e-16 on the two stacks, ≤ 1.5e-15 under the other OpenBLAS kernels: the two laws
    are algebraically equal).  Broke: the orthotropic ν₁₂ given as 0.3 + 1e-12 → 3.8e-13
    (the earlier bound, 1e-12, let it pass)."""
    nu, t = 0.3, 0.1
    G = E / (2 * (1 + nu))
    force = E * W * t**3 / 12 / L**2
    angle = np.radians(30.0)
    fibre = f"[{float(np.cos(angle))!r}, {float(np.sin(angle))!r}, 0.0]"
    probes = [
        ("tip0", (L, 0.0, 0.0)),
        ("tip1", (L, W, 0.0)),
        ("mid0", (L / 2, 0.0, 0.0)),
        ("mid1", (L / 2, W, 0.0)),
    ]
    common = dict(
        divisions="[20, 2]", load=(0.0, 0.3 * force, force), dt=0.5, ramp="linear", probes=probes
    )
    iso = run_scene(
        write_scene(
            tmp_path, strip(f"thickness = {t}\nE = {E}\nnu = {nu}", **common), "isotropic.toml"
        )
    )
    ortho = run_scene(
        write_scene(
            tmp_path,
            strip(
                f'thickness = {t}\nmaterial = "orthotropic"\nE1 = {E}\nE2 = {E}\nG12 = {G}\n'
                f"G13 = {G}\nG23 = {G}\nnu12 = {nu}\nfibre = {fibre}",
                **common,
            ),
            "orthotropic.toml",
        )
    )
    a = np.array([row[1] for row in iso.history])
    b = np.array([row[1] for row in ortho.history])
    assert a.shape == b.shape == (3, 4, 3)
    tip = a[-1]
    print(
        f"tip corners {tip[0]}, {tip[1]}; largest difference "
        f"{np.abs(a - b).max() / np.abs(a).max():.1e} of the largest displacement"
    )
    assert abs(tip[1, 2] - tip[0, 2]) > 1e-3 and abs(tip[0, 1]) > 1e-2  # twisted, bent in plane
    assert np.abs(a - b).max() < 1e-14 * np.abs(a).max()


def _curvature(u, z, h):
    """w'' at the middle of three stations h apart: exact for a cubic w."""
    return (u[z[0]] - 2 * u[z[1]] + u[z[2]]) / h**2


#: the stations of the long strip (L = 20, W = 1), away from the clamp's boundary layer
LONG, STATIONS = 20.0, (6.0, 10.0, 14.0)


@pytest.mark.parametrize(
    "fibre, modulus",
    [((2.0, 0.0, 1.0), E1), ((0.0, 3.0, 0.0), E2)],
    ids=["fibre-along", "fibre-across"],
)
def test_orthotropic_strip_bends_with_the_modulus_along_it(tmp_path, fibre, modulus):
    """A narrow strip (L = 20, W = 1, t = 0.1, 40 x 2 cells) with the fibre along X
    bends with E1 I, across X with E2 I (I = W t³/12; free long edges: the plane-stress
    law's own E along X; the fibres given are (2, 0, 1) and (0, 3, 0): projected on
    the surface and normalised).  The curvature at X = 10 from the second difference of
    uz at X = 6, 10, 14 (exact for the cubic of beam theory; the shear's linear part and
    the clamp's boundary layer drop out) against P (L − 10)/(E I): within 3e-7, reached
    −2.4e-8 and −1.4e-8 on both stacks.  The tip deflection against P L³/(3 E I) +
    P L/(k_s G12 W t) (G13 = G23 = G12): within 0.5 %, reached −0.15 % and −0.08 %
    (the clamp holds the anticlastic curvature −ν κ of the root, ν = ν12 or ν21)."""
    probes = [("tip", (LONG, W / 2, 0.0))]
    probes += [(f"x{x:g}", (x, W / 2, 0.0)) for x in STATIONS]
    sim = run_scene(
        write_scene(
            tmp_path,
            strip(
                f"thickness = 0.1\n{ORTHOTROPIC}\nfibre = [{fibre[0]}, {fibre[1]}, {fibre[2]}]",
                length=LONG,
                divisions="[40, 2]",
                probes=probes,
            ),
        )
    )
    uz = sim.history[-1][1][:, 2]
    EI = modulus * W * 0.1**3 / 12
    kappa = _curvature(uz, (1, 2, 3), STATIONS[1] - STATIONS[0])
    kappa_exact = P * (LONG - STATIONS[1]) / EI
    tip_exact = P * LONG**3 / (3 * EI) + P * LONG / (K_S * G12 * W * 0.1)
    print(
        f"fibre {fibre}: curvature {kappa:.9e}, P(L - x)/EI {kappa_exact:.9e} (error "
        f"{kappa / kappa_exact - 1:+.2e}); tip {uz[0]:.6e}, beam {tip_exact:.6e} "
        f"(error {uz[0] / tip_exact - 1:+.2e})"
    )
    assert abs(kappa / kappa_exact - 1) < 3e-7
    assert abs(uz[0] / tip_exact - 1) < 5e-3


@pytest.mark.parametrize(
    "degrees, cells", [(45.0, "quadrilateral"), (-30.0, "quadrilateral"), (45.0, "triangle")]
)
def test_off_axis_fibre_twists_the_bent_strip(tmp_path, degrees, cells):
    """Bending-twisting coupling: the narrow strip (L = 20, W = 1, W/L = 0.05) with the
    fibre at an angle α from X toward Y, bent by the tip force P along Z.  Narrow-strip
    theory (free long edges: M_yy = M_xy = 0): (w,xx, w,yy, 2 w,xy) = D⁻¹ (m, 0, 0) with
    m(x) = P (L − x)/W the bending moment per width that bends it toward +Z and D of the
    layer at α (narrow_strip_curvatures; its sign convention for κ and M cancels in
    κ = D⁻¹ M).  The section's rotation about +X is φ = ∂uz/∂Y, measured as
    (uz(x, W) − uz(x, 0))/W (the anticlastic w,yy is even about the middle line), so
    φ(14) − φ(6) = ½ (2κ_xy per unit m) (P/W) ∫₆¹⁴ (L − x) dx: a twist of −3e-6 rad
    at 45° (the root's boundary layer makes φ(6) itself 3.7 % smaller than from X = 0,
    hence two stations).  Within 1e-8, reached −1.1e-9 (45°) and +8e-10 (−30°) on
    both stacks; the bending curvature at X = 10 against κ_xx = (D⁻¹)₁₁ m within
    2e-7, reached 1.8e-8 and 1.4e-8.  The third case, on triangles (skewed cells,
    whose metric has off-diagonal terms) with the fibre given as formulas (a DG2
    field), reaches 1.5e-7 (within 1.5e-6) and 4.9e-9."""
    angle = np.radians(degrees)
    fibre = f"[{float(np.cos(angle))!r}, {float(np.sin(angle))!r}, 0.0]"
    if cells == "triangle":
        # skewed cells (their metric is not diagonal) and the fibre as a field: the
        # same constant direction written as formulas of X
        fibre = f'["{float(np.cos(angle))!r} + 0*X", "{float(np.sin(angle))!r}", "0"]'
    probes = [
        (f"{side}{x:g}", (x, y, 0.0))
        for x in STATIONS
        for side, y in (("a", 0.0), ("b", W), ("m", W / 2))
    ]
    sim = run_scene(
        write_scene(
            tmp_path,
            strip(
                f"thickness = 0.1\n{ORTHOTROPIC}\nfibre = {fibre}",
                length=LONG,
                divisions="[40, 2]",
                probes=probes,
                extra=f'cell = "{cells}"',
            ),
        )
    )
    uz = sim.history[-1][1][:, 2]
    kxx, _, k2xy = mr.narrow_strip_curvatures(E1, E2, G12, NU12, 0.1, angle, 1.0)
    phi = [(uz[3 * i + 1] - uz[3 * i]) / W for i in range(3)]
    twist = phi[2] - phi[0]
    x0, x1 = STATIONS[0], STATIONS[2]
    twist_exact = 0.5 * k2xy * P / W * ((LONG - x0) ** 2 - (LONG - x1) ** 2) / 2
    kappa = _curvature(uz, (2, 5, 8), STATIONS[1] - STATIONS[0])
    kappa_exact = kxx * P * (LONG - STATIONS[1]) / W
    print(
        f"fibre at {degrees}°: twist φ(14) − φ(6) = {twist:.9e} rad, narrow strip "
        f"{twist_exact:.9e} (error {twist / twist_exact - 1:+.2e}); φ(6) {phi[0]:.4e}; "
        f"curvature error {kappa / kappa_exact - 1:+.2e}"
    )
    # triangles (the third case) reached 1.5e-7 and 4.9e-9
    assert abs(twist / twist_exact - 1) < (1e-8 if cells == "quadrilateral" else 1.5e-6)
    assert abs(kappa / kappa_exact - 1) < 2e-7


@pytest.mark.parametrize(
    "fibre, modulus, shear",
    [((1.0, 0.0, 0.0), E1, "G13"), ((0.0, 1.0, 0.0), E2, "G23")],
    ids=["fibre-along", "fibre-across"],
)
def test_transverse_shear_moduli_of_the_fibre_frame(tmp_path, fibre, modulus, shear):
    """A short thick strip (L = 10, W = 4, t = 0.5, ν12 = 0, so no anticlastic
    coupling) with G13 = 0.1e6 and G23 = 0.05e6 given: the plane of X and the normal is
    that of the fibre and the normal (G13) when the fibre is along X, the one across it
    (G23) when the fibre is along Y.  Tip deflection against Timoshenko's
    P L³/(3 E I) + P L/(k_s G W t), where the shear is 1.8 % and 0.9 % of it: within
    1e-7, reached −4e-9 and −8e-9 on both stacks (G13 and G23 swapped: 0.9 % off)."""
    length, width, t, force = 10.0, 4.0, 0.5, 1.0e-3
    moduli = {"G13": 0.1e6, "G23": 0.05e6}
    sim = run_scene(
        write_scene(
            tmp_path,
            strip(
                f'thickness = {t}\nmaterial = "orthotropic"\nE1 = {E1}\nE2 = {E2}\nG12 = {G12}\n'
                f"nu12 = 0.0\nG13 = {moduli['G13']}\nG23 = {moduli['G23']}\n"
                f"fibre = [{fibre[0]}, {fibre[1]}, {fibre[2]}]",
                length=length,
                width=width,
                load=(0.0, 0.0, force),
                probes=[("tip", (length, width / 2, 0.0))],
            ),
        )
    )
    w = tip_deflection(sim)
    exact = force * length**3 / (3 * modulus * width * t**3 / 12) + force * length / (
        K_S * moduli[shear] * width * t
    )
    print(
        f"fibre {fibre}: tip deflection {w:.9e}, Timoshenko with {shear} {exact:.9e}, "
        f"error {w / exact - 1:+.2e}"
    )
    assert abs(w / exact - 1) < 1e-7


PLATE = 10.0


def plate_scene(t: float, q: float, divisions: str) -> str:
    clamps = "".join(
        f'\n[[boundary]]\nwhere = "{edge}"\nfix = ["clamped"]\n'
        for edge in ("x=0", "x=L", "y=0", "y=W")
    )
    return f"""
title = "clamped orthotropic square plate"
[mesh]
length = {PLATE}
width = {PLATE}
divisions = {divisions}
[shell]
thickness = {t}
{ORTHOTROPIC}
fibre = [1.0, 0.0, 0.0]
[time]
end = 1.0
dt = 1.0
{clamps}
[[load]]
kind = "pressure"
value = {q}
ramp = "constant"
[[output.probes]]
name = "centre"
at = [{PLATE / 2}, {PLATE / 2}, 0.0]
"""


def test_clamped_orthotropic_plate_under_pressure(tmp_path):
    """A clamped square plate (a = 10) with the fibre along X (E1/E2 = 4) under a
    uniform pressure, at a/t = 100 and 200 (24 x 24 cells; centre deflection 4e-5 t, a
    linear response): against the Kirchhoff plate's Ritz solution
    (clamped_orthotropic_plate, 12² terms, converged to 1e-10) with D11, D12, D22,
    D66 = D[0, 0], D[0, 1], D[1, 1], D[2, 2] of orthotropic_D (its κ = (κxx, κyy, 2κxy),
    so ½ κ·Dκ has the 2 D66 w,xy² = ½ · 4 D66 w,xy² of the Ritz energy).  The shell's
    transverse shear softens it by c (t/a)²: +0.28 % at a/t = 100, +0.06 % at 200 (both
    asserted in (0, 0.5 %)); Richardson's (4 r(t/2) − r(t))/3 of the ratios r to the
    Ritz values removes it and is within 0.1 % of 1: reached −0.011 % on both stacks
    (the mesh's own error; 48 x 48 reaches −0.003 %).  D66's share of the deflection is
    0.13 per unit: an in-plane shear modulus off by 1 % moves it by 0.13 %."""
    ratios = {}
    for t in (PLATE / 100, PLATE / 200):
        D = mr.orthotropic_D(E1, E2, G12, NU12, t, 0.0)
        q = 1e-4 * t * D[1, 1] / (pr.SQUARE_CLAMPED * PLATE**4)  # deflection below 1e-4 t
        ritz = pr.clamped_orthotropic_plate(
            PLATE, PLATE, D[0, 0], D[0, 1], D[1, 1], D[2, 2], q, terms=12
        )
        sim = run_scene(write_scene(tmp_path, plate_scene(t, q, "[24, 24]"), f"plate{t:g}.toml"))
        w = tip_deflection(sim)
        ratios[t] = w / ritz
        print(
            f"a/t = {PLATE / t:g}: centre deflection {w:.6e}, Ritz {ritz:.6e} "
            f"(w/t {w / t:.1e}), ratio - 1 = {ratios[t] - 1:+.3e}"
        )
    thick, thin = ratios[PLATE / 100], ratios[PLATE / 200]
    kirchhoff = (4 * thin - thick) / 3
    print(f"extrapolated to t -> 0: ratio - 1 = {kirchhoff - 1:+.3e}")
    assert 0 < thin - 1 < thick - 1 < 5e-3
    assert abs(kirchhoff - 1) < 1e-3


# ------------------------------------------------------------------ bad input


def _check_error(scene) -> str:
    """`rftfem check SCENE` in this process: exit status 2 and one line, returned."""
    from rftfem import cli

    err = io.StringIO()
    with redirect_stderr(err):
        status = cli.main(["check", str(scene)])
    lines = err.getvalue().splitlines()
    assert status == 2, err.getvalue()
    assert len(lines) == 1 and lines[0].startswith("rftfem: error: "), lines
    return lines[0]


def test_profile_that_does_not_cover_the_body(tmp_path):
    """A profile over 0 ≤ X ≤ 5 on the strip of length 10: one line naming the key, a
    point of the body beyond X = 5 and the profile's X range."""
    (tmp_path / "short.csv").write_text(
        "X,Y,Z,thickness\n0,0.5,0,0.1\n2.5,0.5,0,0.1\n5,0.5,0,0.1\n", encoding="utf-8"
    )
    line = _check_error(write_scene(tmp_path, strip('thickness = "short.csv"', divisions="[4, 1]")))
    print(line)
    assert "shell.thickness.profile" in line and "does not cover the body" in line
    assert "its X range [0, 5]" in line
    point = re.search(r"the point \[([^\]]*)\]", line)
    assert point, line
    assert float(point.group(1).split(",")[0]) > 5.0
