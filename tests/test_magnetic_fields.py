"""Magnetic actuation beyond the paper's protocols (docs/model.md §5.5): formulas,
magnetization profiles, field waveforms and nonuniform fields, each against an
exact or independent answer.

- formulas: the parser's values against Python's own arithmetic, its errors one line;
- time tables: a table field equals the same field given as a formula;
- a point dipole: force and couple on a small magnetized plate against the closed-form
  dipole-dipole force and torque;
- gradient force: a stiff plate in a uniform-gradient field drifts at force over drag;
- tangents: Taylor remainders of order 2.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import build_model, run_scene, write_scene

from rftfem.errors import SceneError
from rftfem.model.magnetic_sources import TimeTable
from rftfem.scene.expressions import parse

# ------------------------------------------------------------------ formulas


@pytest.mark.parametrize(
    "text, expected",
    [
        ("1 + 2*3", 7.0),
        ("-2^2", -4.0),  # the power binds tighter than the sign
        ("2^3^2", 2.0**9),  # and is right-associative
        ("(1 + 2)*3 / 4", 2.25),
        ("sin(pi/6) + cos(0) + tan(pi/4)", 0.5 + 1 + 1),
        ("atan2(1, -1) + asin(1) + acos(1) + atan(1)", 3 * math.pi / 4 + math.pi / 2 + math.pi / 4),
        ("exp(log(3)) + sqrt(16) + abs(-2)", 3 + 4 + 2),
        ("min(3, 1, 2) + max(-1, -4)", 1 - 1),
        ("2.5e-3*1E3 + .5", 3.0),
    ],
)
def test_formula_values(text, expected):
    f = parse(text, "k", ())
    assert f.constant and f.value() == pytest.approx(expected, rel=1e-15, abs=1e-15)


def test_formula_of_variables_on_arrays():
    X = np.linspace(0.0, 3.7, 7)
    f = parse("62.9*cos(2*pi*X/3.7) - Y^2", "k", ("X", "Y", "Z"))
    assert f.names == {"X", "Y"}
    got = f.numbers({"X": X, "Y": 0.5})
    assert np.allclose(got, 62.9 * np.cos(2 * np.pi * X / 3.7) - 0.25, rtol=0, atol=1e-13)


@pytest.mark.parametrize(
    "text, words",
    [
        ("2*X +", ["unexpected end", "position 6"]),
        ("2**X", ["'^'", "position 3"]),
        ("sinh(X)", ["unknown function 'sinh'", "position 1"]),
        ("x + 1", ["variable 'x' is not allowed here", "X, Y, Z"]),
        ("foo", ["unknown name 'foo'"]),
        ("atan2(X)", ["atan2() takes 2 arguments"]),
        ("(X + 1", ["expected ')'"]),
        ("X $ 2", ["unexpected character '$'", "position 3"]),
        # a part without a variable that has no value: typically a parameter set to 0
        ("cos(2*pi*X/(0.0))", ["divides by zero", "/ 0.0)"]),
        ("1/(2 - 2)", ["without a finite value"]),
        ("X + log(0)", ["without a finite value", "log(0.0)"]),
        ("X*(-8)^(1/3)", ["without a finite value"]),
    ],
)
def test_bad_formulas_say_where(text, words):
    with pytest.raises(SceneError) as e:
        parse(text, "magnetic.parts.0.magnetization", ("X", "Y", "Z"))
    msg = str(e.value)
    assert "\n" not in msg and msg.startswith("magnetic.parts.0.magnetization: ")
    for w in words:
        assert w in msg, msg


def test_a_formula_without_a_value_at_a_time_names_its_key():
    f = parse("2e-6/t", "magnetic.field.B.0", ("t",))
    assert f.numbers({"t": 0.5}) == pytest.approx(4e-6, rel=1e-15)
    with pytest.raises(SceneError) as e:
        f.numbers({"t": 0.0})
    msg = str(e.value)
    assert msg.startswith("magnetic.field.B.0: '2e-6/t' has no value at t = 0"), msg


# ------------------------------------------------------------------ time tables


def test_cubic_table_reproduces_a_cubic_and_linear_a_line():
    """A not-a-knot spline through samples of a cubic polynomial is that polynomial;
    linear interpolation of a line is that line (both to round-off, reached 1e-16)."""
    t = np.array([0.0, 0.3, 0.5, 1.1, 1.6, 2.0])
    cubic = lambda s: np.stack([1 - 2 * s + 0.5 * s**3, 3 * s**2 - s**3, 0 * s + 2], -1)
    line = lambda s: np.stack([1 - 2 * s, 3 * s, 0 * s + 2], -1)
    tc, tl = TimeTable(t, cubic(t), "cubic"), TimeTable(t, line(t), "linear")
    s = np.linspace(0.0, 2.0, 41)
    assert np.abs(np.array([tc(x) for x in s]) - cubic(s)).max() < 1e-13
    assert np.abs(np.array([tl(x) for x in s]) - line(s)).max() < 1e-14
    assert np.array_equal(tc(-1.0), cubic(t[:1])[0]) and np.array_equal(tc(3.0), cubic(t[-1:])[0])


STRIP = """
title = "a clamped magnetic strip in a time-dependent uniform field"
[mesh]
kind = "strip"
length = 4.0
width = 1.0
divisions = [4, 1]
[shell]
thickness = 0.1
E = 50.0
nu = 0.3
[fluid]
drag = [1.0, 1.0, 2.0]
[time]
scheme = "backward-euler"
dt = 0.05
end = 0.5
[[boundary]]
where = "x=0"
fix = ["clamped"]
[[magnetic.parts]]
region = "all"
magnetization = 1.0
direction = [1.0, 0.0, 0.0]
[[output.probes]]
name = "tip"
at = [4.0, 0.5, 0.0]
"""


def test_table_field_equals_the_formula_field(tmp_path):
    """The same field, B_z = 0.4 t (1 + t) (2 − t) and B_y = 0.1 − 0.2 t, as formulas of t
    and as a cubic table of six rows: the strip's tip history is the same to round-off
    (reached 0); through a linear table it is not."""
    formula = STRIP + (
        '[magnetic.field]\nkind = "expression"\nB = ["0", "0.1 - 0.2*t", "0.4*t*(1 + t)*(2 - t)"]\n'
    )
    ts = [0.0, 0.1, 0.2, 0.35, 0.45, 0.6]
    rows = [[t, 0.0, 0.1 - 0.2 * t, 0.4 * t * (1 + t) * (2 - t)] for t in ts]
    table = STRIP + f'[magnetic.field]\nkind = "table"\nvalues = {rows}\ninterpolation = "cubic"\n'
    a = run_scene(write_scene(tmp_path, formula, "formula.toml"))
    b = run_scene(write_scene(tmp_path, table, "table.toml"))
    c = run_scene(write_scene(tmp_path, table.replace('"cubic"', '"linear"'), "linear.toml"))
    ha, hb, hc = (np.array([row[1][0] for row in s.history]) for s in (a, b, c))
    scale = np.abs(ha).max()
    print(
        f"tip: formula vs cubic table {np.abs(hb - ha).max() / scale:.1e}, vs linear "
        f"table {np.abs(hc - ha).max() / scale:.1e} of the largest displacement {scale:.3f}"
    )
    assert scale > 0.02  # the field bends the strip
    assert np.abs(hb - ha).max() <= 1e-12 * scale
    assert np.abs(hc - ha).max() > 1e-4 * scale


# ------------------------------------------------------------------ a point dipole

PLATE_A, PLATE_T, PLATE_M = 0.01, 0.001, 50.0

PLATE = f"""
title = "a small magnetized plate near a point dipole"
[mesh]
kind = "strip"
length = {PLATE_A}
width = {PLATE_A}
divisions = [2, 2]
[shell]
thickness = {PLATE_T}
E = 1.0e3
nu = 0.3
[time]
scheme = "backward-euler"
dt = 0.01
end = 0.1
[[magnetic.parts]]
region = "all"
magnetization = {PLATE_M}
direction = [1.0, 0.0, 0.0]
[magnetic.field]
kind = "dipole"
moment = [0.0, 0.0, 1.0]
position = [0.0, 0.0, 5.0]
"""


def dipole_field(m_s, p, x):
    r = x - p
    d = np.linalg.norm(r)
    return 1e-7 * (3 * r * (m_s @ r) / d**5 - m_s / d**3)


def dipole_force(m1, x1, m_s, p):
    """Force on the dipole m1 at x1 in the field of m_s at p (textbook closed form)."""
    r = x1 - p
    d = np.linalg.norm(r)
    n = r / d
    return (
        3e-7
        / d**4
        * (m1 * (m_s @ n) + m_s * (m1 @ n) + n * (m1 @ m_s) - 5 * n * (m1 @ n) * (m_s @ n))
    )


@pytest.fixture(scope="module")
def plate_model(tmp_path_factory):
    return build_model(PLATE, tmp_path_factory.mktemp("dipole"), compile_forms=True)


def magnetic_residual(model) -> np.ndarray:
    from test_consistency import vector_of

    return vector_of(model, model.mapped(model.effects["magnetic"]))()


@pytest.mark.parametrize("source", [(1.0, 0.0, 0.0), (0.6, 0.0, 0.8), (-0.3, 0.5, 0.2)])
@pytest.mark.parametrize("distance", [0.5, 1.0, 2.0])
def test_dipole_force_and_couple_on_a_small_plate(plate_model, source, distance):
    """The plate (side a = 0.01, moment m₁ = t m a² along X) at distance d from a source
    dipole of moment m_s = (0.3, −0.5, 1.2): the total force −Σ R_u and the couple
    about the plate's centre −Σ (X − c) × R_u of the assembled virtual work (the
    magnetization is in the plane, so only the displacements carry it) against the
    closed forms ∇(m₁·B) and m₁ × B at the centre.  The plate's size makes them differ
    by O((a/d)²): reached at most 1.3 (a/d)² (couple, d = 0.5), falling 4× per doubled d."""
    model = plate_model
    effect = model["magnetic"]
    c = np.array([PLATE_A / 2, PLATE_A / 2, 0.0])
    direction = np.array(source) / np.linalg.norm(source)
    p = c + distance * direction
    m_s = np.array([0.3, -0.5, 1.2])
    # the source's position and moment are Constants of the compiled form
    effect.source.position_constant.value[:] = p
    effect.source.moment_constant.value[:] = m_s
    R = magnetic_residual(model)
    Ru = R[model.u_dofs].reshape(-1, 3)
    X = model.Vu.tabulate_dof_coordinates()
    force = -Ru.sum(axis=0)
    couple = -np.cross(X - c, Ru).sum(axis=0)
    m1 = PLATE_T * PLATE_M * PLATE_A**2 * np.array([1.0, 0.0, 0.0])
    F_exact = dipole_force(m1, c, m_s, p)
    T_exact = np.cross(m1, dipole_field(m_s, p, c))
    ef = np.linalg.norm(force - F_exact) / np.linalg.norm(F_exact)
    et = np.linalg.norm(couple - T_exact) / np.linalg.norm(T_exact)
    print(
        f"d = {distance}, direction {np.round(direction, 3)}: force {force}, exact "
        f"{F_exact}, error {ef:.1e}; couple error {et:.1e}"
    )
    assert ef < 13 * (PLATE_A / distance) ** 2
    assert et < 13 * (PLATE_A / distance) ** 2


@pytest.mark.parametrize("distance", [0.7, 4.5e61, 1e110, 1e200])
def test_a_far_dipole_gives_a_small_field_not_nan(distance):
    """The source's own field (numpy: scales, probes) at a distance d along a tilted
    direction: the closed form within 1e-15 where d³ is a float (the fuzzer put a
    magnet's path 4.5e61 away, where the old ``r⁵`` overflowed to inf/inf), exactly 0
    beyond, and no floating-point warning.  Broke: the old 3 r (r·m)/r⁵ − m/r³ → nan
    and an overflow warning at 4.5e61 and beyond."""
    import warnings

    from rftfem.model.magnetic_sources import dipole_field as source_field

    m_s = np.array([0.3, -0.5, 1.2])
    n = np.array([0.6, 0.0, 0.8])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        B = source_field(distance * n[None, :], m_s)[0]
    exact = 1e-7 * (3 * n * (n @ m_s) - m_s) / distance**3 if distance < 5e102 else 0.0
    print(f"d = {distance:.3g}: B = {B}, exact {exact}")
    assert np.all(np.isfinite(B))
    if distance < 5e102:
        assert np.abs(B - exact).max() < 1e-15 * np.abs(exact).max()
    else:
        assert np.all(B == 0.0)


# ------------------------------------------------------------------ gradient force

GRADIENT_PLATE = """
title = "a stiff magnetized plate in a field gradient"
[mesh]
kind = "strip"
length = 1.0
width = 1.0
divisions = [2, 2]
[shell]
thickness = 0.1
E = 1.0e8
nu = 0.3
[[magnetic.parts]]
region = "all"
magnetization = 2.0
direction = [1.0, 0.0, 0.0]
[[output.probes]]
name = "centre"
at = [0.5, 0.5, 0.0]
"""


def test_uniform_gradient_drifts_the_plate_at_force_over_drag(tmp_path):
    """B = G (x, −(y − ½), 0), free of divergence and curl: on the plate magnetized
    along X it pulls with t m G A along X everywhere (the couple density is odd about
    the centre line, and nothing turns).  Without inertia the drag balances it at
    once: from the t = 0 state (the reference: the field, on at t = 0, acts from the
    first step on, docs/model.md §6.7) the plate moves at v = t m G A / (C₁ A) (reached:
    relative 2e-9 in x, the plate's strain under its
    couple density at E = 1e8; the rest round-off)."""
    G, C1 = 0.5, 0.4
    text = (
        GRADIENT_PLATE
        + f"""
[fluid]
drag = [{C1}, 0.7, 1.3]
[time]
scheme = "backward-euler"
dt = 0.1
end = 1.0
[magnetic.field]
kind = "expression"
B = ["{G}*x", "-{G}*(y - 0.5)", "0"]
[solver]
snes_atol = 1e-14
"""
    )
    sim = run_scene(write_scene(tmp_path, text))
    assert sim.summary["active_effects"] == [
        "elasticity",
        "drag",
        "magnetic",
        "magnetic field: expression",
        "magnetic gradient force",
    ]
    v = 0.1 * 2.0 * G / C1
    t = np.array([row[0] for row in sim.history])
    u = np.array([row[1][0] for row in sim.history])
    assert np.abs(u[0]).max() == 0.0
    err = np.abs(u[:, 0] - v * t).max() / (v * t[-1])
    side = np.abs(u[:, 1:]).max() / (v * t[-1])
    print(
        f"drift: u_x {u[-1, 0]:.12f} against v t = {v * t[-1]:.12f} (error {err:.1e}); "
        f"largest u_y, u_z {side:.1e} of it"
    )
    assert err < 2e-8 and side < 1e-12


def test_gradient_force_in_vacuum_at_each_scheme_order(tmp_path):
    """A potential field B = K((x−c)² − η², −2(x−c)η, 0), η = y − ½, whose centre moves,
    c(t) = ½ + A sin Ωt, K < 0: the plate's centre obeys x'' = −ω² (x − c(t)),
    ω² = −2 m K / ρ, started at rest where the force is zero.  Exact:
    x − ½ = A ω²/(ω² − Ω²) (sin Ωt − (Ω/ω) sin ωt).  The error at t = 2π/ω, at steps of
    T/16 and T/32, falls as the scheme's order, 2 for generalized-α and HHT (the
    schemes with inertia; backward Euler drops it)."""
    K, rho, m, A, Om = -0.5, 2.0, 2.0, 0.1, 0.7
    omega = math.sqrt(-2 * m * K / rho)
    end = 2 * math.pi / omega
    text = (
        GRADIENT_PLATE.replace("nu = 0.3", f"nu = 0.3\ndensity = {rho}")
        + f"""
