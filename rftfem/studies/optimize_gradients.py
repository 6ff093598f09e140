"""The adjoint's gradient of an ``rftfem optimize`` evaluation: the objective's one run
quantity, its derivatives from gradient.json through the formula."""

from __future__ import annotations

import json
from typing import TYPE_CHECKING

from rftfem.studies.reuse import status_of

if TYPE_CHECKING:
    from pathlib import Path

    from rftfem.outputs.formulas import Objective
    from rftfem.outputs.quantities import Quantity, RunFolder
    from rftfem.studies.optimize_parameters import Parameter

__all__ = ["adjoint_quantity", "read_gradient", "without_gradient"]


def without_gradient(folder: Path) -> bool:
    """A finished run without the gradient.json that an adjoint search needs."""
    return status_of(folder) == "ok" and not (folder / "gradient.json").is_file()


def adjoint_quantity(objective: Objective) -> Quantity | None:
    """The one quantity of ``objective`` read from the run, or None if it has several
    (the others may be ``scene(KEY)`` values, whose derivatives are known)."""
    from rftfem.studies.objective import SceneValue

    read = [q for q in objective.quantities if not isinstance(q, SceneValue)]
    return read[0] if len(read) == 1 else None


def read_gradient(run: RunFolder, objective: Objective, params: list[Parameter]) -> list | None:
    """d objective / d parameter: the run quantity's derivative from gradient.json (the
    adjoint's), a ``scene(KEY)``'s 1 for its own key, through the formula by the chain
    rule (its partial derivatives by central differences)."""
    from rftfem.studies.objective import SceneValue

    try:
        data = json.loads((run.dir / "gradient.json").read_text(encoding="utf-8"))
        dq_run = [float(data["gradient"][p.key]) for p in params]
    except (OSError, ValueError, KeyError, TypeError):
        return None
    env = {f"q{i}": q.evaluate(run) for i, q in enumerate(objective.quantities)}
    total = [0.0] * len(params)
    for i, q in enumerate(objective.quantities):
        name, v = f"q{i}", env[f"q{i}"]
        h = 1e-6 * max(abs(v), 1e-300)
        up, down = dict(env, **{name: v + h}), dict(env, **{name: v - h})
        dfdq = (float(objective.formula.numbers(up)) - float(objective.formula.numbers(down))) / (
            2 * h
        )
        dq = (
            [1.0 if q.key == p.key else 0.0 for p in params]
            if isinstance(q, SceneValue)
            else dq_run
        )
        total = [t + dfdq * d for t, d in zip(total, dq)]
    return total
