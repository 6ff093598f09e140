"""Self-test of material_references.py and plate_references.py: prints each
reference next to a literature value or an independent cross-check.

    /usr/bin/python3 tests/material_references_check.py
"""

import os
import sys
import time

import numpy as np
from scipy import integrate

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import material_references as mr  # noqa: E402
import plate_references as pr  # noqa: E402

T0 = time.perf_counter()


def row(label, got, ref, note=""):
    rel = abs(got - ref) / abs(ref) if ref else abs(got)
    print(f"  {label:<44s} {got: .10g}  ref {ref: .10g}  rel {rel:.1e} {note}")


def section(title):
    print(f"\n== {title}")


# ---------------------------------------------------------------- 1 tapered
section("1. tapered cantilever, small deflection")
P, L, w, E, t0, nu = 2.0, 3.0, 0.5, 7.0e4, 0.05, 0.3
EI = E * w * t0 ** 3 / 12
row("uniform tip deflection / (PL^3/3EI)", mr.tapered_tip_deflection(P, L, w, E, t0),
    P * L ** 3 / (3 * EI))
row("uniform tip rotation / (PL^2/2EI)", mr.tapered_tip_rotation(P, L, w, E, t0),
    P * L ** 2 / (2 * EI))
row("plate strip, E/(1-nu^2)", mr.tapered_tip_deflection(P, L, w, E, t0, plate=True, nu=nu),
    P * L ** 3 * (1 - nu ** 2) / (3 * EI))
# t = t0 (1 - c x/L): delta = 12 P L^3/(E w t0^3 c^3) [-2d - d^2/2 - ln(1-c) - 3/2], d = c-1
c = 0.5
d = c - 1
closed = 12 * P * L ** 3 / (E * w * t0 ** 3 * c ** 3) * (-2 * d - d * d / 2 - np.log(1 - c) - 1.5)
taper = lambda x: t0 * (1 - c * x / L)
row("linear taper c=1/2 vs closed form", mr.tapered_tip_deflection(P, L, w, E, taper), closed)
edges = np.linspace(0, L, 6)
g = mr.tapered_deflection_gradient(P, L, w, E, taper, edges)
h = 1e-4 * t0
for i in (0, 2, 4):
    bump = lambda s, x: taper(x) + s * h * (edges[i] <= x < edges[i + 1])
    fd = (mr.tapered_tip_deflection(P, L, w, E, lambda x: bump(1, x), points=edges)
          - mr.tapered_tip_deflection(P, L, w, E, lambda x: bump(-1, x), points=edges)) / (2 * h)
    row(f"gradient interval {i} vs central difference", g[i], fd)
Ex = lambda x: E * (1 + x / L)
row("E(x) = E(1+x/L), t uniform vs closed form",
    mr.tapered_tip_deflection(P, L, w, Ex, t0),
    P * L ** 3 / EI * (4 * np.log(2) - 2.5))   # int (L-x)^2/(1+x/L) dx / L^3

# ---------------------------------------------------------------- 2 elastica
section("2. nonuniform elastica (dead tip load)")
dx, y, th = mr.nonuniform_elastica(1.0, 1.0, 1.0)
ex = mr.uniform_elastica_elliptic(1.0)
row("PL^2/EI=1: w/L  (Bisshopp-Drucker 0.30172)", y, 0.30172)
row("PL^2/EI=1: 1-x/L (Bisshopp-Drucker 0.05643)", -dx, 0.05643)
row("PL^2/EI=1: w/L vs first-integral solution", y, ex[1])
row("PL^2/EI=1: 1-x/L vs first-integral solution", -dx, ex[0])
row("PL^2/EI=1: tip angle vs first-integral", th, ex[2], f"({np.degrees(th):.4f} deg)")
for alpha in (3.0, 10.0):
    dx, y, th = mr.nonuniform_elastica(alpha, 1.0, 1.0)
    ex = mr.uniform_elastica_elliptic(alpha)
    row(f"PL^2/EI={alpha:g}: w/L vs first-integral", y, ex[1])
    row(f"PL^2/EI={alpha:g}: 1-x/L vs first-integral", -dx, ex[0])
EIx = lambda x: EI * (1 - c * x / L) ** 3
Psmall = 1e-6 * EI / L ** 2
dx, y, th = mr.nonuniform_elastica(Psmall, L, EIx)
row("small P, tapered EI: y(L) vs tapered_tip_deflection", y,
    mr.tapered_tip_deflection(Psmall, L, w, E, taper))
row("small P, tapered EI: theta(L) vs tapered_tip_rotation", th,
    mr.tapered_tip_rotation(Psmall, L, w, E, taper))
cells = np.array([1.0, 0.6, 0.3, 0.15]) * t0
tpc = lambda x: cells[min(int(x / L * 4), 3)]
EIpc = lambda x: E * w * tpc(x) ** 3 / 12
dx, y, th = mr.nonuniform_elastica(-Psmall, L, EIpc, n=4)
row("small -P, 4 EI steps: y(L) vs tapered (points)", y,
    mr.tapered_tip_deflection(-Psmall, L, w, E, tpc, points=np.linspace(0, L, 5)))