[time]
scheme = "backward-euler"
dt = 0.1
end = {end!r}
[magnetic.field]
kind = "expression"
B = ["{K}*((x - 0.5 - {A}*sin({Om}*t))^2 - (y - 0.5)^2)",
     "-2*{K}*(x - 0.5 - {A}*sin({Om}*t))*(y - 0.5)", "0"]
"""
    )
    scene = write_scene(tmp_path, text)
    exact = (
        A
        * omega**2
        / (omega**2 - Om**2)
        * (math.sin(Om * end) - Om / omega * math.sin(omega * end))
    )
    for scheme, expected in (("generalized-alpha", 2), ("hht", 2)):
        errors = []
        for n in (16, 32):
            sim = run_scene(scene, f'time.scheme="{scheme}"', f"time.dt={end / n!r}")
            t, u = sim.history[-1][0], sim.history[-1][1][0]
            assert abs(t - end) < 1e-9
            errors.append(abs(u[0] - exact) / A)
        order = math.log2(errors[0] / errors[1])
        print(
            f"{scheme}: centre {u[0]:.6f} against {exact:.6f}; error {errors[0]:.2e} (T/16), "
            f"{errors[1]:.2e} (T/32) of A, order {order:.2f}"
        )
        assert abs(order - expected) < 0.25, (scheme, order)


# ---------------------------------------------- a cantilever with a sinusoidal profile

PROFILE_L, PROFILE_EI = 10.0, 1.0
PROFILE_STRIP = f"""
title = "a cantilever magnetized along a turning direction, in a uniform field along Z"
[mesh]
kind = "strip"
length = {PROFILE_L}
width = 1.0
divisions = [20, 1]
[shell]
thickness = 0.1
E = {12 * PROFILE_EI / 0.1**3!r}
nu = 0.0
[time]
scheme = "static"
dt = 0.125
end = 1.0
[[boundary]]
where = "x=0"
fix = ["clamped"]
[[magnetic.parts]]
region = "all"
magnetization = 1.0
direction = ["cos(2*pi*X/{PROFILE_L})", "0", "sin(2*pi*X/{PROFILE_L})"]
[magnetic.field]
kind = "rotating"
direction = [0.0, 0.0, 1.0]
ramp_time = 1.0
[[output.probes]]
name = "tip"
at = [{PROFILE_L}, 0.5, 0.0]
"""


def magneto_elastica(c_over_EI: float, k: float, L: float, n: int = 4000):
    """The clamped-free magneto-elastica by shooting: φ'' = −(c/EI) cos(k s + φ),
    φ(0) = 0, φ'(L) = 0 (φ the tangent's angle from X towards Z; the couple per length
    c cos(ks + φ) turns the fibre q = (cos(ks + φ), 0, sin(ks + φ)) towards B = b e_z,
    c = t W m b).  RK4 on n steps; the secant method on φ'(0).  Returns the tip's
    displacement (x(L) − L, z(L))."""
    h = L / n

    def shoot(kappa0):
        y = np.array([0.0, kappa0, 0.0, 0.0])  # φ, φ', x, z

        def f(s, y):
            return np.array(
                [y[1], -c_over_EI * math.cos(k * s + y[0]), math.cos(y[0]), math.sin(y[0])]
            )

        s = 0.0
        for _ in range(n):
            k1 = f(s, y)
            k2 = f(s + h / 2, y + h / 2 * k1)
            k3 = f(s + h / 2, y + h / 2 * k2)
            k4 = f(s + h, y + h * k3)
            y = y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
            s += h
        return y

    a, b = 0.0, 0.1 * c_over_EI
    fa, fb = shoot(a)[1], shoot(b)[1]
    for _ in range(60):
        a, b, fa = b, b - fb * (b - a) / (fb - fa), fb
        fb = shoot(b)[1]
        if abs(fb) < 1e-14:
            break
    y = shoot(b)
    return np.array([y[2] - L, y[3]])


@pytest.mark.parametrize("strength, tol", [(1e-4, 6e-4), (2.0, 9e-4)])
def test_cantilever_with_a_sinusoidal_profile(tmp_path, strength, tol):
    """q₀(X) = (cos kX, 0, sin kX), k = 2π/L, in B = b e_z ramped up in eight load steps,
    EI = 1, ν = 0, 20 cells.  Small field (b = 1e-4): the tip deflects by
    w = −c L /(EI k²), c = t W m b (the beam with the distributed couple c cos kX,
    closed form).  Large field (b = 2: the tip ends behind the clamp, at x = −0.05):
    the tip against the shooting solution of the magneto-elastica (independent of the
    FE model).  Reached: 6.3e-5 and 8.5e-5 of the tip's displacement."""
    k = 2 * math.pi / PROFILE_L
    c = 0.1 * 1.0 * 1.0 * strength
    text = PROFILE_STRIP.replace("ramp_time = 1.0", f"ramp_time = 1.0\nstrength = {strength!r}")
    sim = run_scene(write_scene(tmp_path, text))
    assert "magnetization profile" in sim.summary["active_effects"]
    u = sim.history[-1][1][0]
    if strength < 1e-3:
        exact = np.array([0.0, -c * PROFILE_L / (PROFILE_EI * k**2)])
        scale = abs(exact[1])
    else:
        exact = magneto_elastica(c / PROFILE_EI, k, PROFILE_L)
        scale = np.linalg.norm(exact)
    error = np.linalg.norm(u[[0, 2]] - exact) / scale
    print(
        f"b = {strength}: tip (u_x, u_z) = {u[[0, 2]]}, exact {exact}, error {error:.1e} "
        f"of |u|; u_y {u[1]:.1e}"
    )
    assert error < tol
    assert abs(u[1]) < 1e-9 * scale


