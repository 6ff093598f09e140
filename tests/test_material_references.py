"""The independent references of tests/material_references.py and
tests/plate_references.py against literature values, closed forms and
cross-checks of their own (numpy/scipy only; about 7 s in all on one BLAS thread).

Each tolerance is about 10 times the largest error reached on the two stacks
(scipy 1.10 and 1.18), or, against a table, a stated number of units of the
table's last digit.  Each test prints what it reached (pytest -s).
"""

from __future__ import annotations

import material_references as mr
import numpy as np
import plate_references as pr
from scipy import integrate


def _rel(got, ref):
    return abs(got / ref - 1)


# ---------------------------------------------------------------- tapered beams

P, L, W, E, T0, NU = 2.0, 3.0, 0.5, 7.0e4, 0.05, 0.3
EI = E * W * T0**3 / 12
C = 0.5  # t = T0 (1 - C x/L)


def _taper(x):
    return T0 * (1 - C * x / L)


def test_tapered_cantilever_closed_forms():
    """Uniform: P L³/3EI, P L²/2EI, the plate strip's (1 − ν²) P L³/3EI; the linear
    taper t₀(1 − c x/L), c = ½: 12 P L³/(E w t₀³ c³) (−2d − d²/2 − ln(1 − c) − 3/2),
    d = c − 1; E(1 + x/L) uniform t: P L³/EI (4 ln 2 − 5/2); all within 1e-14 (reached
    ≤ 1.2e-15).  The gradient on three of five intervals against central differences
    at ±1e-4 t₀ within 1e-6 (reached 1.0e-7).  Broke: the plate's factor 1/(1 − ν²)
    made 1/(1 − ν) → 0.23; the gradient's −3 made −2 → 0.33."""
    d = C - 1
    closed = 12 * P * L**3 / (E * W * T0**3 * C**3) * (-2 * d - d * d / 2 - np.log(1 - C) - 1.5)
    errors = [
        _rel(mr.tapered_tip_deflection(P, L, W, E, T0), P * L**3 / (3 * EI)),
        _rel(mr.tapered_tip_rotation(P, L, W, E, T0), P * L**2 / (2 * EI)),
        _rel(
            mr.tapered_tip_deflection(P, L, W, E, T0, plate=True, nu=NU),
            P * L**3 * (1 - NU**2) / (3 * EI),
        ),
        _rel(mr.tapered_tip_deflection(P, L, W, E, _taper), closed),
        _rel(
            mr.tapered_tip_deflection(P, L, W, lambda x: E * (1 + x / L), T0),
            P * L**3 / EI * (4 * np.log(2) - 2.5),
        ),
    ]
    print("closed forms:", " ".join(f"{e:.1e}" for e in errors))
    assert max(errors) < 1e-14

    edges = np.linspace(0, L, 6)
    g = mr.tapered_deflection_gradient(P, L, W, E, _taper, edges)
    h = 1e-4 * T0
    worst = 0.0
    for i in (0, 2, 4):

        def bumped(s, i=i):
            return lambda x: _taper(x) + s * h * (edges[i] <= x < edges[i + 1])

        fd = (
            mr.tapered_tip_deflection(P, L, W, E, bumped(1), points=edges)
            - mr.tapered_tip_deflection(P, L, W, E, bumped(-1), points=edges)
        ) / (2 * h)
        worst = max(worst, _rel(g[i], fd))
    print(f"gradient against central differences: {worst:.1e}")
    assert worst < 1e-6


# ---------------------------------------------------------------- elastica


def test_uniform_elastica_against_bisshopp_drucker_and_the_first_integral():
    """PL²/EI = 1: the shooting solution's w/L = 0.30172 and 1 − x/L = 0.05643
    (Bisshopp & Drucker 1945) within 1e-5, one unit of the table's last digit
    (reached 7.7e-7 and 3.3e-6); against the first-integral (elliptic) solution at
    PL²/EI = 1, 3, 10 (w/L, 1 − x/L, the tip angle) within 2e-13 (reached 2.6e-14).
    Broke: the shooting's M' = −P cos θ made −P sin θ → w/L 0."""
    dx, y, th = mr.nonuniform_elastica(1.0, 1.0, 1.0)
    print(f"PL²/EI = 1: w/L {y:.8f}, 1 − x/L {-dx:.8f}")
    assert abs(y - 0.30172) < 1e-5 and abs(-dx - 0.05643) < 1e-5
    worst = 0.0
    for alpha in (1.0, 3.0, 10.0):
        dx, y, th = mr.nonuniform_elastica(alpha, 1.0, 1.0)
        ex = mr.uniform_elastica_elliptic(alpha)
        worst = max(worst, _rel(-dx, ex[0]), _rel(y, ex[1]), _rel(th, ex[2]))
    print(f"shooting against the first integral: {worst:.1e}")
    assert worst < 2e-13