# ---------------------------------------------------------------- 3 orthotropic
section("3. orthotropic layer")
E1, E2, G12, n12, t, M = 1.4e5, 1.0e4, 5.0e3, 0.3, 0.002, 0.7
k = mr.narrow_strip_curvatures(E1, E2, G12, n12, t, 0.0, M)
row("angle 0 narrow strip k_xx vs 12M/(E1 t^3)", k[0], 12 * M / (E1 * t ** 3))
row("angle 0 narrow strip k_yy vs -nu12 k_xx", k[1], -n12 * k[0])
row("angle 0 wide plate k_xx vs 12M(1-nu12nu21)/(E1t^3)",
    mr.wide_plate_curvature(E1, E2, G12, n12, t, 0.0, M),
    12 * M * (1 - n12 ** 2 * E2 / E1) / (E1 * t ** 3))
Ei, ni = 2.0e5, 0.3
Dr = mr.orthotropic_D(Ei, Ei, Ei / (2 * (1 + ni)), ni, t, 0.7)
Diso = Ei * t ** 3 / (12 * (1 - ni ** 2)) * np.array([[1, ni, 0], [ni, 1, 0], [0, 0, (1 - ni) / 2]])
print(f"  isotropic at 0.7 rad: max|D - D_iso|/D11 = {np.abs(Dr - Diso).max() / Diso[0, 0]:.1e}")
# Off-axis: transformed compliance (Jones, Mechanics of Composite Materials)
S11, S22, S12, S66 = 1 / E1, 1 / E2, -n12 / E1, 1 / G12
for deg in (30.0, 45.0, 60.0):
    a = np.radians(deg)
    cs, sn = np.cos(a), np.sin(a)
    Sb11 = S11 * cs ** 4 + (2 * S12 + S66) * sn ** 2 * cs ** 2 + S22 * sn ** 4
    Sb12 = S12 * (sn ** 4 + cs ** 4) + (S11 + S22 - S66) * sn ** 2 * cs ** 2
    Sb16 = (2 * S11 - 2 * S12 - S66) * sn * cs ** 3 - (2 * S22 - 2 * S12 - S66) * sn ** 3 * cs
    k = mr.narrow_strip_curvatures(E1, E2, G12, n12, t, a, M)
    f = 12 * M / t ** 3
    row(f"{deg:g} deg k_xx vs Sbar11 12M/t^3", k[0], Sb11 * f)
    row(f"{deg:g} deg k_yy vs Sbar12 12M/t^3", k[1], Sb12 * f)
    row(f"{deg:g} deg 2k_xy vs Sbar16 12M/t^3", k[2], Sb16 * f,
        f"(2k_xy/k_xx = {k[2] / k[0]:+.4f}; wide/narrow k_xx = "
        f"{mr.wide_plate_curvature(E1, E2, G12, n12, t, a, M) / k[0]:.4f})")

# ---------------------------------------------------------------- 4 plate
section("4. clamped rectangular plate, uniform q (Ritz)")
print("  isotropic square, w_c D/(q a^4):  terms  legendre        beam-modes")
for m in (2, 4, 6, 8, 12):
    print(f"  {'':34s}{m:5d}  {pr.clamped_orthotropic_plate(1, 1, 1, .3, 1, .35, 1, m):.10f}"
          f"  {pr.clamped_orthotropic_plate(1, 1, 1, .3, 1, .35, 1, 3 * m, 'beam'):.10f}"
          f" (beam: {3 * m} terms)")
wsq = pr.clamped_orthotropic_plate(1, 1, 1, .3, 1, .35, 1, 14)
row("square vs literature 0.00126532", wsq, pr.SQUARE_CLAMPED)
row("square vs Timoshenko table 35 (0.00126)", wsq, 0.00126)
for ratio in (1.5, 2.0):
    row(f"b/a={ratio}: vs Timoshenko table 35", pr.clamped_orthotropic_plate(1, ratio, 1, .3, 1, .35, 1, 14),
        pr.TIMOSHENKO_TABLE35[ratio])
row("b/a=8 vs long strip 1/384", pr.clamped_orthotropic_plate(1, 8, 1, .3, 1, .35, 1, 20), 1 / 384,
    "(table 35 inf: 0.00260)")
D11, D22, D12, D66, a, b = 4.0, 1.0, 0.25, 0.4, 1.5, 1.0
print(f"  orthotropic D11={D11} D22={D22} D12={D12} D66={D66}, a={a} b={b}, q=1:")
leg = pr.clamped_orthotropic_plate_series(a, b, D11, D12, D22, D66, 1, (2, 4, 6, 8, 10, 12, 14))
bm = pr.clamped_orthotropic_plate_series(a, b, D11, D12, D22, D66, 1, (10, 20, 30, 40), "beam")
for m, v in leg:
    print(f"    legendre {m:3d} terms: {v:.10f}")
for m, v in bm:
    print(f"    beam     {m:3d} terms: {v:.10f}")
row("orthotropic legendre(14) vs beam-modes(40)", leg[-1][1], bm[-1][1])
row("same H=D12+2D66, split D12=0.85 D66=0.1", pr.clamped_orthotropic_plate(
    a, b, D11, 0.85, D22, 0.1, 1, 14), leg[-1][1], "(clamped: only H matters)")
