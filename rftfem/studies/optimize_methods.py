"""The methods of ``rftfem optimize`` (rftfem/studies/optimize.py): scipy.optimize's on the
parameters mapped to the unit box, and a grid."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from rftfem.errors import SceneError
from rftfem.studies.optimize_evaluations import BudgetSpent

if TYPE_CHECKING:
    from collections.abc import Sequence
    from typing import Any

    import numpy as np

    from rftfem.studies.optimize_evaluations import Evaluator

METHODS = ("cobyla", "nelder-mead", "powell", "l-bfgs-b", "grid")
#: the parameters' change (as a fraction of each interval) at which a method stops
X_TOLERANCE = 1e-3
#: the first steps of a method, as a fraction of each interval
FIRST_STEP = 0.25


def search(method: str, ev: Evaluator, z0: Sequence[float], budget: int) -> str:
    """Run ``method`` from the unit point ``z0``; the reason it stopped."""
    import numpy as np
    from scipy import optimize

    n = len(z0)
    z0 = np.asarray(z0, float)
    bounds = [(0.0, 1.0)] * n
    try:
        if method == "grid":
            return _grid(ev, n, budget)
        if method == "nelder-mead":
            res = optimize.minimize(
                ev.merit,
                z0,
                method="Nelder-Mead",
                bounds=bounds,
                options={
                    "initial_simplex": _first_simplex(z0),
                    "xatol": X_TOLERANCE,
                    "fatol": math.inf,
                    "maxfev": 10 * budget,
                },
            )
        elif method == "powell":
            res = optimize.minimize(
                ev.merit,
                z0,
                method="Powell",
                bounds=bounds,
                options={
                    "xtol": X_TOLERANCE,
                    "ftol": 1e-9,
                    "direc": np.eye(n) * FIRST_STEP,
                    "maxfev": 10 * budget,
                },
            )
        elif method == "cobyla":
            res = _cobyla(ev, z0, budget)
        elif method == "l-bfgs-b":
            res = optimize.minimize(
                ev.merit_and_gradient,
                z0,
                jac=True,
                method="L-BFGS-B",
                bounds=bounds,
                options={"maxfun": 10 * budget, "ftol": 1e-12, "gtol": 1e-10},
            )
        else:  # guarded by the option check
            raise SceneError(f"--method: unknown method '{method}'")
    except BudgetSpent:
        return f"the budget of {budget} runs was spent"
    return f"{method} stopped: {' '.join(str(res.message).split())}"


def _grid(ev: Evaluator, n: int, budget: int) -> str:
    """A brute-force grid of the budget's size over the unit box, evaluated."""
    import numpy as np

    m = max(2, int(math.floor(budget ** (1.0 / n) + 1e-9)))
    axes = [np.linspace(0.0, 1.0, m)] * n
    grid = np.array(np.meshgrid(*axes, indexing="ij")).reshape(n, -1).T
    ev.merits(list(grid))
    return f"grid of {m}^{n} points evaluated"


def _first_simplex(z0: np.ndarray) -> np.ndarray:
    """Nelder-Mead's first simplex: ``z0`` and a first step along each axis (back, where
    forward leaves the box)."""
    import numpy as np

    n = len(z0)
    simplex = [z0] + [
        z0 + np.eye(n)[j] * (FIRST_STEP if z0[j] + FIRST_STEP <= 1 else -FIRST_STEP)
        for j in range(n)
    ]
    return np.array(simplex)


def _cobyla(ev: Evaluator, z0: np.ndarray, budget: int) -> Any:
    """COBYLA from ``z0``, the unit box and the constraints as its constraints."""
    from scipy import optimize

    n = len(z0)
    cons = [{"type": "ineq", "fun": lambda z, j=j: z[j]} for j in range(n)]
    cons += [{"type": "ineq", "fun": lambda z, j=j: 1.0 - z[j]} for j in range(n)]
    if ev.constraints:
        cons.append({"type": "ineq", "fun": ev.constraint_margins})
    objective = (lambda z: ev.sign * _value_or_merit(ev, z)) if ev.constraints else ev.merit
    # scipy's Fortran COBYLA calls back into Python and prints two lines of its
    # own when a callback raises: the stop (budget spent, a bad objective) is
    # kept instead, later calls return at once, and it is raised afterwards
    stop = _Stop()
    cons = [
        dict(c, fun=stop.guard(c["fun"], lambda z, k=k: [0.0] * k))
        for c, k in zip(cons, [1] * (2 * n) + [len(ev.constraints)])
    ]
    res = optimize.minimize(
        stop.guard(objective, lambda z: 0.0),
        z0,
        method="COBYLA",
        constraints=cons,
        options={"rhobeg": FIRST_STEP, "tol": X_TOLERANCE, "maxiter": 10 * budget},
    )
    stop.raise_kept()
    return res


class _Stop:
    """An exception raised by a callback, kept until the method returns."""

    def __init__(self):
        self.kept = None

    def guard(self, fun, fallback):
        def guarded(z):
            if self.kept is None:
                try:
                    return fun(z)
                except (BudgetSpent, SceneError) as exc:
                    self.kept = exc
            return fallback(z)

        return guarded

    def raise_kept(self):
        if self.kept is not None:
            raise self.kept


def _value_or_merit(ev: Evaluator, z) -> float:
    """COBYLA's objective with its constraints apart: the objective of a run (signed
    back by the caller), a failed run's merit otherwise."""
    e = ev.evaluate([z])[0]
    return e.objective if e.status in ("ok", "infeasible") else ev.sign * e.merit


def method_named(name: str) -> str:
    """The method ``--method NAME`` names (its usual spellings too)."""
    m = name.strip().lower().replace("_", "-")
    m = {
        "nelder-mead": "nelder-mead",
        "neldermead": "nelder-mead",
        "lbfgsb": "l-bfgs-b",
        "brute": "grid",
    }.get(m, m)
    if m not in METHODS:
        raise SceneError(f"--method: unknown method '{name}' (expected {', '.join(METHODS)})")
    return m


__all__ = ["search", "method_named", "METHODS", "X_TOLERANCE", "FIRST_STEP"]