# ------------------------------------------------------------------ tangents

TAYLOR_STRIP = """
title = "a random state of a strip with a varying magnetization in a nonuniform field"
[mesh]
kind = "strip"
length = 4.0
width = 1.0
divisions = [4, 2]
[shell]
thickness = 0.1
E = 10.0
nu = 0.3
[time]
scheme = "static"
dt = 0.1
end = 1.0
[[boundary]]
where = "x=0"
fix = ["clamped"]
[[magnetic.parts]]
region = "all"
magnetization = "1 + 0.5*sin(X)"
direction = ["cos(2*X)", "0.3", "sin(2*X) + 0.2*Y"]
"""

TAYLOR_FIELDS = {
    "expression": '[magnetic.field]\nkind = "expression"\n'
    'B = ["0.3*x*z + t", "0.2*y^2 - 0.1*x", "0.5 + 0.4*sin(x)*cos(z)"]\n',
    "dipole": '[magnetic.field]\nkind = "dipole"\nmoment = [5.0, -3.0, 8.0]\n'
    "path = [[0.0, 2.0, 0.5, 2.0], [1.0, 1.0, 0.0, 1.5]]\n",
    "uniform": '[magnetic.field]\nkind = "expression"\nB = ["0.5*sin(t)", "0.2", "1 - t"]\n',
}


