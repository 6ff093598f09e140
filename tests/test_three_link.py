"""The three-link swimmer with inertia (demos/three_link.toml) against the rigid-link
reference of tests/rigid_links.py: three rigid plates with distributed mass on free
hinges in the same drag, the stroke's corners applied as constraint impulses.

The links of the shipped scene (E = 400 MPa, Sp ≈ 0.01) bend by ~1e-9 mm in the
drag, so the shell must move as the rigid links do.  The swimmer mostly *folds*:
its free hinges leave a neutral fold mode that inertia ratchets, and the corner's
drift is the chain contracting as it folds; the centroid moves 0.0007 mm in nine
cycles (docs/model.md §6.10, docs/three_link.md)."""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest
import rigid_links
from conftest import DEMOS, run_scene

SCENE = DEMOS / "three_link.toml"
_SCENE = tomllib.loads(SCENE.read_text())
THICKNESS, DENSITY = _SCENE["shell"]["thickness"], _SCENE["shell"]["density"]
LINK = _SCENE["mesh"]["link_width"]
#: reached on both stacks: 0.06 % (corner Y), 0.02 % (centre Z), 0.06 % (angle)
TOLERANCE = 0.005


def _shell_measures(sim) -> dict:
    """Corner Y, centre Y and Z, and the left and middle links' angles about X of the
    last probe row (probes corner, centre, hinge_left, hinge_right)."""
    corner, centre, left, right = (
        np.array(p) + v
        for p, v in zip(
            ([0, 0, 0], [2.5, 0.75, 0], [2.5, 0.5, 0], [2.5, 1.0, 0]), sim.history[-1][1]
        )
    )
    return {
        "corner_y": corner[1],
        "centre_y": centre[1] - 0.75,
        "centre_z": centre[2],
        "angle_middle": math.atan2(*(right - left)[[2, 1]]),
        "angle_left": math.atan2(*(left - corner)[[2, 1]]),
    }


def _rigid(w_left, w_right, t_end) -> dict:
    return rigid_links.simulate(
        w_left, w_right, t_end, density=DENSITY, thickness=THICKNESS, link_width=LINK
    ).summary()


def _compare(ours, ref, keys):
    for key in keys:
        print(
            f"{key:13s} shell {ours[key]:+.6e}  rigid links {ref[key]:+.6e}  "
            f"({100 * (ours[key] / ref[key] - 1):+.3f} %)"
        )
    for key in keys:
        assert ours[key] == pytest.approx(ref[key], rel=TOLERANCE), key


@pytest.mark.long
def test_case_I_as_shipped_folds_as_rigid_links():
    """The demo scene as shipped (HHT α = −0.05, dt = 0.005, nine cycles of the
    out-and-back stroke): corner Y, middle centre Z and middle-link angle within
    0.5 % of the rigid links (reference +0.0771 mm, −0.1108 mm, 0.494 rad).  Before
    the driven dofs' rates were the motion's own and the corners' impulses reached
    the body (docs/model.md §6.10), the corner was at +0.1678 mm: +118 %."""
    sim = run_scene(SCENE, "output.fields=false")
    assert sim.summary["status"] == "ok"
    w_left, w_right = (m["values"] for m in _SCENE["motion"])
    ref = _rigid(w_left, w_right, _SCENE["time"]["end"])
    _compare(_shell_measures(sim), ref, ("corner_y", "centre_z", "angle_middle"))


@pytest.mark.long
def test_square_loop_with_inertia_moves_as_rigid_links():
    """Another stroke: the square loop (w_L, w_R) = (0,0) → (A,0) → (A,A) → (0,A) →
    (0,0), three cycles, with the demo's inertia and step: corner Y, centre Y and Z
    and the left link's angle within 0.5 % of the rigid links."""
    w_left, w_right = rigid_links.loop_tables("square", 0.1, 0.4, 3)
    sim = run_scene(
        SCENE,
        "output.fields=false",
        "time.end=1.2",
        f"motion.0.values={w_left}",
        f"motion.1.values={w_right}",
    )
    assert sim.summary["status"] == "ok"
    ref = _rigid(w_left, w_right, 1.2)
    _compare(_shell_measures(sim), ref, ("corner_y", "centre_y", "centre_z", "angle_left"))
