"""Scenes written back as TOML: values (``value``) and whole scenes (``document``).

The standard library reads TOML but does not write it; a scene is a small tree of
tables, arrays of tables and plain values, which is all this writes.  Reading the
text back with ``tomllib`` gives the same tree (tests/test_optimize.py checks it).
"""

from __future__ import annotations

import json
import math
import re
from typing import Any

_BARE_KEY = re.compile(r"[A-Za-z0-9_-]+")


def value(v: Any) -> str:
    """A value as it is written in a scene (numbers in their shortest exact form)."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        if v != 0.0 and not 1e-4 <= abs(v) < 1e5:
            mantissa, exponent = f"{v:.12e}".split("e")
            short = f"{mantissa.rstrip('0').rstrip('.')}e{int(exponent)}"
            return short if float(short) == v else repr(v)
        return repr(v)
    if isinstance(v, str):  # JSON's escapes are TOML's; TOML also wants DEL escaped
        return json.dumps(v, ensure_ascii=False).replace("\x7f", "\\u007f")
    if isinstance(v, list):
        return "[" + ", ".join(value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{key(k)} = {value(x)}" for k, x in v.items()) + "}"
    raise TypeError(f"no TOML form for {v!r}")


def key(k: str) -> str:
    return k if _BARE_KEY.fullmatch(k) else value(str(k))


def _is_table_array(v: Any) -> bool:
    return isinstance(v, list) and bool(v) and all(isinstance(x, dict) for x in v)


def document(data: dict, header: str = "") -> str:
    """The TOML text of ``data`` (a scene as ``tomllib`` reads it), after ``header``
    (comment lines)."""
    lines = [f"# {line}".rstrip() for line in header.splitlines()]
    _table(data, [], lines)
    return "\n".join(lines).strip("\n") + "\n"


def _table(data: dict, path: list[str], lines: list[str]) -> None:
    plain = {k: v for k, v in data.items() if not isinstance(v, dict) and not _is_table_array(v)}
    for k, v in plain.items():
        lines.append(f"{key(k)} = {value(v)}")
    for k, v in data.items():
        if isinstance(v, dict):
            lines += ["", f"[{'.'.join(key(p) for p in [*path, k])}]"]
            _table(v, [*path, k], lines)
        elif _is_table_array(v):
            for item in v:
                lines += ["", f"[[{'.'.join(key(p) for p in [*path, k])}]]"]
                _table(item, [*path, k], lines)


__all__ = ["value", "key", "document"]