@pytest.mark.long
@pytest.mark.both_stacks
@pytest.mark.parametrize("field", list(TAYLOR_FIELDS))
def test_magnetic_terms_taylor_remainder(tmp_path, field):
    """The magnetic term alone, at a random rotated state (the field at t = 0.5):
    formulas of X, Y, Z in the magnetization, with a nonuniform expression field, a
    moving dipole, and a uniform waveform.  Its ``ufl.derivative`` Jacobian leaves a
    Taylor remainder falling as ε² (orders ≥ 1.9; reached 2.00)."""
    from test_consistency import _random_state, term_taylor

    model = build_model(TAYLOR_STRIP + TAYLOR_FIELDS[field], tmp_path, compile_forms=False)
    model.set_time(0.5)
    rng = np.random.default_rng(11)
    w0 = _random_state(model, rng, 0.4)
    delta = rng.uniform(-1, 1, len(w0))
    orders, rem, r0, jd = term_taylor(model, model.effects["magnetic"], w0, delta)
    print(f"{field}: |R| {np.linalg.norm(r0):.3e}, remainders {rem}, orders {orders}")
    assert np.linalg.norm(jd) > 0 and orders.min() >= 1.9


# ------------------------------------------------------------------ profiles, ranks, input


def _profile_scene(tmp_path, part: str):
    text = STRIP.replace(
        """magnetization = 1.0
direction = [1.0, 0.0, 0.0]""",
        part,
    ) + ('[magnetic.field]\nkind = "expression"\nB = ["0", "0.3*t", "0.6*t"]\n')
    return write_scene(tmp_path, text, f"scene{abs(hash(part)) % 10**6}.toml")


