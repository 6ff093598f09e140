"""Tables over time in a scene: ``[t, value]`` pairs (a load's ramp) and rows
``[t, v1, ..., vk]`` (a motion's or a field's values), with strictly increasing t."""

from __future__ import annotations

import math
from typing import Any

from rftfem.errors import SceneError
from rftfem.scene.messages import Validator, err, fmt, join


class Pairs(Validator):
    """A piecewise-linear table: [[t, value], ...] with strictly increasing t."""

    def __init__(self, what: str):
        self.expected = f"a list of [t, {what}] number pairs with strictly increasing t"
        self.pair = f"a [t, {what}] pair of numbers"

    def __call__(self, value: Any, path: str) -> list[list[float]]:
        if not isinstance(value, list) or not value:
            raise err(path, self.expected, value)
        out = []
        for i, pair in enumerate(value):
            if (
                not isinstance(pair, list)
                or len(pair) != 2
                or any(
                    isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v)
                    for v in pair
                )
            ):
                raise err(join(path, i), self.pair, pair)
            t, s = float(pair[0]), float(pair[1])
            if out and t <= out[-1][0]:
                raise SceneError(
                    f"{path}: expected strictly increasing times, found "
                    f"t = {fmt(t)} after t = {fmt(out[-1][0])} (entry {i})"
                )
            out.append([t, s])
        return out


class Rows(Validator):
    """A table of rows [t, v1, ..., vk] of finite numbers with strictly increasing t
    (``min_rows`` of them at least)."""

    def __init__(self, columns: tuple[str, ...], min_rows: int = 1):
        self.columns, self.min_rows = columns, min_rows
        names = ", ".join(columns)
        self.expected = (
            f"a list of [{names}] rows of numbers with strictly increasing "
            f"{columns[0]}" + (f", {min_rows} rows at least" if min_rows > 1 else "")
        )
        self.row = f"a [{names}] row of {len(columns)} numbers"

    def __call__(self, value: Any, path: str) -> list[list[float]]:
        if not isinstance(value, list) or len(value) < self.min_rows:
            raise err(path, self.expected, value)
        out = []
        for i, row in enumerate(value):
            if (
                not isinstance(row, list)
                or len(row) != len(self.columns)
                or any(
                    isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v)
                    for v in row
                )
            ):
                raise err(join(path, i), self.row, row)
            row = [float(v) for v in row]
            if out and row[0] <= out[-1][0]:
                raise SceneError(
                    f"{path}: expected strictly increasing {self.columns[0]}, "
                    f"found {self.columns[0]} = {fmt(row[0])} after "
                    f"{fmt(out[-1][0])} (row {i})"
                )
            out.append(row)
        return out
