"""Objectives and constraints of ``rftfem optimize``.

An objective is a formula of quantities (rftfem/outputs/formulas.py, the language
collect, sweep and study take too); ``scene(KEY)`` in it is the cost of a design:
``tip_uz@end + 0.1*scene(shell.thickness)``.  A constraint is ``EXPR <= V`` or
``EXPR >= V`` with V a number.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

from rftfem.errors import SceneError
from rftfem.outputs.formulas import Objective, SceneValue, parse


@dataclass(frozen=True)
class Constraint:
    """``objective <= bound`` (``sense`` "<=") or ``objective >= bound``."""

    text: str
    objective: Objective
    sense: str
    bound: float

    def violation(self, value: float) -> float:
        """How far ``value`` is outside the bound (0 when satisfied)."""
        excess = value - self.bound if self.sense == "<=" else self.bound - value
        return max(0.0, excess)


def parse_constraint(text: str) -> Constraint:
    """``EXPR <= V`` or ``EXPR >= V`` (V a finite number)."""
    m = (
        re.fullmatch(r"(.+?)(<=|>=)\s*([^<>=]+)", text.strip(), re.S)
        if isinstance(text, str)
        else None
    )
    if m is None:
        raise SceneError(
            f"--constraint '{text}': expected EXPR<=V or EXPR>=V "
            f"(e.g. 'mean(drag_power, 1, 2)<=2e-6')"
        )
    try:
        bound = float(m.group(3))
    except ValueError:
        raise SceneError(
            f"--constraint '{text}': expected a number after "
            f"'{m.group(2)}', found '{m.group(3).strip()}'"
        ) from None
    if not math.isfinite(bound):
        raise SceneError(f"--constraint '{text}': the bound must be finite")
    return Constraint(text, parse(m.group(1), "--constraint"), m.group(2), bound)


__all__ = ["Objective", "SceneValue", "Constraint", "parse", "parse_constraint"]
