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
written); on rows ``value_at``, ``rate``, ``mean``, ``extreme``.
"""

from __future__ import annotations

import csv
import json
import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rftfem.errors import SceneError

#: files of a run that hold time series (searched in this order)
SERIES_FILES = ("probes.csv", "body.csv")
#: files whose presence marks a folder as a run folder (without summary.json)
RUN_FILES = ("probes.csv", "steps.csv", "body.csv")
FUNCTIONS = ("rate", "mean", "max", "min", "spin", "steady")
#: spin(): the axis and the plane coordinates (p, q) that measure the angle atan2(q, p)
SPIN_AXES = {"x": (1, 2), "y": (2, 0), "z": (0, 1)}
#: seconds by which a CSV file may be newer than summary.json in a finished run
STALE_SUMMARY_S = 1.0


class Unavailable(SceneError):
    """The run has no data for this quantity (no such file, no rows, or the time is
    past its last row): an empty cell of ``rftfem collect`` in a run that did not
    finish, an error otherwise."""


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


def parse(text: str) -> Quantity:
    """Parse a quantity expression (grammar in the module docstring); SceneError if bad."""
    toks = _tokens(text)
    pos = 0

    def take(kind=None, value=None, what="") -> str:
        nonlocal pos
        if pos >= len(toks):
            raise SceneError(f"quantity '{text}': expected {what} at the end")
        k, v = toks[pos]
        if (kind and k != kind) or (value and v != value):
            raise SceneError(f"quantity '{text}': expected {what}, found '{v}'")
        pos += 1
        return v

    def time_value() -> float | str:
        k, v = toks[pos] if pos < len(toks) else ("", "")
        if k == "num" or v in ("start", "end"):
            take(what="a time")
            return float(v) if k == "num" else v
        return take("num", what="a time (a number, 'start' or 'end')")

    if not toks:
        raise SceneError("quantity '': empty expression")
    head = take("name", what="a column name or one of " + ", ".join(FUNCTIONS))
    if pos < len(toks) and toks[pos][1] == "(":
        if head not in FUNCTIONS:
            raise SceneError(
                f"quantity '{text}': unknown function '{head}' (known: {', '.join(FUNCTIONS)})"
            )
        take(value="(", what="'('")
        other = axis = ""
        if head == "spin":
            column = take("name", what="a probe name")
            take(value=",", what="',' and the second probe")
            other = take("name", what="a probe name")
            take(value=",", what="',' and an axis (x, y or z)")
            axis = take("name", what="an axis (x, y or z)")
            if axis not in SPIN_AXES:
                raise SceneError(f"quantity '{text}': expected an axis x, y or z, found '{axis}'")
        else:
            column = take(
                "name",
                what="a column name"
                if head != "steady"
                else "a steady value's name (e.g. centroid_x_rate)",
            )
        if head == "steady":
            take(value=")", what="')' (steady() takes a name and no times)")
            if pos < len(toks):
                raise SceneError(
                    f"quantity '{text}': unexpected '{toks[pos][1]}' after the expression"
                )
            return Quantity(text, head, column)
        bounds = []
        while pos < len(toks) and toks[pos][1] == "," and len(bounds) < 2:
            take(value=",", what="','")
            bounds.append(time_value())
        take(value=")", what="')'" if len(bounds) < 2 else "')' (at most two times)")
        a, b = [*bounds, "start", "end"][:2] if len(bounds) != 1 else (bounds[0], "end")
        q = Quantity(text, head, column, a, b, other, axis)
    elif head in FUNCTIONS and pos >= len(toks):
        raise SceneError(f"quantity '{text}': expected '(' after '{head}'")
    else:
        take(
            value="@",
            what=f"'@' and a time (e.g. tip_uz@end) or a function ({', '.join(FUNCTIONS)})",
        )
        q = Quantity(text, "at", head, time_value(), "end")
    if pos < len(toks):
        raise SceneError(f"quantity '{text}': unexpected '{toks[pos][1]}' after the expression")
    for bound in (q.a, q.b):
        if isinstance(bound, float) and not math.isfinite(bound):
            raise SceneError(f"quantity '{text}': times must be finite")
    if isinstance(q.a, float) and isinstance(q.b, float) and q.func != "at" and not q.b > q.a:
        raise SceneError(f"quantity '{text}': the window needs A < B")
    return q


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


# --- run folders -------------------------------------------------------------------


class RunFolder:
    """A results folder of ``rftfem run``: its summary (None if missing), its status,
    and its time series (read on demand)."""

    def __init__(self, path: str | Path):
        self.dir = Path(path)
        if not self.dir.is_dir():
            raise SceneError(
                f"{self.dir}: no such folder"
                if not self.dir.exists()
                else f"{self.dir}: not a folder"
            )
        summary_file = self.dir / "summary.json"
        self.summary = None
        if summary_file.is_file():
            try:
                self.summary = json.loads(summary_file.read_text(encoding="utf-8"))
            except (ValueError, UnicodeDecodeError) as exc:
                raise SceneError(f"{summary_file}: not valid JSON ({exc})") from None
            if not isinstance(self.summary, dict) or "status" not in self.summary:
                raise SceneError(f"{summary_file}: not a summary of rftfem run (no status)")
        elif not any((self.dir / f).is_file() for f in RUN_FILES):
            raise SceneError(
                f"{self.dir}: not a run folder (no summary.json, {', '.join(RUN_FILES)})"
            )
        #: summary.json of an older run: a newer one writes (or wrote) the CSV files
        self.stale = self.summary is not None and self._stale_summary()
        if self.stale:
            self.summary = None
        self._tables: dict[str, tuple[list[str], np.ndarray] | None] = {}

    @property
    def status(self) -> str:
        if self.stale or (self.summary is not None and self.summary["status"] == "running"):
            return "running-or-interrupted"
        if self.summary is None:
            return "missing-summary"
        return str(self.summary["status"])

    def _stale_summary(self) -> bool:
        written = (self.dir / "summary.json").stat().st_mtime
        return any(
            (self.dir / f).is_file() and (self.dir / f).stat().st_mtime > written + STALE_SUMMARY_S
            for f in RUN_FILES
        )

    def _table(self, name: str):
        if name not in self._tables:
            path = self.dir / name
            if not path.is_file():
                self._tables[name] = None
            else:
                self._tables[name] = read_csv(path)
        return self._tables[name]

    def columns(self) -> dict[str, list[str]]:
        """The columns of each series file present (without ``time``)."""
        return {
            name: [c for c in table[0] if c != "time"]
            for name in SERIES_FILES
            if (table := self._table(name)) is not None
        }

    def file_of(self, column: str) -> str | None:
        for name, cols in self.columns().items():
            if column in cols:
                return name
        return None

    def series(self, column: str, text: str = "") -> tuple[np.ndarray, np.ndarray]:
        """(time, values) of ``column``; SceneError naming the valid columns if unknown,
        Unavailable when the run has no series file at all."""
        columns = self.columns()
        name = self.file_of(column)
        if name is None:
            if not columns:
                raise Unavailable(
                    f"quantity '{text}': {self.dir} has no {' or '.join(SERIES_FILES)}"
                )
            # probes.csv and body.csv of a static run both end with load_factor
            valid = ", ".join(dict.fromkeys(c for cols in columns.values() for c in cols))
            raise SceneError(
                f"quantity '{text}': unknown column '{column}' in {self.dir} (valid: {valid})"
            )
        header, data = self._table(name)
        return data[:, header.index("time")], data[:, header.index(column)]


def read_csv(path: Path) -> tuple[list[str], np.ndarray]:
    """Header and rows (floats) of a run's CSV file.  Rows that are not complete
    (a run killed while writing) are left out; rows must be in time order."""
    with open(path, encoding="utf-8", newline="") as f:
        reader = csv.reader(f)
        header = next(reader, None)
        if not header or "time" not in header:
            raise SceneError(f"{path}: no header with a 'time' column")
        rows = []
        for row in reader:
            try:
                values = [float(v) for v in row]
            except ValueError:
                continue
            if len(values) == len(header):
                rows.append(values)
    data = np.array(rows, dtype=float).reshape(-1, len(header))
    if len(data) > 1 and np.any(np.diff(data[:, header.index("time")]) <= 0):
        raise SceneError(f"{path}: times are not increasing")
    return header, data