def test_nonuniform_elastica_small_load_is_the_tapered_beam():
    """A load 1e-6 EI/L² on the taper: the elastica's y(L) and θ(L) against the
    small-deflection integrals within 1e-8 (reached 1.3e-9);
    four steps of EI (a piecewise-constant thickness, negative load) within 7e-10
    (reached 6.8e-11).  Broke: EI(s) read at s/2 → 0.33."""
    small = 1e-6 * EI / L**2
    dx, y, th = mr.nonuniform_elastica(small, L, lambda x: EI * (1 - C * x / L) ** 3)
    errors = (
        _rel(y, mr.tapered_tip_deflection(small, L, W, E, _taper)),
        _rel(th, mr.tapered_tip_rotation(small, L, W, E, _taper)),
    )
    cells = np.array([1.0, 0.6, 0.3, 0.15]) * T0

    def steps(x):
        return cells[min(int(x / L * 4), 3)]

    dx, y, th = mr.nonuniform_elastica(-small, L, lambda x: E * W * steps(x) ** 3 / 12, n=4)
    stepped = _rel(
        y, mr.tapered_tip_deflection(-small, L, W, E, steps, points=np.linspace(0, L, 5))
    )
    print(f"small load: {errors[0]:.1e}, {errors[1]:.1e}; four steps {stepped:.1e}")
    assert max(errors) < 1e-8 and stepped < 7e-10


# ---------------------------------------------------------------- orthotropic

E1, E2, G12, NU12, T, M = 1.4e5, 1.0e4, 5.0e3, 0.3, 0.002, 0.7


def test_orthotropic_layer_against_the_transformed_compliance():
    """On axis: κxx = 12M/(E₁t³), κyy = −ν₁₂κxx (narrow strip), 12M(1 − ν₁₂ν₂₁)/(E₁t³)
    (wide plate); off axis at 30°, 45°, 60°: (κxx, κyy, 2κxy) = (S̄₁₁, S̄₁₂, S̄₁₆) 12M/t³
    with S̄ the transformed compliance (Jones, Mechanics of Composite Materials,
    written out here independently of the rotated stiffness); isotropic moduli at
    0.7 rad give D = E t³/(12(1 − ν²)) [[1, ν, 0], [ν, 1, 0], [0, 0, (1 − ν)/2]]: all
    within 2e-14 (reached ≤ 2.2e-15).  Broke: T's shear row −2cs made −cs → 6.2."""
    f = 12 * M / T**3
    k = mr.narrow_strip_curvatures(E1, E2, G12, NU12, T, 0.0, M)
    errors = [
        _rel(k[0], f / E1),
        _rel(k[1], -NU12 * f / E1),
        _rel(
            mr.wide_plate_curvature(E1, E2, G12, NU12, T, 0.0, M), f * (1 - NU12**2 * E2 / E1) / E1
        ),
    ]
    S11, S22, S12, S66 = 1 / E1, 1 / E2, -NU12 / E1, 1 / G12
    for deg in (30.0, 45.0, 60.0):
        c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
        Sb11 = S11 * c**4 + (2 * S12 + S66) * s**2 * c**2 + S22 * s**4
        Sb12 = S12 * (s**4 + c**4) + (S11 + S22 - S66) * s**2 * c**2
        Sb16 = (2 * S11 - 2 * S12 - S66) * s * c**3 - (2 * S22 - 2 * S12 - S66) * s**3 * c
        k = mr.narrow_strip_curvatures(E1, E2, G12, NU12, T, np.radians(deg), M)
        errors += [_rel(k[0], Sb11 * f), _rel(k[1], Sb12 * f), _rel(k[2], Sb16 * f)]
    Ei, ni = 2.0e5, 0.3
    D = mr.orthotropic_D(Ei, Ei, Ei / (2 * (1 + ni)), ni, T, 0.7)
    iso = Ei * T**3 / (12 * (1 - ni**2)) * np.array([[1, ni, 0], [ni, 1, 0], [0, 0, (1 - ni) / 2]])
    errors.append(np.abs(D - iso).max() / iso[0, 0])
    print(f"orthotropic layer: largest {max(errors):.1e}")
    assert max(errors) < 2e-14


