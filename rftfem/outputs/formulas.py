"""Formulas of quantities: the one language of ``rftfem collect``, ``sweep``,
``study``, ``optimize`` and ``Result.quantity``.

A formula is arithmetic (rftfem/scene/expressions.py: numbers, ``+ - * / ^``,
parentheses, ``abs sqrt exp log min max ...``) whose operands are quantities of
rftfem/outputs/quantities.py, read off one run folder::

    rate(centroid_x, 1, 2) / mean(drag_power, 1, 2)     speed per power
    abs(tip_uz@end - 0.25)                              distance to a target
    rate(c_x, 2, 4) / scene(magnetic.field.frequency)   a walker's step per period
    steady(front_ux_rate)                               a single quantity

A quantity is ``COLUMN@TIME`` or one of the quantity functions (``rate``,
``mean``, ``max``, ``min``, ``spin``, ``steady``) called on a column; ``max`` and
``min`` whose first argument is not a bare column name are the formula's own
(``max(rate(x, 1, 2), 0)``).  ``scene(KEY)`` is a value of the run's scene (as
summary.json echoes it, overrides applied).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import TYPE_CHECKING

from rftfem.errors import SceneError
from rftfem.outputs import quantities
from rftfem.scene import expressions
from rftfem.scene.overrides import lookup

if TYPE_CHECKING:
    from pathlib import Path

_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_-]*")
_TIME = re.compile(r"\s*(?:start|end|[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)")


@dataclass(frozen=True)
class Objective:
    """A formula over quantities: ``evaluate(run)`` reads each quantity, then the formula."""

    text: str
    formula: expressions.Formula
    quantities: tuple  # of quantities.Quantity and SceneValue

    def evaluate(self, run: quantities.RunFolder | str | Path) -> float:
        run = run if isinstance(run, quantities.RunFolder) else quantities.RunFolder(run)
        env = {f"q{i}": q.evaluate(run) for i, q in enumerate(self.quantities)}
        value = float(self.formula.numbers(env))
        if not math.isfinite(value):
            raise quantities.Unavailable(f"'{self.text}' is not finite ({value}) in {run.dir}")
        return value


@dataclass(frozen=True)
class SceneValue:
    """``scene(KEY)``: the number at KEY (``shell.E``, ``load.0.value.2``) in the run's
    validated scene."""

    text: str
    key: str

    def evaluate(self, run: quantities.RunFolder) -> float:
        node = (run.summary or {}).get("scene")
        if node is None:
            raise quantities.Unavailable(f"'{self.text}': {run.dir} has no summary.json")
        missing = object()
        node = lookup(node, self.key, absent=missing)
        if node is missing:
            raise SceneError(f"'{self.text}': the scene has no key '{self.key}'")
        if node is None:
            raise SceneError(f"'{self.text}': '{self.key}' is not a number (the scene has none)")
        if isinstance(node, bool) or not isinstance(node, (int, float)):
            raise SceneError(f"'{self.text}': '{self.key}' is not a number")
        return float(node)


def _closing(text: str, start: int, what: str) -> int:
    """The index just after the parenthesis that closes the one at ``start``."""
    depth = 0
    for i in range(start, len(text)):
        depth += {"(": 1, ")": -1}.get(text[i], 0)
        if depth == 0:
            return i + 1
    raise SceneError(f"{what} '{text}': a '(' is not closed")


def _is_quantity_call(name: str, text: str, open_at: int) -> bool:
    if name not in quantities.FUNCTIONS:
        return False
    if name not in ("max", "min"):
        return True
    m = re.compile(r"\(\s*[A-Za-z_][A-Za-z0-9_-]*\s*([,)])").match(text, open_at)
    return m is not None  # max(COLUMN, ...) is a quantity, max(a + b, c) the formula's


def parse(text: str, what: str = "--objective") -> Objective:
    """Parse an objective (module docstring); a one-line SceneError naming ``what``."""
    if not isinstance(text, str) or not text.strip():
        raise SceneError(f"{what}: expected a formula of quantities, found '{text}'")
    pieces, found = _operands(text, what)
    if not found and _NAME.fullmatch(text.strip()):
        try:  # a bare column: the quantity language says what it lacks ('@')
            quantities.parse(text.strip())
        except SceneError as exc:
            raise SceneError(f"{what}: {exc}") from None
    if not found:
        raise SceneError(
            f"{what} '{text}': no quantity in it (e.g. tip_uz@end, "
            f"rate(centroid_x, 1, 2), steady(front_ux_rate))"
        )
    formula_text, last = "", 0
    for (a, b), name in pieces:
        formula_text += text[last:a] + f" {name} "
        last = b
    formula_text += text[last:]
    names = tuple(f"q{i}" for i in range(len(found)))
    try:
        formula = expressions.parse(formula_text, what, names)
    except SceneError as exc:
        raise SceneError(f"{what} '{text}': {_plain(str(exc))}") from None
    return Objective(text, formula, tuple(found))


def _operands(
    text: str, what: str
) -> tuple[list[tuple[tuple[int, int], str]], list[quantities.Quantity | SceneValue]]:
    """The quantities and scene values of a formula, in order, with the span of each in
    ``text`` and the name (``q0``, ``q1``, ...) it has in the arithmetic."""
    pieces, found, pos = [], [], 0
    while pos < len(text):
        m = _NAME.search(text, pos)
        if m is None:
            break
        name, end = m.group(), m.end()
        rest = text[end:]
        after = end + len(rest) - len(rest.lstrip())
        if name == "scene" and after < len(text) and text[after] == "(":
            span = (m.start(), _closing(text, after, what))
            found.append(_scene_value(text, span, after, what))
        else:
            span = _quantity_span(text, m, after, what)
            if span is None:
                pos = end
                continue
            try:
                found.append(quantities.parse(text[span[0] : span[1]]))
            except SceneError as exc:
                raise SceneError(f"{what}: {exc}") from None
        pieces.append((span, f"q{len(found) - 1}"))
        pos = span[1]
    return pieces, found


def _scene_value(text: str, span: tuple[int, int], open_at: int, what: str) -> SceneValue:
    """``scene(KEY)`` at ``span`` of ``text``, its '(' at ``open_at``."""
    key = text[open_at + 1 : span[1] - 1].strip()
    if not re.fullmatch(r"[A-Za-z0-9_-]+(\.[A-Za-z0-9_-]+)*", key):
        raise SceneError(
            f"{what} '{text}': expected a dotted scene key in scene(...), found '{key}'"
        )
    return SceneValue(text[span[0] : span[1]], key)


def _quantity_span(text: str, m: re.Match, after: int, what: str) -> tuple[int, int] | None:
    """Where the quantity that starts with the name ``m`` ends (a call or ``NAME@TIME``);
    None if the name is not a quantity's (a function or a variable of the formula)."""
    name = m.group()
    if after < len(text) and text[after] == "(" and _is_quantity_call(name, text, after):
        return (m.start(), _closing(text, after, what))
    if after < len(text) and text[after] == "@":
        t = _TIME.match(text, after + 1)
        if t is None:
            raise SceneError(
                f"{what} '{text}': expected a time (a number, 'start' or 'end') after '{name}@'"
            )
        return (m.start(), t.end())
    return None


def _plain(message: str) -> str:
    """An expression error without its position in the text with placeholders."""
    message = message.split(": ", 1)[-1]
    return re.sub(r" at position \d+ in formula .*$", "", message, flags=re.S)


__all__ = ["Objective", "SceneValue", "parse"]
