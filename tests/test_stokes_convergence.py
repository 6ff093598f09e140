"""The Stokes layer's convergence on what users run (docs/stokes.md §Convergence,
§RFT against Stokes): slow reproductions, run by ``./dev.sh test-all``.

The swimming sheet's steady speed (case I, the paper's sheet and wave) on three
meshes, each twice as fine as the one before, shell and liquid together; and the
liquid alone refined at the middle mesh.
"""

from __future__ import annotations

import math

import pytest

from conftest import ROOT, run_scene

SHEET = ROOT / "demos" / "swimming_sheet.toml"
STOKES = ["--unset fluid.drag", 'fluid.model="stokes"', "fluid.viscosity=1e-9",
          "output.fields=false", "time.output_every=1"]


def _speed(*overrides) -> float:
    sim = run_scene(SHEET, *STOKES, *overrides)
    steady = sim.summary["steady"]
    assert steady["reached"]
    return steady["values"]["front_ux_rate"]


@pytest.mark.slow
def test_swimming_sheet_converges_in_stokes_flow():
    """Case I on 5 × 1, 10 × 2 and 20 × 4 cells: the observed order lies in [1.5, 4]
    (reached 2.43: 0.48808, 0.49580, 0.49723), the limit with the order free and
    fixed at 1.5 (0.49755 and 0.49801) brackets the paper's RFT speed 0.49763 within
    0.3 %, and the shipped 20 × 4 is within 0.5 % of both limits (reached 0.06 and
    0.16 %).  The liquid alone refined at 10 × 2 (fluid.refine = 1) moves the speed
    towards the limit by less than the shell's refinement does (reached +0.13 %
    against +0.29 %)."""
    u = [_speed(f"mesh.divisions=[{5 * 2 ** k}, {2 ** k}]") for k in range(3)]
    order = math.log2((u[1] - u[0]) / (u[2] - u[1]))
    free = u[2] + (u[2] - u[1]) / (2 ** order - 1)
    fixed = u[2] + (u[2] - u[1]) / (2 ** 1.5 - 1)
    print(f"sheet in Stokes flow: {u}, order {order:.3f}, limits {free:.5f} {fixed:.5f}")
    assert 1.5 <= order <= 4.0
    for limit in (free, fixed):
        assert abs(u[2] / limit - 1) < 5e-3
        assert abs(0.49763 / limit - 1) < 3e-3
    refined = _speed("mesh.divisions=[10, 2]", "fluid.refine=1")
    print(f"10 × 2 with fluid.refine = 1: {refined:.5f}")
    assert 0 < refined - u[1] < u[2] - u[1]
