"""``--vary`` of ``rftfem sweep``: a key and its values, listed or a range."""

from __future__ import annotations

import math
import re
import tomllib
from dataclasses import dataclass

from rftfem.errors import SceneError
from rftfem.scene.overrides import lookup

_RANGE = re.compile(r"^([^:]+):([^:]+):([^:]+)(?::(log|lin))?$")


@dataclass
class Vary:
    key: str
    values: list


def _toml_value(text: str, what: str):
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        if re.fullmatch(r"[A-Za-z_][\w.\-]*", text):
            return text  # a bare word, as --set takes it
        raise SceneError(
            f"{what}: '{text}' is not a value (a number, true/false, \"text\" or [array])"
        ) from None


def parse_vary(text: str, scene: dict) -> Vary:
    """``KEY=v1,v2`` or ``KEY=LO:HI:N[:log]`` against the loaded ``scene`` (the key's
    present value tells a numeric key from another)."""
    key, sep, spec = text.partition("=")
    key, spec = key.strip(), spec.strip()
    what = f"--vary {text}"
    if not sep or not key or not spec:
        raise SceneError(f"{what}: expected KEY=v1,v2,... or KEY=LO:HI:N[:log]")
    match = _RANGE.match(spec)
    if match and "[" not in spec:
        lo_text, hi_text, n_text, scale = match.groups()
        current = lookup(scene, key)
        if isinstance(current, bool) or not isinstance(current, (int, float)):
            found = "absent" if current is None else repr(current)
            raise SceneError(
                f"{what}: a range LO:HI:N needs a numeric key; {key} is "
                f"{found} in the scene (give its values as a list)"
            )
        try:
            lo, hi = float(lo_text), float(hi_text)
            n = int(n_text)
        except ValueError:
            raise SceneError(f"{what}: expected numbers LO:HI and a whole number N") from None
        if n < 2 or not (math.isfinite(lo) and math.isfinite(hi)) or lo == hi:
            raise SceneError(f"{what}: expected N >= 2 and finite LO != HI")
        if scale == "log":
            if lo <= 0 or hi <= 0:
                raise SceneError(f"{what}: a log range needs LO and HI > 0")
            values = [
                math.exp(math.log(lo) + k * (math.log(hi) - math.log(lo)) / (n - 1))
                for k in range(n)
            ]
        else:
            values = [lo + k * (hi - lo) / (n - 1) for k in range(n)]
        values[0], values[-1] = lo, hi
        if isinstance(current, int) and all(float(v).is_integer() for v in values):
            values = [int(v) for v in values]
        return Vary(key, values)
    values = [_toml_value(v.strip(), what) for v in _split_list(spec)]
    if not values:
        raise SceneError(f"{what}: no values")
    return Vary(key, values)


def _split_list(spec: str) -> list[str]:
    """Split on the commas outside brackets and quotes."""
    parts, depth, quote, cur = [], 0, None, ""
    for ch in spec:
        if quote:
            quote = None if ch == quote else quote
        elif ch in "\"'":
            quote = ch
        elif ch == "[":
            depth += 1
        elif ch == "]":
            depth -= 1
        elif ch == "," and depth == 0:
            parts.append(cur)
            cur = ""
            continue
        cur += ch
    parts.append(cur)
    return [p for p in (p.strip() for p in parts) if p]


__all__ = ["Vary", "parse_vary"]