def _write_profile(path, xs, ys, m):
    rows = ["X,Y,Z,mx,my,mz"] + [
        ",".join(repr(float(v)) for v in (x, y, 0.0, *m(x))) for x in xs for y in ys
    ]
    path.write_text("\n".join(rows) + "\n")


def test_profile_file_equals_the_formulas(tmp_path):
    """A profile file of M = (1 + 0.1 X, 0, 0.5) on a 9 × 2 grid against the same
    magnetization as formulas of X: the file is interpolated (multilinear) to the P1
    nodes, exact for a linear M, so the tips agree to round-off (reached 3e-15)."""
    _write_profile(
        tmp_path / "m.csv", np.linspace(0, 4, 9), [0.0, 1.0], lambda x: (1 + 0.1 * x, 0.0, 0.5)
    )
    a = run_scene(_profile_scene(tmp_path, 'profile = "m.csv"'))
    b = run_scene(
        _profile_scene(
            tmp_path,
            'magnetization = "sqrt((1 + 0.1*X)^2 + 0.25)"\ndirection = ["1 + 0.1*X", "0", "0.5"]',
        )
    )
    ha, hb = (np.array([row[1][0] for row in s.history]) for s in (a, b))
    scale = np.abs(ha).max()
    print(f"profile file vs formulas: {np.abs(ha - hb).max() / scale:.1e} of {scale:.3f}")
    assert scale > 0.01 and np.abs(ha - hb).max() < 1e-12 * scale


