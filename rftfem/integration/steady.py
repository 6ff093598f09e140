"""Steady periodic states: ``time.until = "periodic"`` (docs/model.md §6.13).

A run driven periodically (a travelling wave, a rotating field) settles after
a start-up transient into a periodic state.  Over each period ``k`` the watched
value of every output column is

- for positions (the probes' and the centroid's columns), the drift over the
  period, ``D_k = M_k − M_{k−1}`` of the period means ``M`` (a swimmer's speed
  is ``D/T``);
- for everything else in body.csv (energies, power, field, moment,
  reactions), the period mean ``M_k``.

A transient that dies out exponentially makes the watched values converge
geometrically, ``V_k = V∞ + c r^k``, and Aitken's Δ² extrapolation of three
successive values,

    V∞ ≈ V_k − (ΔV_k)² / (ΔV_k − ΔV_{k−1}),

is exact for one such mode; Shanks' second transform of five (Wynn's ε
algorithm) for two, as an energy or a power quadratic in the transient has
(r and r²), and is taken where it stays near Aitken's.  The run stops at the
end of the first period whose extrapolation agrees with the last period's to
``time.steady_tolerance`` of the column's scale (its watched value, or its swing
over the period if larger; for a position, also the largest drift of any
position, the swim: a sideways drift near zero need not settle to a thousandth
of itself) for every column, and reports the extrapolated values and that
agreement as their estimated error.  Where a column's values do not converge
geometrically (|r| ≥ 1, or fewer than four periods) it is not yet steady.
"""

from __future__ import annotations

import math

import numpy as np

#: the fewest periods watched before a run may be found steady (the first holds the
#: start-up: four give three drifts and two extrapolations to compare)
MIN_PERIODS = 4


#: a column below this share of the largest in its group is round-off about zero
FLOOR = 1e-9


def group_of(column: str) -> str:
    """Columns compared for size: positions, energies (the drag power with them), or
    the column alone."""
    if is_position(column):
        return "position"
    if column in ("elastic_energy", "kinetic_energy", "drag_power", "fluid_power"):
        return "energy"
    return column


def is_resultant(column: str) -> bool:
    """Whether a column is a component of a resultant force or moment (``fluid_Fx``,
    a reaction's ``NAME_Mz``)."""
    return column[-3:-2] == "_" and column[-2] in "FM" and column[-1] in "xyz"


def is_position(column: str) -> bool:
    """Whether a column is a position, whose drift over a period is watched."""
    return column.startswith("centroid_") or column.endswith(("_ux", "_uy", "_uz"))