# ---------------------------------------------------------------- clamped plate


def test_clamped_plate_against_the_literature():
    """Isotropic square, w_c D/(q a⁴): 0.00126532 (pr.SQUARE_CLAMPED) within 1e-8,
    one unit of its last digit (reached 9.1e-10), the beam-mode basis (36 terms) equal
    to the Legendre one (14) within 2e-7 relative (reached 2.2e-8, its algebraic
    convergence); Timoshenko & Woinowsky-Krieger's table 35 at b/a = 1, 1.5, 2 within
    3e-5, three units of its last digit (reached 5.3e-6, 3.5e-6, 7.0e-6); b/a = 8
    against the long strip's 1/384 within 3e-8 relative (reached 2.7e-9).  Broke: the D12
    coupling term
    dropped → square 0.0013617 (off by 9.6e-5)."""
    square = pr.clamped_orthotropic_plate(1, 1, 1, 0.3, 1, 0.35, 1, 14)
    beam = pr.clamped_orthotropic_plate(1, 1, 1, 0.3, 1, 0.35, 1, 36, "beam")
    table = {r: pr.clamped_orthotropic_plate(1, r, 1, 0.3, 1, 0.35, 1, 14) for r in (1.5, 2.0)}
    table[1.0] = square
    strip = pr.clamped_orthotropic_plate(1, 8, 1, 0.3, 1, 0.35, 1, 20)
    off = {r: abs(v - pr.TIMOSHENKO_TABLE35[r]) for r, v in table.items()}
    print(
        f"square {square:.10f} ({square - pr.SQUARE_CLAMPED:+.1e}), beam modes "
        f"{_rel(beam, square):.1e}; table 35: {off}; 1/384: {_rel(strip, 1 / 384):.1e}"
    )
    assert abs(square - pr.SQUARE_CLAMPED) < 1e-8
    assert _rel(beam, square) < 2e-7
    assert max(off.values()) < 3e-5
    assert _rel(strip, 1 / 384) < 3e-8


def test_orthotropic_plate_two_bases_and_its_invariances():
    """D₁₁ = 4, D₂₂ = 1, D₁₂ = 0.25, D₆₆ = 0.4 on 1.5 × 1: the Legendre basis (14
    terms) and the clamped beam modes (40) agree within 1e-7 (reached 7.5e-9); the
    same H = D₁₂ + 2D₆₆ split otherwise gives the same deflection within 1e-14
    (reached 7.8e-16: clamped edges see H only); H = √(D₁₁D₂₂) on √2 × 1 maps to the
    isotropic square within 1e-14 (reached 8.9e-16).  Broke: the D66 term's 4 made 2 →
    the bases still agree (5.6e-9), the split differs by 0.041."""
    a, b, D11, D22, D12, D66 = 1.5, 1.0, 4.0, 1.0, 0.25, 0.4
    legendre = pr.clamped_orthotropic_plate(a, b, D11, D12, D22, D66, 1, 14)
    beam = pr.clamped_orthotropic_plate(a, b, D11, D12, D22, D66, 1, 40, "beam")
    split = pr.clamped_orthotropic_plate(a, b, D11, 0.85, D22, 0.1, 1, 14)
    mapped = pr.clamped_orthotropic_plate(np.sqrt(2), 1, 4, 1.0, 1, 0.5, 1, 14)
    square = pr.clamped_orthotropic_plate(1, 1, 1, 0.3, 1, 0.35, 1, 14)
    errors = _rel(beam, legendre), _rel(split, legendre), _rel(mapped, square)
    print("bases {:.1e}, split H {:.1e}, affine map {:.1e}".format(*errors))
    assert errors[0] < 1e-7 and errors[1] < 1e-14 and errors[2] < 1e-14


# ---------------------------------------------------------------- magnetic strip

LS, TB, LO, HI = 10.0, 0.1, 0.05, 0.2