row("H=sqrt(D11D22), a=sqrt2 b: affine map to square", pr.clamped_orthotropic_plate(
    np.sqrt(2), 1, 4, 1.0, 1, 0.5, 1, 14), pr.SQUARE_CLAMPED, "(w D22/(q b^4))")

# ---------------------------------------------------------------- 5 magnetic
section("5. magnetic strip thickness optimum (L=10, tbar=0.1, tmin=0.05, tmax=0.2)")
L, tb, lo, hi = 10.0, 0.1, 0.05, 0.2
# independent evaluation of J by nested quadrature for a random piecewise t
rng = np.random.default_rng(1)
tr = rng.uniform(lo, hi, 7)
tf = lambda x: tr[min(int(x / L * 7), 6)]
pts = np.linspace(0, L, 8)
mt = lambda x: integrate.quad(tf, x, L, points=[p for p in pts if x < p < L], epsrel=1e-13)[0]
for kind, ker in (("rotation", lambda x: 1.0), ("deflection", lambda x: L - x)):
    q = integrate.quad(lambda x: mt(x) * ker(x) / tf(x) ** 3, 0, L, points=pts[1:-1], epsrel=1e-12)[0]
    row(f"J_{kind}(random 7 cells) vs nested quad", mr.magnetic_strip_coefficient(tr, L, kind), q)
    J, gr = mr._strip_objective(tr, L, kind)
    e = np.eye(7)[3] * 1e-6
    fd = (mr.magnetic_strip_coefficient(tr + e, L, kind) - mr.magnetic_strip_coefficient(tr - e, L, kind)) / 2e-6
    row(f"dJ_{kind}/dt_3 vs central difference", gr[3], fd)
a_sw, rot_bb, defl_bb = mr.bang_bang_coefficients(L, tb, lo, hi)
urot, udef = mr.uniform_strip_rotation_coefficient(L, tb), mr.uniform_strip_deflection_coefficient(L, tb)
print(f"  uniform: rotation L^2/(2 tbar^2) = {urot:.6g}, deflection L^3/(3 tbar^2) = {udef:.6g}")
print(f"  continuous bang-bang (tmin on [0,{a_sw:.4f}), tmax after): rotation {rot_bb:.6f} "
      f"({rot_bb / urot:.4f}x), deflection {defl_bb:.6f} ({defl_bb / udef:.4f}x)")


def shape(tv):
    n = len(tv)
    x = (np.arange(n) + 0.5) * L / n
    at_lo, at_hi = np.isclose(tv, lo, rtol=1e-6), np.isclose(tv, hi, rtol=1e-6)
    mid = ~(at_lo | at_hi)
    s = f"tmin on x<{x[at_lo].max() + L / n / 2:.3f}, tmax on x>{x[at_hi].min() - L / n / 2:.3f}"
    if mid.any():
        s += ", between: " + ", ".join(f"t={v:.4f} at x={xx:.3f}" for v, xx in zip(tv[mid], x[mid]))
    return s


for kind, fun, ref, uni in (("rotation", mr.magnetic_strip_thickness_optimum, rot_bb, urot),
                            ("deflection", mr.magnetic_strip_deflection_optimum, defl_bb, udef)):
    print(f"  maximise tip {kind}:")
    for n in (20, 40, 80, 60, 120, 240):
        tv, J = fun(L, tb, lo, hi, n)
        print(f"    n={n:4d}: coeff {J:.6f} = {J / uni:.5f} x uniform, "
              f"bang-bang - coeff = {ref - J:.3e}, mass {tv.mean() / tb - 1:+.1e}")
        print(f"            shape: {shape(tv)}")
    # global check, n = 20: SLSQP from 100 random starts (feasible ends only)
    rng = np.random.default_rng(7)
    vals = []
    for _ in range(100):
        u = np.clip(rng.uniform(lo, hi, 20) / tb, lo / tb, hi / tb)
        r = mr._slsqp(L, tb, lo, hi, kind, u)
        v = r.x * tb
        if abs(v.mean() - tb) < 1e-10 and v.min() > lo - 1e-12 and v.max() < hi + 1e-12:
            vals.append(mr.magnetic_strip_coefficient(v, L, kind))
    row(f"  n=20 best of {len(vals)} random-start SLSQP runs", max(vals), fun(L, tb, lo, hi, 20)[1],
        f"({sum(np.isclose(vals, max(vals), rtol=1e-9))} reach it)")
    # discrete optimality conditions at n = 60 (switch on a node)
    tv, J = fun(L, tb, lo, hi, 60)
    _, gr = mr._strip_objective(tv, L, kind)
    gs = gr / (L / 60)
    il, ih = np.isclose(tv, lo), np.isclose(tv, hi)
    print(f"    n=60 first variation g(s): max on tmin part {gs[il].max():.4g} <= "
          f"min on tmax part {gs[ih].min():.4g}  (lambda in between)")

print(f"\ntotal runtime {time.perf_counter() - T0:.2f} s")
