"""The headlines of the demos that move on a floor ([[contact]]), at the demos' own
settings, against the same runs refined (twice the cells along the sheet and half
the step; docs/accuracy.md): demos/sheet_walking.toml (the step per field period)
and demos/sheet_inchworm.toml (the mean speed).  Both converge at first order in
the cell length (the feet touch the floor at quadrature points) and are
converged in the step; the tolerances are about ten times the differences
reached."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import DEMOS, run_scene

#: sheet_walking.toml at 64×2 cells and 512 steps a period: the centroid's advance
#: over the last field period (mm); as shipped (32×2, 256 a period) 0.91195, −0.72 %
WALKING_REFINED = 0.91854
#: sheet_inchworm.toml at 64×2 cells and 512 steps a period: the mean speed over the
#: last period (mm/s); as shipped 0.94053, −0.56 %
INCHWORM_REFINED = 0.94585


def _advance(out, t0, t1):
    body = np.genfromtxt(out / "body.csv", delimiter=",", names=True)
    t, x = body["time"], body["centroid_x"]
    return float(np.interp(t1, t, x) - np.interp(t0, t, x))


def _newton(out):
    steps = np.genfromtxt(out / "steps.csv", delimiter=",", names=True)
    return steps["newton_its"]


@pytest.mark.slow
def test_sheet_walking_as_shipped_steps_as_refined(tmp_path):
    """demos/sheet_walking.toml as shipped: the sheet walks along +X, and its step over
    the last field period (3–4 s) is within 7 % of the refined run's (reached −0.72 %:
    0.91195 against 0.91854 mm; half the step alone +0.001 %), in about 2.3 Newton
    iterations a step (trust region; at most 4 allowed)."""
    run_scene(DEMOS / "sheet_walking.toml", "output.fields=false", out_dir=tmp_path)
    step = _advance(tmp_path, 3.0, 4.0)
    its = _newton(tmp_path)
    print(
        f"sheet walking: {step:.5f} mm a period ({100 * (step / WALKING_REFINED - 1):+.2f} % "
        f"from the refined run); Newton {its.mean():.2f} a step, at most {its.max():.0f}"
    )
    assert step > 0.5
    assert abs(step / WALKING_REFINED - 1) < 0.07
    assert its.mean() < 4.0


@pytest.mark.slow
def test_sheet_inchworm_as_shipped_crawls_as_refined(tmp_path):
    """demos/sheet_inchworm.toml as shipped: the mean speed over the last pulse (2–3 s)
    within 6 % of the refined run's (reached −0.56 %: 0.94053 against 0.94585 mm/s;
    half the step alone +0.003 %), in about 2.4 Newton iterations a step."""
    run_scene(DEMOS / "sheet_inchworm.toml", "output.fields=false", out_dir=tmp_path)
    speed = _advance(tmp_path, 2.0, 3.0)  # a period of 1 s
    its = _newton(tmp_path)
    print(
        f"sheet inchworm: {speed:.5f} mm/s ({100 * (speed / INCHWORM_REFINED - 1):+.2f} % "
        f"from the refined run); Newton {its.mean():.2f} a step, at most {its.max():.0f}"
    )
    assert speed > 0.5
    assert abs(speed / INCHWORM_REFINED - 1) < 0.06
    assert its.mean() < 4.0


@pytest.mark.slow
def test_sheet_inchworm_on_even_friction_goes_nowhere(tmp_path):
    """The inchworm's stroke is reciprocal and symmetric about the sheet's middle: on a
    floor with the same friction every way (0.4) one pulse moves it less than 3e-12 of
    the ratchet floor's step (reached 2.8e-13 and 3.3e-13 of it: −2.6e-13 and −3.2e-13
    mm against 0.94 mm).  Broke: friction [0.4, 0.40000004, 0.4] (backward 1e-7 above
    forward) → moved 4.4e-7 of the step (the earlier 1e-6 passed it)."""
    run_scene(
        DEMOS / "sheet_inchworm.toml",
        "output.fields=false",
        "contact.0.friction=0.4",
        "time.end=1.0",
        out_dir=tmp_path,
    )
    moved = _advance(tmp_path, 0.0, 1.0)
    print(
        f"on even friction: moved {moved:.2e} mm in a pulse "
        f"({abs(moved) / INCHWORM_REFINED:.1e} of the ratchet's step)"
    )
    assert abs(moved) < 3e-12 * INCHWORM_REFINED
