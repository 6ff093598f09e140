"""demos/thickness_design.py's headline: ``rftfem optimize --vary-field`` designs the
thickness of a clamped magnetic strip (21 values, linear between, 0.05-0.2 mm, the
uniform strip's mass) for the largest angle of its last 0.5 mm in the field, and
reaches beam theory's optimum of the same design space
(tests/material_references.py, magnetic_strip_piecewise_linear_optimum with the
same chord): the same profile node by node, within 4e-7 mm (reached 4.8e-9 and
3.9e-8 mm on the two stacks: the value at X = 6.5, which the mass fixes, twice the
mass's relative departure, −1.9e-8 on the current stack), the designed angle and
its ratio to the uniform strip's within 1 % (reached −0.088 % and −0.091 %, both
stacks).  The difference is the large deflection (the couple on a piece turned by θ
is cos θ of the small-deflection one: −0.076 %) and the 40 cells (−0.012 %); against
the beam with cos θ the designed angle is within 0.15 % (reached −0.012 %).
docs/thickness_design.md has the numbers.  Broke: the mass constraint's slope
(optimize_fields._linear_slope) tilted by up to 2e-6 along the strip → 6.7e-7 mm,
the angles unchanged (the earlier bound, 1.5e-4 mm, let it pass)."""

from __future__ import annotations

import csv
import importlib.util
import sys

import numpy as np
import pytest
from conftest import DEMOS, ROOT, run_command
from material_references import (
    magnetic_strip_linear_coefficient,
    magnetic_strip_piecewise_linear_optimum,
)


def _demo():
    spec = importlib.util.spec_from_file_location("thickness_design", DEMOS / "thickness_design.py")
    demo = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(demo)
    return demo


def _large_deflection_chord(strip, t_nodes, chord, n=20001):
    """The beam's angle of its last ``chord`` when the couple on a piece turned by θ is
    cos θ of the small-deflection one (M0 B w t cos θ): θ' = 12 m / (E w t³),
    m(x) = ∫ₓᴸ M0 B w t cos θ ds, θ(0) = 0, by fixed-point iteration on a fine grid."""
    from scipy.integrate import cumulative_trapezoid, trapezoid

    x = np.linspace(0.0, strip.length, n)
    t = np.interp(x, strip.X, t_nodes)
    theta = np.zeros(n)
    for _ in range(50):
        above = cumulative_trapezoid((t * np.cos(theta))[::-1], -x[::-1], initial=0.0)[::-1]
        new = cumulative_trapezoid(strip.K * above / t**3, x, initial=0.0)
        if np.abs(new - theta).max() < 1e-15:
            break
        theta = new
    last = x >= strip.length - chord
    return float(
        np.arctan2(trapezoid(np.sin(theta[last]), x[last]), trapezoid(np.cos(theta[last]), x[last]))
    )


@pytest.mark.slow
def test_thickness_design_reaches_the_beam_optimum_of_its_design_space(tmp_path):
    demo = _demo()
    done = run_command(
        [
            sys.executable,
            "-m",
            "rftfem",
            "optimize",
            str(demo.SCENE),
            *demo.DESIGN,
            "--out",
            str(tmp_path),
        ],
        cwd=ROOT,
        timeout=900,
    )
    assert done.returncode == 0, done.stderr
    with open(tmp_path / "optimize.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    ok = [r for r in rows if r["status"] in ("ok", "infeasible")]
    # SLSQP may try a step off the mass constraint (scipy 1.18: once, +5.6 %): its row
    # says "infeasible", and the best is among those of the start's mass (to 1e-6)
    feasible = [r for r in ok if abs(float(r["mass"]) / float(ok[0]["mass"]) - 1) <= 1e-6]
    assert all((r in feasible) == (r["status"] == "ok") for r in ok)
    start, best = ok[0], max(feasible, key=lambda r: float(r["objective"]))
    with open(tmp_path / "best-thickness.csv", newline="") as f:
        designed = np.array([float(r["thickness"]) for r in csv.DictReader(f)])

    strip, (lo, hi), chord = demo.Strip(), demo.BOUNDS, demo.CHORD
    n, L, K = len(strip.X), strip.length, strip.K
    t_beam, J = magnetic_strip_piecewise_linear_optimum(L, strip.mean, lo, hi, n, chord=chord)
    J_uniform = magnetic_strip_linear_coefficient(np.full(n, strip.mean), L, chord)
    theta0, theta = float(start["objective"]), float(best["objective"])
    large = _large_deflection_chord(strip, t_beam, chord)
    print(
        f"thickness design: {len(rows)} runs; uniform {theta0:.7f} rad (beam "
        f"{K * J_uniform:.7f}, {100 * (theta0 / (K * J_uniform) - 1):+.4f} %), designed "
        f"{theta:.7f} (beam {K * J:.7f}, {100 * (theta / (K * J) - 1):+.3f} %; with cos θ "
        f"{large:.7f}, {100 * (theta / large - 1):+.3f} %), ratio {theta / theta0:.4f} "
        f"(beam {J / J_uniform:.4f}, {100 * (theta / theta0 / (J / J_uniform) - 1):+.3f} %); "
        f"profiles differ by {np.abs(designed - t_beam).max():.1e} mm at most"
    )
    assert len(rows) <= 20 and len(ok) == len(rows)
    # the same mass: the trapezoid mean of the designed profile is the uniform one
    mean = np.sum((designed[1:] + designed[:-1]) / 2 * np.diff(strip.X)) / L
    assert mean == pytest.approx(strip.mean, rel=1e-6)
    # the same profile: thin to X = 6, 0.075 at 6.5, thick from 7 on
    assert np.abs(designed - t_beam).max() < 4e-7
    # the uniform start: the beam's chord (+3e-5: the shear strain of the couple)
    assert theta0 == pytest.approx(K * J_uniform, rel=3e-4)
    # the headline
    assert theta / theta0 == pytest.approx(J / J_uniform, rel=0.01)
    assert theta == pytest.approx(K * J, rel=0.01)
    assert theta == pytest.approx(large, rel=1.5e-3)