@pytest.mark.mpi
def test_two_processes_match_serial(tmp_path, cli_run):
    """A varying magnetization (formulas) in a moving dipole's field, under
    ``mpirun -n 2``: the probe history equals the serial one to 1e-10 of its
    largest displacement (reached 1e-14)."""
    text = (
        TAYLOR_STRIP.replace('scheme = "static"', 'scheme = "backward-euler"')
        + '[fluid]\ndrag = [1.0, 1.0, 2.0]\n[[output.probes]]\nname = "tip"\n'
        + "at = [4.0, 0.5, 0.0]\n"
        + TAYLOR_FIELDS["dipole"].replace("moment = [5.0, -3.0, 8.0]", "moment = [5e6, -3e6, 8e6]")
    )
    scene = write_scene(tmp_path, text)
    tables = [
        np.loadtxt(
            cli_run(scene, tmp_path / f"np{n}", ["time.end=0.3"], np=n) / "probes.csv",
            delimiter=",",
            skiprows=1,
        )
        for n in (1, 2)
    ]
    scale = np.abs(tables[0][:, 1:]).max()
    worst = np.abs(tables[1] - tables[0]).max() / scale
    print(f"mpirun -n 2 vs serial: {worst:.1e} of the largest tip displacement {scale:.3f}")
    assert scale > 1e-3 and worst < 1e-10