def test_magnetic_strip_coefficient_against_nested_quadrature():
    """J = ∫ mt k / t³ dx (k = 1 and L − x) of a random 7-cell thickness against
    nested adaptive quadrature within 2e-15 (reached 2.2e-16), its gradient against
    central differences within 1e-9 (reached 8e-11); the piecewise-linear J of 9
    random node values (k = 1 and the chord d = 2.5's min(1, (L − x)/d), L − d a
    node) within 7e-15 (reached 6.7e-16), its gradient within 6e-9 (reached
    5.9e-10), the uniform strip's L²/(2t̄²) and ((L² − d²)/2 + d²/3)/t̄² within 2e-15
    (reached 2.2e-16).
    Broke: the cells' S_{i+1} made S_i → 0.19; the linear Q's last half-cell
    dropped → 0.0067."""
    rng = np.random.default_rng(1)
    t = rng.uniform(LO, HI, 7)
    pts = np.linspace(0, LS, 8)

    def tf(x):
        return t[min(int(x / LS * 7), 6)]

    def mt(x):
        return integrate.quad(tf, x, LS, points=[p for p in pts if x < p < LS], epsrel=1e-13)[0]

    quad, grads = [], []
    for kind, kernel in (("rotation", lambda x: 1.0), ("deflection", lambda x: LS - x)):
        q = integrate.quad(
            lambda x: mt(x) * kernel(x) / tf(x) ** 3, 0, LS, points=pts[1:-1], epsrel=1e-12
        )[0]
        quad.append(_rel(mr.magnetic_strip_coefficient(t, LS, kind), q))
        _, g = mr._strip_objective(t, LS, kind)
        e = np.eye(7)[3] * 1e-6
        fd = (
            mr.magnetic_strip_coefficient(t + e, LS, kind)
            - mr.magnetic_strip_coefficient(t - e, LS, kind)
        ) / 2e-6
        grads.append(_rel(g[3], fd))

    nodes = rng.uniform(LO, HI, 9)
    X = np.linspace(0, LS, 9)

    def mt_linear(x):
        return integrate.quad(
            lambda s: np.interp(s, X, nodes),
            x,
            LS,
            points=[p for p in X if x < p < LS],
            epsrel=1e-13,
        )[0]

    linear, linear_grads, uniform = [], [], []
    for chord in (0.0, 2.5):

        def kernel(x, chord=chord):
            return min(1.0, (LS - x) / chord) if chord else 1.0

        q = integrate.quad(
            lambda x: mt_linear(x) * kernel(x) / np.interp(x, X, nodes) ** 3,
            0,
            LS,
            points=X[1:-1],
            epsrel=1e-12,
        )[0]
        J, g = mr.magnetic_strip_linear_coefficient(nodes, LS, chord, grad=True)
        linear.append(_rel(J, q))
        e = np.eye(9)[4] * 1e-6
        fd = (
            mr.magnetic_strip_linear_coefficient(nodes + e, LS, chord)
            - mr.magnetic_strip_linear_coefficient(nodes - e, LS, chord)
        ) / 2e-6
        linear_grads.append(_rel(g[4], fd))
        uniform.append(
            _rel(
                mr.magnetic_strip_linear_coefficient(np.full(9, TB), LS, chord),
                ((LS**2 - chord**2) / 2 + chord**2 / 3) / TB**2,
            )
        )
    print(
        f"cells: quadrature {max(quad):.1e}, gradient {max(grads):.1e}; linear: "
        f"quadrature {max(linear):.1e}, gradient {max(linear_grads):.1e}, uniform "
        f"{max(uniform):.1e}"
    )
    assert max(quad) < 2e-15 and max(grads) < 1e-9
    assert max(linear) < 7e-15 and max(linear_grads) < 6e-9 and max(uniform) < 2e-15


