"""Material values that vary over the body (docs/scenes.md, "Material fields").

``shell.thickness``, ``shell.E``, ``shell.nu``, ``shell.density``, the orthotropic
moduli and the same keys of ``[[shell.parts]]`` take

- a number: the same value everywhere (on the part);
- a formula of the reference coordinates X, Y, Z (a string): evaluated at the
  nodes of the material's field (rftfem/model/materials.py);
- a profile: ``{ profile = "file.csv" }`` or just ``"file.csv"``, rows X,Y,Z,value
  on a grid, interpolated (multilinear) to those nodes.

The validator keeps a formula as its text and a profile as ``{"profile": path}``; a
formula without variables is its number.  Values are checked on the body when the
model is built, where the nodes are known.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from rftfem.errors import SceneError
from rftfem.scene.validators import Formula, Num, Validator, err, fmt, found

REFERENCE = ("X", "Y", "Z")

__all__ = ["MaterialField", "is_field", "field_values", "profile_file", "describe"]


class MaterialField(Validator):
    """A number (checked by ``number``), a formula of X, Y, Z, or a profile file."""

    def __init__(self, number: Validator | None = None):
        self.formula = Formula(REFERENCE, number or Num())
        self.number = self.formula.number
        self.expected = (
            f"{self.number.expected}, a formula of X, Y, Z (a string) or a "
            'profile file ({ profile = "file.csv" }, rows X,Y,Z,value)'
        )

    def __call__(self, value: Any, path: str) -> float | str | dict[str, str]:
        if isinstance(value, dict):
            unknown = sorted(set(value) - {"profile"})
            if unknown or "profile" not in value:
                raise err(
                    path,
                    self.expected,
                    value,
                    " (a table here has one key, profile"
                    + (f", not {unknown[0]}" if unknown else "")
                    + ")",
                )
            name = value["profile"]
            if not isinstance(name, str) or not name.strip():
                raise err(f"{path}.profile", "a CSV file name (a string)", name)
            return {"profile": name.strip()}
        if isinstance(value, str) and value.strip().lower().endswith(".csv"):
            return {"profile": value.strip()}
        if isinstance(value, str):
            from rftfem.scene.expressions import parse, substitute
            from rftfem.scene.validators import _PARAMETERS

            try:
                parse(substitute(value, _PARAMETERS.get()), path, REFERENCE)
            except SceneError as exc:  # say what the key takes, then what is wrong
                why = str(exc).removeprefix(f"{path}: ")
                raise SceneError(
                    f"{path}: expected {self.number.expected}, a formula of "
                    f"X, Y, Z or a profile file; found {found(value)} "
                    f"({why})"
                ) from None
        return self.formula(value, path)

    def describe(self, name: str) -> str:
        return (
            f"{self.number.describe(name)}, a formula of X, Y, Z (a string) or a profile "
            '(`{ profile = "file.csv" }`, rows X,Y,Z,value)'
        )


def is_field(value: float | str | dict[str, str]) -> bool:
    """Whether a validated material value varies over the body (formula or profile)."""
    return isinstance(value, (str, dict))


def profile_file(scene: dict, name: str) -> Path:
    """A profile's path: relative to the scene file's folder."""
    folder = scene.get("_folder") or (
        Path(scene["_path"]).parent if scene.get("_path") else Path(".")
    )
    return Path(folder) / Path(name).expanduser()


def field_values(
    scene: dict, value: float | str | dict[str, str], at: np.ndarray, key: str
) -> np.ndarray:
    """A validated material value at the points ``at`` (n, 3): (n,) floats.  A formula
    or profile that is not finite somewhere is a one-line SceneError naming the point."""
    from rftfem.scene.expressions import parse
    from rftfem.scene.profiles import profile_values, read_profile

    at = np.asarray(at, dtype=float).reshape(-1, 3)
    if not is_field(value):
        return np.full(len(at), float(value))
    if isinstance(value, dict):
        points, values = read_profile(
            profile_file(scene, value["profile"]), f"{key}.profile", columns=1, names="value"
        )
        out = profile_values(points, values, at, f"{key}.profile")[:, 0]
    else:
        formula = parse(value, key, REFERENCE)
        with np.errstate(all="ignore"):
            out = np.broadcast_to(
                np.asarray(
                    formula.numbers({"X": at[:, 0], "Y": at[:, 1], "Z": at[:, 2]}), dtype=float
                ),
                len(at),
            ).copy()
    bad = ~np.isfinite(out)
    if bad.any():
        p = at[np.argmax(bad)]
        raise SceneError(
            f"{key}: {describe(value)} is not a finite number at "
            f"{fmt([round(float(v), 9) + 0.0 for v in p])} on the body"
        )
    return out


def describe(value: float | str | dict[str, str]) -> str:
    """The value as a message names it."""
    if isinstance(value, dict):
        return f"the profile '{value['profile']}'"
    if isinstance(value, str):
        return f"the formula '{value}'"
    return fmt(value)
