"""The design of ``rftfem optimize --vary-field`` (rftfem/studies/optimize_fields.py): the
field's grid and bounds, and the mass and volume constraints."""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rftfem.errors import SceneError

__all__ = ["FieldDesign", "FieldConstraint", "parse_vary_field", "parse_field_constraint"]


@dataclass
class FieldDesign:
    """One ``--vary-field KEY=LO:HI``: the grid, the start values and the bounds."""

    key: str
    lo: float
    hi: float
    points: np.ndarray
    start: np.ndarray

    @property
    def name(self) -> str:
        return self.key.split(".")[-1]

    def write(self, values: np.ndarray, path: Path) -> None:
        rows = "\n".join(
            f"{p[0]!r},{p[1]!r},{p[2]!r},{float(v)!r}" for p, v in zip(self.points.tolist(), values)
        )
        path.write_text(f"X,Y,Z,{self.name}\n{rows}\n", encoding="utf-8")


@dataclass
class FieldConstraint:
    text: str
    name: str  # mass or volume
    sense: str  # <=, >= or =
    bound: float | None  # None: the start's value


def parse_vary_field(text: str, scene: dict) -> FieldDesign:
    from rftfem.scene.fields import field_values, profile_file
    from rftfem.scene.profiles import read_profile
    from rftfem.studies.field_gradients import FIELD_KEYS

    key, sep, rng = text.partition("=")
    key = key.strip()
    bits = [b.strip() for b in rng.split(":")]
    if not sep or len(bits) != 2:
        raise SceneError(
            f"--vary-field '{text}': expected KEY=LO:HI (e.g. shell.thickness=0.05:0.2)"
        )
    if (
        key not in FIELD_KEYS
        or key in ("shell.E", "shell.nu")
        and scene["shell"]["material"] == "orthotropic"
    ):
        raise SceneError(
            f"--vary-field '{text}': expected one of {', '.join(FIELD_KEYS)} "
            "(E and nu of an isotropic shell)"
        )
    try:
        lo, hi = float(bits[0]), float(bits[1])
    except ValueError:
        raise SceneError(f"--vary-field '{text}': expected numbers LO and HI") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
        raise SceneError(f"--vary-field '{text}': expected finite LO < HI")
    value = scene["shell"][key.split(".")[-1]]
    if isinstance(value, dict):
        points, values = read_profile(
            profile_file(scene, value["profile"]), f"{key}.profile", columns=1, names="value"
        )
        start = values[:, 0]
    else:
        mesh = scene["mesh"]
        if mesh["kind"] != "strip":
            raise SceneError(
                f"--vary-field {key}: the mesh is not a strip; give {key} as a "
                'profile ({ profile = "file.csv" }): its grid values are the '
                "design's variables"
            )
        nx, ny = mesh["divisions"]
        X, Y = np.linspace(0.0, mesh["length"], nx + 1), np.linspace(0.0, mesh["width"], ny + 1)
        points = np.array([[x, y, 0.0] for y in Y for x in X])
        start = field_values(scene, value, points, key)
    return FieldDesign(key, lo, hi, points, np.clip(start, lo, hi))


def parse_field_constraint(text: str) -> FieldConstraint:
    m = re.fullmatch(r"\s*(mass|volume)\s*(<=|>=|==|=)\s*(\S+)\s*", text)
    if m is None:
        raise SceneError(
            f"--constraint '{text}': with --vary-field expected mass or volume, "
            "=, <= or >=, and a number or 'start' (e.g. 'mass=start')"
        )
    bound = None
    if m[3] != "start":
        try:
            bound = float(m[3])
        except ValueError:
            raise SceneError(
                f"--constraint '{text}': expected a number or 'start' after '{m[2]}'"
            ) from None
    return FieldConstraint(text, m[1], "=" if m[2] in ("=", "==") else m[2], bound)
