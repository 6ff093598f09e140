"""The parameters of ``rftfem optimize``: a ``--vary KEY=LO:HI[:log]`` and its unit interval."""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

from rftfem.errors import SceneError
from rftfem.scene import toml_writer
from rftfem.scene.overrides import lookup

__all__ = ["Parameter", "parse_vary"]


@dataclass
class Parameter:
    """One ``--vary KEY=LO:HI[:log]``: the key, its interval and its scene value."""

    key: str
    lo: float
    hi: float
    log: bool
    set_key: str  # the key of --set (the vector's for a component)
    index: int | None  # the component, or None
    vector: list | None  # the scene's vector (for a component)
    start: float

    def from_unit(self, z: float) -> float:
        z = min(1.0, max(0.0, float(z)))
        if z == self.to_unit(self.start):  # the scene's own value, not a round trip
            return self.start
        if self.log:
            return math.exp(math.log(self.lo) + z * (math.log(self.hi) - math.log(self.lo)))
        return self.lo + z * (self.hi - self.lo)

    def to_unit(self, x: float) -> float:
        if self.log:
            return (math.log(x) - math.log(self.lo)) / (math.log(self.hi) - math.log(self.lo))
        return (x - self.lo) / (self.hi - self.lo)

    def dx_dz(self, x: float) -> float:
        return x * (math.log(self.hi) - math.log(self.lo)) if self.log else self.hi - self.lo

    def override(self, x: float) -> str:
        if self.index is None:
            return f"{self.set_key}={toml_writer.value(x)}"
        vec = list(self.vector)
        vec[self.index] = x
        return f"{self.set_key}={toml_writer.value(vec)}"


def parse_vary(text: str, scene: dict) -> Parameter:
    """``KEY=LO:HI[:log]`` against the loaded scene (its value is the start)."""
    key, sep, rng = text.partition("=")
    key = key.strip()
    bits = [b.strip() for b in rng.split(":")]
    if not sep or not key or len(bits) not in (2, 3) or (len(bits) == 3 and bits[2] != "log"):
        raise SceneError(
            f"--vary '{text}': expected KEY=LO:HI or KEY=LO:HI:log (e.g. shell.E=1e5:1e7:log)"
        )
    try:
        lo, hi = float(bits[0]), float(bits[1])
    except ValueError:
        raise SceneError(
            f"--vary '{text}': expected numbers LO and HI, found '{bits[0]}' and '{bits[1]}'"
        ) from None
    log = len(bits) == 3
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
        raise SceneError(f"--vary '{text}': expected finite LO < HI, found {lo:g} and {hi:g}")
    if log and lo <= 0:
        raise SceneError(f"--vary '{text}': a log scale needs LO > 0, found {lo:g}")
    head, _, last = key.rpartition(".")
    value, set_key, index, vector = lookup(scene, key), key, None, None
    if (
        isinstance(lookup(scene, head), list)
        and re.fullmatch(r"\d+", last)
        and not isinstance(value, dict)
    ):
        vector, set_key, index = list(lookup(scene, head)), head, int(last)
    if value is not None and (isinstance(value, bool) or not isinstance(value, (int, float))):
        raise SceneError(
            f"--vary {key}: expected a key with a number value, found "
            f"{toml_writer.value(value) if not isinstance(value, dict) else 'a table'}"
        )
    start = float(value) if value is not None and lo <= value <= hi else None
    p = Parameter(key, lo, hi, log, set_key, index, vector, math.nan)
    p.start = start if start is not None else p.from_unit(0.5)
    return p