def _one_line_exit_2(args, *words):
    import subprocess
    import sys

    from conftest import ROOT

    done = subprocess.run(
        [sys.executable, "-m", "rftfem", *map(str, args)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=600,
    )
    lines = done.stderr.strip().splitlines()
    assert done.returncode == 2 and len(lines) == 1, (done.returncode, done.stderr)
    for w in words:
        assert w in lines[0], lines[0]
    return lines[0]


def _scene_error(tmp_path, text, *sets, build=False) -> str:
    """The SceneError of loading (``build``: and building the model of) a scene: one line."""
    from rftfem.scene.reading import load_scene

    with pytest.raises(SceneError) as e:
        if build:
            build_model(text, tmp_path, sets)
        else:
            load_scene(write_scene(tmp_path, text), list(sets))
    msg = str(e.value)
    assert "\n" not in msg, msg
    return msg


def test_bad_magnetic_input_is_one_line_exit_2(tmp_path):
    """Bad formulas, tables, profile files and a dipole inside the body: one line
    naming the key (in process); through the command line, exit 2 with that line."""
    text = TAYLOR_STRIP + TAYLOR_FIELDS["expression"]
    for sets, words in (
        (['magnetic.field.B=["x", "q", "0"]'], ["magnetic.field.B.1", "unknown name 'q'"]),
        (
            ['magnetic.parts.0.direction=["X", "0", "t"]'],
            ["magnetic.parts.0.direction.2", "variable 't' is not allowed"],
        ),
        (["magnetic.field.values=[[0, 1, 2, 3]]"], ["magnetic.field.values", 'kind = "table"']),
        (
            ['magnetic.field.kind="table"', 'magnetic.field.B=["0","0","1"]'],
            ["magnetic.field.B", '"expression"'],
        ),
        (['magnetic.field.kind="dipole"', "magnetic.field.B=[0,0,1]"], ["magnetic.field.B"]),
    ):
        msg = _scene_error(tmp_path, text, *sets)
        assert all(w in msg for w in words), msg
    msg = _scene_error(
        tmp_path, TAYLOR_STRIP + '[magnetic.field]\nkind = "dipole"\nmoment = [0.0, 0.0, 1.0]\n'
    )
    assert "'position' (fixed) and 'path'" in msg and "neither" in msg, msg
    # a profile grid with a hole, one that does not reach the body's end, none at all
    _write_profile(tmp_path / "m.csv", np.linspace(0, 4, 5), [0.0, 1.0], lambda x: (1.0, 0.0, 0.0))
    lines = (tmp_path / "m.csv").read_text().splitlines()
    (tmp_path / "hole.csv").write_text("\n".join(lines[:4] + lines[5:]) + "\n")
    _write_profile(
        tmp_path / "short.csv", np.linspace(0, 3, 4), [0.0, 1.0], lambda x: (1.0, 0.0, 0.0)
    )
    for name, words in (
        ("hole.csv", ["magnetic.parts.0.profile", "missing"]),
        ("short.csv", ["magnetic.parts.0.profile", "does not cover"]),
        ("none.csv", ["magnetic.parts.0.profile", "cannot read"]),
    ):
        profiled = TAYLOR_STRIP.replace(
            """magnetization = "1 + 0.5*sin(X)"
direction = ["cos(2*X)", "0.3", "sin(2*X) + 0.2*Y"]""",
            f'profile = "{name}"',
        )
        msg = _scene_error(tmp_path, profiled + TAYLOR_FIELDS["uniform"], build=True)
        assert all(w in msg for w in words), msg
    # the command line: exit 2 and the one line, at check and at run
    scene = write_scene(tmp_path, text)
    _one_line_exit_2(
        ["check", scene, "--set", 'magnetic.parts.0.magnetization="1 + sin(X"'],
        "magnetic.parts.0.magnetization",
        "expected ')'",
    )
    dipole = write_scene(
        tmp_path,
        TAYLOR_STRIP + '[magnetic.field]\nkind = "dipole"\n'
        "moment = [0.0, 0.0, 1.0]\nposition = [2.0, 0.5, 0.05]\n",
        "in.toml",
    )
    _one_line_exit_2(
        ["run", dipole, "--out", tmp_path / "in"], "magnetic.field.position", "inside the body"
    )


# --------------------------------------- the energy path against the uniform couple


@pytest.mark.parametrize("stretch, tilt", [(1.0, 0.0), (1.0, 0.7), (1.3, 0.0), (1.3, 0.7)])
def test_zero_gradient_energy_path_against_the_uniform_couple(tmp_path, stretch, tilt):
    """The same constant field b written as formulas of x, y, z with no gradient
    (``0*x`` terms make them "nonuniform") takes the energy path Π = −∫ t (F M)·B dA₀.
    On test_magnetic.py's plate, stretched by λ along X and turned by ψ about X,
    magnetized out of its plane along q₀ = (cos φ, 0, sin φ), a virtual rigid
    rotation δφ of the whole plate takes from the energy path's residual exactly
    −t m |F q₀| A (q × b)·δφ, where the uniform couple's takes −t m J A (q × b)·δφ
    (J = λ): the two agree to round-off under a rigid turn (λ = 1), and under stretch
    differ by the factor |F q₀| / J = √(λ² cos²φ + sin²φ) / λ that docs/model.md §5.5
    predicts (the membrane strain along q₀).  Checked to 5e-15 of t m A |b| for δφ
    along X, Y, Z (reached 5e-16); the turn alone would hide a lost J, the stretch alone a lost
    director part of F."""
    from test_magnetic import TILTED, turned_plate_works

    phi = math.radians(40.0)
    b = 0.7 * np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    uniform = TILTED.format(q0x=math.cos(phi), q0z=math.sin(phi))
    formulas = ", ".join(f'"{float(v)!r} + 0*x + 0*y*z"' for v in b)
    energy = uniform.replace(
        "strength = 0.7\ndirection = [0.3, -0.5, 0.8]", f'kind = "expression"\nB = [{formulas}]'
    )
    works = {}
    for name, text in (("uniform", uniform), ("energy", energy)):
        (tmp_path / name).mkdir()
        model = build_model(text, tmp_path / name, compile_forms=False)
        assert model["magnetic"].uniform == (name == "uniform")
        model.set_time(1.0)
        works[name], R = turned_plate_works(model, stretch, tilt)
    q_unnormed = R @ np.array([stretch * math.cos(phi), 0.0, math.sin(phi)])
    length = np.linalg.norm(q_unnormed)
    q = q_unnormed / length
    t, m, area = 0.1, 3.0, 2.0
    couple = np.cross(q, b)
    exact = {"uniform": -t * m * stretch * area * couple, "energy": -t * m * length * area * couple}
    scale = t * m * area * np.linalg.norm(b)
    for name in works:
        err = np.abs(np.array(works[name]) - exact[name]).max() / scale
        print(
            f"λ = {stretch}, ψ = {tilt}, {name}: {np.array(works[name])} exact "
            f"{exact[name]}, error {err:.1e}"
        )
        assert err < 5e-15
    ratio = np.array(works["energy"]) / np.array(works["uniform"])
    assert ratio == pytest.approx(np.full(3, length / stretch), rel=1e-12)


@pytest.mark.parametrize(
    "text",
    [
        "atan2(X - 0.3, Y + 0.2)",
        "min(X, Y, 0.6)",
        "max(X, 0.4*Y)",
        "abs(X - 0.5)",
        "log(X + 0.5)",
        "exp(1.5*Y)",
        "tan(1.2*X)",
        "asin(0.9*Y)",
        "acos(0.8*X - 0.1)",
        "sqrt(X + Y + 0.5) + sin(3*X)*cos(2*Y) - X^2/(1 + Y) + pi",
    ],
)
def test_every_formula_function_reaches_ufl_as_in_numpy(text):
    """Each function of the formula language turned into UFL, compiled and evaluated
    at the points of a P2 interpolation on the unit square, against the same formula
    evaluated by numpy there (1e-14; the UFL names differ: ln, atan_2 or atan2,
    min_value, ...).  A function mapped to the wrong UFL one shows at once.  (The
    square root stays off 0, where its infinite slope turns the current stack's 7e-18
    of round-off in the origin's coordinates into 4e-9.)"""
    import ufl
    from dolfinx import fem
    from dolfinx import mesh as dmesh
    from mpi4py import MPI

    from rftfem import compat

    domain = dmesh.create_unit_square(MPI.COMM_SELF, 3, 3)
    formula = parse(text, "test", ("X", "Y"))
    X = ufl.SpatialCoordinate(domain)
    expr = formula.ufl({"X": X[0], "Y": X[1]})
    V = compat.function_space(domain, "Lagrange", 2)
    f = fem.Function(V)
    f.interpolate(compat.expression(expr, V))
    points = V.tabulate_dof_coordinates()
    expected = formula.numbers({"X": points[:, 0], "Y": points[:, 1]})
    assert np.abs(f.x.array - expected).max() < 1e-14 * max(1.0, np.abs(expected).max())
