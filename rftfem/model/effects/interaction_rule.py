"""How many points per cell and layers through the thickness sum the magnetized parts'
interactions, by default (``[magnetic] interaction_points = "auto"``, docs/bodies.md)."""

from __future__ import annotations

import numpy as np


def rule(size: float, thickness: float, nearest: float) -> tuple[int, int]:
    """The Gauss points per cell side ``q`` and through the thickness ``L`` that sum
    the interactions of magnetized cells of side ``size`` and ``thickness`` whose
    nearest cell centres of different parts are ``nearest`` apart to about 1e-3
    (docs/bodies.md: measured on plates a thickness apart against finer sums):
    the error of ``q`` points falls as ``(size/nearest)^(2q)``, of ``L`` layers as
    ``(thickness/nearest)^(2L)``."""
    ratio = size / nearest if nearest > 0.0 else np.inf
    q = 1 if ratio <= 0.05 else 2 if ratio <= 0.3 else 3 if ratio <= 0.6 else 4
    ratio = thickness / nearest if nearest > 0.0 else np.inf
    layers = 1 if ratio <= 0.05 else 2 if ratio <= 0.3 else 3
    return q, layers


def rule_of_cells(rows: np.ndarray, thickness: float) -> tuple[int, int]:
    """:func:`rule` for the magnetized cells given as ``rows`` (centre x, y, z, group,
    area; every process's): the cells' size from the largest area, and the nearest two
    centres of different groups."""
    from scipy.spatial import cKDTree

    nearest = np.inf
    for g in np.unique(rows[:, 3]):
        inside = rows[:, 3] == g
        if inside.all():
            continue
        gap, _ = cKDTree(rows[~inside, :3]).query(rows[inside, :3], k=1)
        nearest = min(nearest, float(gap.min()))
    size = float(np.sqrt(rows[:, 4].max())) if len(rows) else 0.0
    return rule(size, thickness, nearest)
