"""The plane wall's gap during a run (docs/stokes.md): the set-up's warning, and each
accepted step's refusal or warning of a body closer than the images hold, in blobs.
"""

from __future__ import annotations

import numpy as np

from rftfem.model import stokes_body

WALL_GAP_REFUSED, WALL_GAP_WARNED = stokes_body.WALL_GAP_REFUSED, stokes_body.WALL_GAP_WARNED


def set_up_warnings(gap: float) -> list[str]:
    """A wall closer than WALL_GAP_WARNED blobs at the set-up (``gap``, the motions'
    reach included)."""
    if gap < WALL_GAP_WARNED:
        return [
            f"fluid.wall: the body comes within {gap:.3g} blobs of the "
            f"wall (with the motions' reach); under {WALL_GAP_WARNED} the "
            f"images leak and the speeds near the wall are off: move the wall "
            f"away or refine the mesh"
        ]
    return []


def check_step(x: np.ndarray, gaps: np.ndarray, t: float, warn: bool) -> list[str]:
    """The closest of the nodes' ``gaps`` (in blobs, at the positions ``x``) of the
    step accepted at ``t``: under WALL_GAP_REFUSED blobs the run fails (RunFailed: the
    images no longer hold the wall's no slip); under WALL_GAP_WARNED it is warned of
    if ``warn``."""
    gap = float(gaps.min())
    if gap < WALL_GAP_REFUSED:
        from rftfem.errors import RunFailed

        i = int(np.argmin(gaps))
        raise RunFailed(
            f"the body came within {gap:.3g} blobs of the wall (the node now "
            f"at {stokes_body.point_text(x[i])}); the wall's images need {WALL_GAP_WARNED}: "
            "move the wall away or refine the mesh"
        )
    if gap < WALL_GAP_WARNED and warn:
        return [
            f"fluid.wall: at t = {t:.6g} the body came within {gap:.3g} blobs of the "
            f"wall; under {WALL_GAP_WARNED} the images leak (body.csv: "
            "wall_gap_blobs)"
        ]
    return []