def period_mean(t: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Trapezoidal mean over one period of rows (n, m) at times t (n)."""
    weights = np.zeros(len(t))
    dt = np.diff(t)
    weights[:-1] += dt / 2
    weights[1:] += dt / 2
    return weights @ values / (t[-1] - t[0])


def aitken(v: np.ndarray) -> np.ndarray:
    """Δ² extrapolation of the last three rows of ``v`` (k, m), per column; NaN where
    the differences do not shrink geometrically (|r| ≥ 1).  A column whose last two
    differences are both zero is its last value."""
    d1, d2 = v[-2] - v[-3], v[-1] - v[-2]
    out = np.full(v.shape[1], np.nan)
    still = (d1 == 0) & (d2 == 0)
    out[still] = v[-1, still]
    moving = ~still & (d1 != 0)
    ratio = np.where(moving, d2 / np.where(d1 == 0, 1, d1), np.inf)
    ok = moving & (np.abs(ratio) < 1)
    out[ok] = v[-1, ok] - d2[ok] ** 2 / (d2[ok] - d1[ok])
    return out


def shanks(v: np.ndarray) -> np.ndarray:
    """The limit of each column of ``v`` (k, m): Shanks' second transform of the last
    five rows (Wynn's ε algorithm), exact for two geometric modes (a quantity
    quadratic in a decaying transient, an energy or a power, has modes r and r²),
    where it is defined and no further from Aitken's value than the five rows'
    change or Aitken's own step (round-off makes it wild); else Aitken's Δ² of the
    last three rows."""
    out = aitken(v)
    if len(v) < 5:
        return out
    with np.errstate(divide="ignore", invalid="ignore"):
        for j in range(v.shape[1]):
            eps_prev = np.zeros(5)
            eps = v[-5:, j].astype(float)
            for _ in range(4):  # ε_1 … ε_4 of the five terms
                diff = np.diff(eps)
                nxt = eps_prev[1 : len(eps)] + 1.0 / diff
                eps_prev, eps = eps, nxt
            e2 = eps[0]
            bound = max(abs(v[-1, j] - v[-5, j]), abs(out[j] - v[-1, j]))
            if np.isfinite(e2) and np.isfinite(out[j]) and abs(e2 - out[j]) <= bound:
                out[j] = e2
    return out


class SteadyWatch:
    """Period by period, the watched values of the output columns and the test."""

    def __init__(self, period: float, tolerance: float, columns: list[str], method: str = "shanks"):
        """``method``: "shanks" (rftfem's), "aitken", or "none" (the watched values
        themselves: the transient run out), the last two for benchmarks/steady_state.py."""
        self.period, self.tolerance, self.columns = period, tolerance, columns
        self.method = method
        self.position = np.array([is_position(c) for c in columns])
        #: the columns the test reads: not the resultants (the liquid's, a reaction's),
        #: which follow from the state the others watch and about zero are round-off
        #: with no scale of their own (a free swimmer's net force)
        self.decides = np.array([not is_resultant(c) for c in columns], dtype=bool)
        self.means, self.swings, self.estimates = [], [], []
        #: the result once steady (or at the end): dict for summary.json
        self.result = None

    def add_period(self, t: np.ndarray, rows: np.ndarray) -> bool:
        """One period's output rows (its first row the last one of the period before);
        returns whether the run is steady."""
        self.means.append(period_mean(t, rows))
        self.swings.append(np.ptp(rows, axis=0))
        means = np.array(self.means)
        watched = np.where(self.position, np.diff(means, axis=0, prepend=np.nan), means)
        if len(means) >= 3:
            extrapolate = {
                "shanks": shanks,
                "aitken": lambda v: aitken(v[-3:]),
                "none": lambda v: v[-1],
            }[self.method]
            self.estimates.append(extrapolate(watched[-5:]))
        if len(means) < MIN_PERIODS or len(self.estimates) < 2:
            return False
        now, before = self.estimates[-1], self.estimates[-2]
        size = np.maximum(np.abs(watched[-1]), self.swings[-1])
        if self.position.any():  # a drift counts against the body's largest (its swim)
            drift = np.abs(watched[-1][self.position]).max()
            size = np.where(self.position, np.maximum(size, drift), size)
        scale = np.maximum(size, self._floors(size))
        agreement = np.abs(now - before)
        # a column that does not converge geometrically (round-off about zero) is
        # steady where its change over the period is below the tolerance
        change = np.abs(watched[-1] - watched[-2])
        agreement = np.where(np.isfinite(agreement), agreement, change)
        steady = bool(np.all((agreement <= self.tolerance * scale)[self.decides]))
        self._keep(now, agreement, watched[-1], steady)
        return steady

    def _floors(self, size: np.ndarray) -> np.ndarray:
        """Per column, ``FLOOR`` times the largest size in its group (positions; the
        energies, with the drag power times the period; each other column alone):
        below it a column is round-off about zero."""
        groups = [group_of(c) for c in self.columns]
        factor = np.array(
            [self.period if c in ("drag_power", "fluid_power") else 1.0 for c in self.columns]
        )
        sized = size * factor
        out = np.empty_like(size)
        for g in set(groups):
            mine = np.array([x == g for x in groups])
            out[mine] = FLOOR * sized[mine].max() / factor[mine]
        return out

    def _keep(self, values, errors, last, steady):
        out, err = {}, {}
        for name, pos, v, e, w in zip(self.columns, self.position, values, errors, last):
            key = f"{name}_rate" if pos else name
            factor = 1 / self.period if pos else 1.0
            out[key] = float(v * factor) if math.isfinite(v) else float(w * factor)
            err[key] = float(e * factor) if math.isfinite(e) else None
        self.result = {
            "reached": steady,
            "period": self.period,
            "periods": len(self.means),
            "tolerance": self.tolerance,
            "method": self.method,
            "values": out,
            "estimated_errors": err,
        }