def test_magnetic_strip_optimum_is_the_bang_bang_profile():
    """t = tmin on [0, a), tmax after, a = L (tmax − t̄)/(tmax − tmin): its closed-form
    coefficients equal the cells' J of that profile at n = 60 (a on an edge) within
    1e-14 (reached 1.1e-15); the uniform strip's L²/(2t̄²) and L³/(3t̄²) likewise.  The
    optimizer's optimum (tip rotation and deflection) at n = 60, 120, 240 is that
    profile and its value within 3e-14 (reached 3.8e-15), at n = 20, 40, 80 (a inside a
    cell) below it, the bound being global (the module's notes), every n at the mass
    within 3e-12 (reached 2.8e-13); at n = 20 no start of 40 random ones ends above
    it (within 2e-12, reached 1.5e-13), and at n = 60 the first variation on the tmin
    part is below that on the tmax part (a multiplier between).  Broke: a = L (t̄ −
    tmin)/(tmax − tmin) → the n = 60 optimum is not that profile (a wrong gradient,
    −3 made −2, still ends there: the gradient is the previous test's)."""
    a, rot, defl = mr.bang_bang_coefficients(LS, TB, LO, HI)
    bang = np.where((np.arange(60) + 0.5) * LS / 60 < a, LO, HI)
    closed = [
        _rel(mr.magnetic_strip_coefficient(bang, LS, "rotation"), rot),
        _rel(mr.magnetic_strip_coefficient(bang, LS, "deflection"), defl),
        _rel(
            mr.magnetic_strip_coefficient(np.full(13, TB), LS, "rotation"),
            mr.uniform_strip_rotation_coefficient(LS, TB),
        ),
        _rel(
            mr.magnetic_strip_coefficient(np.full(13, TB), LS, "deflection"),
            mr.uniform_strip_deflection_coefficient(LS, TB),
        ),
    ]
    print(f"closed forms {max(closed):.1e}")
    assert max(closed) < 1e-14
    rng = np.random.default_rng(7)
    for kind, optimum, bound in (
        ("rotation", mr.magnetic_strip_thickness_optimum, rot),
        ("deflection", mr.magnetic_strip_deflection_optimum, defl),
    ):
        found = {n: optimum(LS, TB, LO, HI, n) for n in (20, 40, 80, 60, 120, 240)}
        reached = []
        for n in (60, 120, 240):
            t, J = found[n]
            x = (np.arange(n) + 0.5) * LS / n
            assert np.allclose(t, np.where(x < a, LO, HI), rtol=1e-6, atol=0), (kind, n)
            reached.append(_rel(J, bound))
        coarse = [found[n][1] / bound - 1 for n in (20, 40, 80)]
        mass = max(abs(t.mean() / TB - 1) for t, _ in found.values())
        ends = []
        for _ in range(40):
            u = rng.uniform(LO, HI, 20) / TB
            v = mr._slsqp(LS, TB, LO, HI, kind, u).x * TB
            if abs(v.mean() - TB) < 1e-10 and v.min() > LO - 1e-12 and v.max() < HI + 1e-12:
                ends.append(mr.magnetic_strip_coefficient(v, LS, kind))
        t = found[60][0]
        g = mr._strip_objective(t, LS, kind)[1]
        thin, thick = np.isclose(t, LO), np.isclose(t, HI)
        print(
            f"{kind}: n = 60, 120, 240 {', '.join(f'{r:.1e}' for r in reached)}; "
            f"n = 20, 40, 80 {', '.join(f'{c:+.1e}' for c in coarse)}; random starts "
            f"{len(ends)}, best {max(ends) / found[20][1] - 1:+.1e}; g {g[thin].max():.4g} "
            f"< {g[thick].min():.4g}; mass {mass:.1e}"
        )
        assert max(reached) < 3e-14
        assert max(coarse) < -1e-3 and mass < 3e-12
        assert len(ends) > 30 and max(ends) < found[20][1] * (1 + 2e-12)
        assert np.all(thin | thick) and g[thin].max() < g[thick].min()


def test_piecewise_linear_optimum_is_the_best_single_ramp():
    """Piecewise-linear t on 21 nodes (k = 1 and the chord 0.5 of
    test_thickness_design): the optimizer's profile and J against a search of the
    one-parameter family tmin | one intermediate node | tmax (its value fixed by the
    mass): J within 3e-11 (reached 2.8e-12), the profile within 2e-10 (reached
    1.5e-11), below the bang-bang bound (chord 0).
    Broke: the optimizer's mean by n equal weights (not the trapezoid) → 0.018."""
    n = 21
    c = np.r_[0.5, np.ones(n - 2), 0.5] / (n - 1)
    for chord in (0.0, 0.5):
        t, J = mr.magnetic_strip_piecewise_linear_optimum(LS, TB, LO, HI, n, chord=chord)
        family = []
        for i in range(1, n - 1):
            v = np.r_[np.full(i, LO), 0.0, np.full(n - i - 1, HI)]
            v[i] = (TB - c @ v) / c[i]
            if LO <= v[i] <= HI:
                family.append((mr.magnetic_strip_linear_coefficient(v, LS, chord), v))
        best, v = max(family, key=lambda p: p[0])
        print(
            f"chord {chord}: optimum {J:.10g}, single ramp {best:.10g} "
            f"({J / best - 1:+.1e}), profiles {np.abs(t - v).max():.1e}"
        )
        assert abs(J / best - 1) < 3e-11 and np.abs(t - v).max() < 2e-10
        if not chord:
            assert J < mr.bang_bang_coefficients(LS, TB, LO, HI)[1]
