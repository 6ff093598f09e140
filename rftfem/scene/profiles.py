"""Profile files: values given at the points of a grid (rows ``X, Y, Z, v₁, …``),
interpolated to the body's nodes (docs/scenes.md: magnetization and material profiles).

The grid is the tensor product of the distinct X, Y and Z values of the rows; a
coordinate with one value only is not interpolated along.  Interpolation is
multilinear; :func:`profile_weights` gives its weights, so a gradient with respect
to the nodal values is carried back to the grid's values (``Wᵀ g``).
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

from rftfem.errors import SceneError
from rftfem.scene.validators import fmt

__all__ = ["read_profile", "profile_values", "profile_weights", "Grid"]


def read_profile(
    path: Path, key: str, columns: int = 3, names: str = "mx,my,mz"
) -> tuple[np.ndarray, np.ndarray]:
    """Rows ``X, Y, Z`` and ``columns`` values (``names`` for messages) of a profile
    file; a header line and ``#`` comments are allowed.  ``(points, values)``."""
    want = 3 + columns
    what = f"X,Y,Z,{names}"
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise SceneError(
            f"{key}: cannot read the profile file '{path}' ({exc.strerror or exc})"
        ) from None
    rows = []
    for n, row in enumerate(csv.reader(text.splitlines()), start=1):
        if not row or not "".join(row).strip() or row[0].lstrip().startswith("#"):
            continue
        try:
            values = [float(v) for v in row]
        except ValueError:
            if not rows and n == 1:
                continue  # a header
            raise SceneError(
                f"{key}: line {n} of '{path}' is not {want} numbers {what}: {','.join(row)[:60]}"
            ) from None
        if len(values) != want or not all(math.isfinite(v) for v in values):
            raise SceneError(
                f"{key}: line {n} of '{path}' is not {want} finite numbers "
                f"{what}: {','.join(row)[:60]}"
            )
        rows.append(values)
    if not rows:
        raise SceneError(f"{key}: the profile file '{path}' has no rows {what}")
    rows = np.array(rows)
    return rows[:, :3], rows[:, 3:]


class Grid:
    """The grid of a profile's points: its axes, and each row's place in it."""

    def __init__(self, points: np.ndarray, key: str):
        self.key = key
        self.axes, self.where = [], []
        for c in range(3):
            u = np.unique(points[:, c])
            if len(u) > 1:
                self.axes.append(u)
                self.where.append(c)
        self.span = max(float(np.ptp(points, axis=0).max()), 1.0)
        self.shape = tuple(len(a) for a in self.axes)
        if int(np.prod(self.shape)) != len(points):
            first = "XYZ"[self.where[0]] if self.where else ""
            raise SceneError(
                f"{key}: the profile's {len(points)} points are not a complete grid "
                f"({' x '.join(map(str, self.shape)) or '1'} = {int(np.prod(self.shape))} "
                f"points expected from its distinct {first} values): points are missing "
                "or repeated"
            )
        index = tuple(np.searchsorted(a, points[:, c]) for a, c in zip(self.axes, self.where))
        #: the grid position (flat) -> the row of the file
        self.row = np.full(self.shape, -1, dtype=np.int64)
        self.row[index] = np.arange(len(points))
        if (self.row < 0).any():
            missing = np.argwhere(self.row < 0)[0]
            point = [float(self.axes[k][i]) for k, i in enumerate(missing)]
            raise SceneError(
                f"{key}: the profile has no row at {fmt(point)} "
                f"({'/'.join('XYZ'[c] for c in self.where)}): its grid has a hole"
            )


def profile_weights(points: np.ndarray, at: np.ndarray, key: str) -> tuple[np.ndarray, np.ndarray]:
    """``(rows, weights)``, each (n, 2^d): the value at ``at[i]`` is
    ``Σ_k weights[i, k] · values[rows[i, k]]`` (multilinear).  The grid must be
    complete and cover every point asked for (a one-line SceneError)."""
    grid = Grid(points, key)
    span = max(grid.span, float(np.ptp(at, axis=0).max()) if len(at) else 0.0)
    tol = 1e-9 * span
    for a, c in zip(grid.axes, grid.where):
        outside = (at[:, c] < a[0] - tol) | (at[:, c] > a[-1] + tol)
        if outside.any():
            p = at[np.argmax(outside)]
            raise SceneError(
                f"{key}: the profile does not cover the body: the point "
                f"{fmt([round(float(v), 9) + 0.0 for v in p])} lies outside its "
                f"{'XYZ'[c]} range [{fmt(float(a[0]))}, {fmt(float(a[-1]))}]"
            )
    lo, frac = [], []
    for a, c in zip(grid.axes, grid.where):
        i = np.clip(np.searchsorted(a, at[:, c], side="right") - 1, 0, len(a) - 2)
        lo.append(i)
        frac.append(np.clip((at[:, c] - a[i]) / (a[i + 1] - a[i]), 0.0, 1.0))
    corners = 2 ** len(grid.axes)
    rows = np.zeros((len(at), corners), dtype=np.int64)
    weights = np.ones((len(at), corners))
    for corner in range(corners):
        idx = []
        for k in range(len(grid.axes)):
            bit = (corner >> k) & 1
            weights[:, corner] *= frac[k] if bit else 1 - frac[k]
            idx.append(lo[k] + bit)
        rows[:, corner] = grid.row[tuple(idx)] if idx else 0
    return rows, weights


def profile_values(points: np.ndarray, values: np.ndarray, at: np.ndarray, key: str) -> np.ndarray:
    """The profile's values at the points ``at`` (n, 3): (n, columns)."""
    rows, weights = profile_weights(points, at, key)
    values = np.asarray(values, dtype=float).reshape(len(points), -1)
    return np.einsum("nk,nkc->nc", weights, values[rows])
