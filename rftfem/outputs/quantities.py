"""Quantities of a run: numbers read off the time series of its results folder.

A quantity reads one column of the run's probes.csv (``<probe>_ux``, ``_uy``,
``_uz``: displacements of material points) or body.csv (``centroid_x``,
``elastic_energy``, ``drag_power``, ...), as a function of the ``time`` column,
linearly interpolated between rows::

    quantity := COLUMN "@" TIME                       value at TIME
              | FUNC "(" COLUMN ["," TIME ["," TIME]] ")"
    FUNC     := "rate"     (x(b) - x(a)) / (b - a): mean rate, e.g. a swimming speed
              | "mean"     time average over [a, b] (trapezoid rule on the rows)
              | "max" | "min"   extreme over [a, b] (rows and the interpolated ends)
              | "spin" "(" PROBE "," PROBE "," AXIS ["," TIME ["," TIME]] ")"
                           mean turning rate (rad per unit time) of the line from
                           the first probe to the second about AXIS (x, y or z):
                           its angle in the plane normal to AXIS, unwrapped
              | "steady" "(" NAME ")"   summary.json's steady value of a periodic run:
                           NAME_rate for a position (a speed), else the column
    TIME     := NUMBER | "start" | "end"              (first / last row of the run)

A window ``(COLUMN)`` is the whole run, ``(COLUMN, a)`` is ``[a, end]``.
Examples: ``tip_uz@end``, ``rate(front_ux, 1, 2)``, ``max(elastic_energy)``,
``steady(front_ux_rate)``.

A bad expression, an unknown column (the valid ones are named) or a time before
the first row is a SceneError; data the run does not have (no series file or no
rows, a time past its last row) is :class:`Unavailable`, a SceneError that a
caller may excuse in a run that did not finish (:class:`NotSteady` in any run).

API: ``evaluate(expr, run_dir)``; ``parse(expr).evaluate(run)``; ``RunFolder(run_dir)``
(summary, status, series); ``read_csv(path)`` (the complete rows, also of a log being
written; these two from :mod:`rftfem.outputs.run_folder`); on rows ``value_at``,
``rate``, ``mean``, ``extreme``.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rftfem.errors import SceneError
from rftfem.outputs.run_folder import (  # noqa: F401  (importable from here as before)
    RUN_FILES,
    SERIES_FILES,
    STALE_SUMMARY_S,
    RunFolder,
    Unavailable,
    read_csv,
)

FUNCTIONS = ("rate", "mean", "max", "min", "spin", "steady")
#: spin(): the axis and the plane coordinates (p, q) that measure the angle atan2(q, p)
SPIN_AXES = {"x": (1, 2), "y": (2, 0), "z": (0, 1)}


class NotSteady(Unavailable):
    """steady(NAME) of a run not steady by time.end: an empty cell, though it finished."""


# --- the quantity language --------------------------------------------------------

_TOKEN = re.compile(
    r"\s*(?:(?P<num>[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)"
    r"|(?P<name>[A-Za-z_][A-Za-z0-9_-]*)|(?P<op>[(),@])|(?P<bad>\S))"
)


def _tokens(text: str) -> list[tuple[str, str]]:
    out = []
    for m in _TOKEN.finditer(text):
        kind = m.lastgroup
        if kind is None:  # trailing blanks
            continue
        if kind == "bad":
            raise SceneError(f"quantity '{text}': unexpected '{m.group(kind)}'")
        out.append((kind, m.group(kind)))
    return out


@dataclass(frozen=True)
class Quantity:
    """A parsed quantity: ``func`` is "at", "rate", "mean", "max" or "min";
    ``a``/``b`` are numbers or "start"/"end" (for "at", ``a`` is the time)."""

    text: str
    func: str
    column: str
    a: float | str = "start"
    b: float | str = "end"
    #: spin(): the second probe and the axis (``column`` is the first probe)
    other: str = ""
    axis: str = ""

    def evaluate(self, run: "RunFolder | str | Path") -> float:
        run = run if isinstance(run, RunFolder) else RunFolder(run)
        if self.func == "steady":
            return steady_value(run, self.column, self.text)
        if self.func == "spin":
            t, x = spin_angle(run, self.column, self.other, self.axis, self.text)
        else:
            t, x = run.series(self.column, self.text)
        if len(t) == 0:
            raise Unavailable(
                f"quantity '{self.text}': {run.dir}: no rows in {run.file_of(self.column)}"
            )
        if self.func == "at":
            return value_at(t, x, _time(self.a, t, self.text, run))
        a, b = _time(self.a, t, self.text, run), _time(self.b, t, self.text, run)
        if not b > a:  # with b = end: the run stopped before a
            cls = Unavailable if self.b == "end" else SceneError
            raise cls(f"quantity '{self.text}': empty window [{a:g}, {b:g}] in {run.dir}")
        if self.func in ("rate", "spin"):
            return rate(t, x, a, b)
        if self.func == "mean":
            return mean(t, x, a, b)
        return extreme(t, x, a, b, self.func)


class _Reader:
    """The tokens of a quantity expression, read from the left."""

    def __init__(self, text: str):
        self.text, self.toks, self.pos = text, _tokens(text), 0

    def more(self) -> bool:
        return self.pos < len(self.toks)

    def next_is(self, value: str) -> bool:
        return self.more() and self.toks[self.pos][1] == value

    def take(self, kind: str | None = None, value: str | None = None, what: str = "") -> str:
        if not self.more():
            raise SceneError(f"quantity '{self.text}': expected {what} at the end")
        k, v = self.toks[self.pos]
        if (kind and k != kind) or (value and v != value):
            raise SceneError(f"quantity '{self.text}': expected {what}, found '{v}'")
        self.pos += 1
        return v

    def time_value(self) -> float | str:
        k, v = self.toks[self.pos] if self.more() else ("", "")
        if k == "num" or v in ("start", "end"):
            self.take(what="a time")
            return float(v) if k == "num" else v
        return self.take("num", what="a time (a number, 'start' or 'end')")

    def end(self) -> None:
        """SceneError if anything follows the expression."""
        if self.more():
            found = self.toks[self.pos][1]
            raise SceneError(f"quantity '{self.text}': unexpected '{found}' after the expression")


def parse(text: str) -> Quantity:
    """Parse a quantity expression (grammar in the module docstring); SceneError if bad."""
    r = _Reader(text)
    if not r.toks:
        raise SceneError("quantity '': empty expression")
    head = r.take("name", what="a column name or one of " + ", ".join(FUNCTIONS))
    if r.next_is("("):
        if head not in FUNCTIONS:
            raise SceneError(
                f"quantity '{text}': unknown function '{head}' (known: {', '.join(FUNCTIONS)})"
            )
        r.take(value="(", what="'('")
        if head == "steady":
            return _steady_call(r)
        q = _function_call(r, head)
    elif head in FUNCTIONS and not r.more():
        raise SceneError(f"quantity '{text}': expected '(' after '{head}'")
    else:
        r.take(
            value="@",
            what=f"'@' and a time (e.g. tip_uz@end) or a function ({', '.join(FUNCTIONS)})",
        )
        q = Quantity(text, "at", head, r.time_value(), "end")
    r.end()
    for bound in (q.a, q.b):
        if isinstance(bound, float) and not math.isfinite(bound):
            raise SceneError(f"quantity '{text}': times must be finite")
    if isinstance(q.a, float) and isinstance(q.b, float) and q.func != "at" and not q.b > q.a:
        raise SceneError(f"quantity '{text}': the window needs A < B")
    return q


def _steady_call(r: _Reader) -> Quantity:
    """``steady(NAME)`` after its '(': a name and no times."""
    column = r.take("name", what="a steady value's name (e.g. centroid_x_rate)")
    r.take(value=")", what="')' (steady() takes a name and no times)")
    r.end()
    return Quantity(r.text, "steady", column)


def _function_call(r: _Reader, head: str) -> Quantity:
    """``FUNC(COLUMN[, A[, B]])`` or ``spin(PROBE, PROBE, AXIS[, A[, B]])`` after its '('."""
    other = axis = ""
    if head == "spin":
        column = r.take("name", what="a probe name")
        r.take(value=",", what="',' and the second probe")
        other = r.take("name", what="a probe name")
        r.take(value=",", what="',' and an axis (x, y or z)")
        axis = r.take("name", what="an axis (x, y or z)")
        if axis not in SPIN_AXES:
            raise SceneError(f"quantity '{r.text}': expected an axis x, y or z, found '{axis}'")
    else:
        column = r.take("name", what="a column name")
    bounds = []
    while r.next_is(",") and len(bounds) < 2:
        r.take(value=",", what="','")
        bounds.append(r.time_value())
    r.take(value=")", what="')'" if len(bounds) < 2 else "')' (at most two times)")
    a, b = [*bounds, "start", "end"][:2] if len(bounds) != 1 else (bounds[0], "end")
    return Quantity(r.text, head, column, a, b, other, axis)


def evaluate(expr: str, run_dir: RunFolder | str | Path) -> float:
    """The value of quantity ``expr`` in the run folder ``run_dir``."""
    return parse(expr).evaluate(run_dir)


def _time(bound, t: np.ndarray, text: str, run: "RunFolder") -> float:
    """A window bound as a time within the rows [t[0], t[-1]] (a round-off
    outside is clamped); Unavailable past the last row, SceneError before the first."""
    if bound == "start":
        return float(t[0])
    if bound == "end":
        return float(t[-1])
    tol = 1e-9 * max(1.0, abs(t[0]), abs(t[-1]))
    if bound < t[0] - tol or bound > t[-1] + tol:
        cls = Unavailable if bound > t[-1] else SceneError
        raise cls(
            f"quantity '{text}': time {bound:g} is outside the run {run.dir} "
            f"(rows from {t[0]:g} to {t[-1]:g})"
        )
    return float(min(max(bound, t[0]), t[-1]))


# --- functions on the rows ---------------------------------------------------------


def value_at(t: np.ndarray, x: np.ndarray, at: float) -> float:
    """x at time ``at``, linear between rows (a row's own value at its time)."""
    t, x = np.asarray(t, dtype=float), np.asarray(x, dtype=float)
    if not t[0] <= at <= t[-1]:
        raise ValueError(f"time {at} outside [{t[0]}, {t[-1]}]")
    hit = np.flatnonzero(t == at)
    if len(hit):
        return float(x[hit[-1]])
    j = int(np.searchsorted(t, at, side="right"))  # t[j-1] < at < t[j]
    w = (at - t[j - 1]) / (t[j] - t[j - 1])
    return float(x[j - 1] + w * (x[j] - x[j - 1]))


def rate(t: np.ndarray, x: np.ndarray, a: float, b: float) -> float:
    """Mean rate of change over [a, b]: (x(b) - x(a)) / (b - a)."""
    return (value_at(t, x, b) - value_at(t, x, a)) / (b - a)


def _window(t, x, a: float, b: float) -> tuple[np.ndarray, np.ndarray]:
    """The piecewise-linear x on [a, b]: interpolated ends and the rows between."""
    t, x = np.asarray(t, dtype=float), np.asarray(x, dtype=float)
    inside = (t > a) & (t < b)
    tw = np.concatenate(([a], t[inside], [b]))
    xw = np.concatenate(([value_at(t, x, a)], x[inside], [value_at(t, x, b)]))
    return tw, xw


def mean(t: np.ndarray, x: np.ndarray, a: float, b: float) -> float:
    """Time average of the piecewise-linear x over [a, b] (trapezoid rule)."""
    tw, xw = _window(t, x, a, b)
    return float(np.sum(0.5 * (xw[1:] + xw[:-1]) * np.diff(tw)) / (b - a))


def extreme(t: np.ndarray, x: np.ndarray, a: float, b: float, which: str = "max") -> float:
    """Largest (``which="max"``) or smallest value of x over [a, b]."""
    _, xw = _window(t, x, a, b)
    return float(xw.max() if which == "max" else xw.min())


def spin_angle(
    run: "RunFolder", first: str, second: str, axis: str, text: str = ""
) -> tuple[np.ndarray, np.ndarray]:
    """(time, angle): the angle about ``axis`` of the line from probe ``first`` to
    probe ``second`` (current positions: the scene's ``at`` plus the displacement
    columns), unwrapped so that whole turns add up."""
    if run.summary is None:
        raise Unavailable(
            f"quantity '{text}': {run.dir} has no summary.json with the probes' positions"
        )
    probes = {
        p.get("name"): p.get("at")
        for p in (run.summary.get("scene", {}).get("output", {}).get("probes") or [])
    }
    positions = []
    for name in (first, second):
        if name not in probes:
            raise SceneError(
                f"quantity '{text}': no probe '{name}' in {run.dir} "
                f"(probes: {', '.join(map(str, probes)) or 'none'})"
            )
        cols = [run.series(f"{name}_{c}", text) for c in ("ux", "uy", "uz")]
        t = cols[0][0]
        positions.append(
            np.asarray(probes[name], dtype=float) + np.stack([c[1] for c in cols], axis=1)
        )
    p, q = SPIN_AXES[axis]
    line = positions[1] - positions[0]
    return t, np.unwrap(np.arctan2(line[:, q], line[:, p]))


def steady_value(run: "RunFolder", name: str, text: str = "") -> float:
    """summary.json's extrapolated steady value ``name`` (docs/model.md §6.13)."""
    found = (run.summary or {}).get("steady")
    if run.summary is None:
        raise Unavailable(f"quantity '{text}': {run.dir} has no summary.json")
    if not found:
        raise SceneError(
            f"quantity '{text}': {run.dir} is not a run of time.until = "
            '"periodic" (summary.json has no steady values)'
        )
    values = found.get("values") or {}
    if name not in values and (values or found.get("reached")):
        raise SceneError(
            f"quantity '{text}': no steady value '{name}' in {run.dir} "
            f"(there: {', '.join(values) or 'none'})"
        )
    if not found.get("reached"):  # (too few periods for any value: the name is unchecked)
        raise NotSteady(
            f"quantity '{text}': {run.dir} stopped at time.end before it "
            f"was steady (after {found.get('periods')} periods)"
        )
    return float(values[name])
