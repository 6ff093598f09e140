"""``rftfem collect``: one table row per run folder of a parameter study.

    rftfem collect DIR... [--out TABLE.csv] [--quantity NAME=EXPR ...]

Each DIR is a folder written by ``rftfem run --out DIR``.  The table (CSV, on
stdout without ``--out``) has one row per folder, in the order given:

* ``folder``, ``status`` and ``failure`` (the reason of a failed run).  The
  status is ``ok``, ``failed``, ``running-or-interrupted`` (the summary says
  "running", or probes.csv, steps.csv or body.csv were written more than a second
  after summary.json: a newer run writes into an old folder, or was killed; the
  old summary is then ignored) or ``missing-summary`` (the run's CSV files but no
  summary.json: a run still starting, or killed);
* one column per scene key whose value differs across the collected runs, named
  by its key path as for ``--set`` (``time.dt``, ``load.0.value``), with the
  values of each run's validated scene in summary.json (so runs made from
  different scene files show too; ``scene_file`` when those differ), then
  ``overrides``: the run's ``--set`` strings joined by ``;``;
* ``steps``, ``newton_iterations``, ``dt_cuts``, ``time_reached``,
  ``wall_total_s``, ``dofs``, ``mpi_size`` (copied from summary.json);
* one column per ``--quantity``.

Quantities
----------
A quantity reads one column of the run's probes.csv (``<probe>_ux``,
``_uy``, ``_uz``: displacements of material points) or body.csv (``centroid_x``,
``elastic_energy``, ``drag_power``, ...), as a function of the ``time`` column,
linearly interpolated between rows::

    quantity := COLUMN "@" TIME                       value at TIME
              | FUNC "(" COLUMN ["," TIME ["," TIME]] ")"
    FUNC     := "rate"     (x(b) - x(a)) / (b - a): mean rate, e.g. a swimming speed
              | "mean"     time average over [a, b] (trapezoid rule on the rows)
              | "max" | "min"   extreme over [a, b] (rows and the interpolated ends)
    TIME     := NUMBER | "start" | "end"              (first / last row of the run)

A window ``(COLUMN)`` is the whole run, ``(COLUMN, a)`` is ``[a, end]``.
Examples: ``tip_uz@end``, ``tip_uz@2.5``, ``rate(front_ux, 1, 2)``,
``mean(drag_power, 1)``, ``max(elastic_energy)``.  ``--quantity EXPR`` without
``NAME=`` names the column by the expression.

A bad expression, an unknown column (the valid ones are listed) or a time outside
the rows of a run whose status is ``ok`` is an error (exit status 2, one line).
In a run that did not finish (failed, interrupted), a quantity it has no data for
is an empty cell.  The table is written whenever every folder could be read, also
with failed runs (exit status 0); one line on stderr sums the statuses up.

The functions are an API for other tools: ``parse(expr) -> Quantity``,
``Quantity.evaluate(run) -> float``, ``evaluate(expr, run_dir) -> float``,
``RunFolder(run_dir)``, ``collect(dirs, quantities) -> (header, rows)``, and the
array functions ``value_at``, ``rate``, ``mean``, ``extreme``.
"""

from __future__ import annotations

import csv
import io
import json
import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rftfem.errors import SceneError

DESCRIPTION = """\
Tabulate run folders of a parameter study (CSV, one row per folder): status and
failure reason, the scene keys that differ between the runs (values from each
run's summary.json), the --set overrides, counts, wall time, dofs, and
quantities computed from probes.csv and body.csv."""

EPILOG = """\
quantities (--quantity NAME=EXPR, repeatable):
  COLUMN@TIME                     value at TIME (linear interpolation), TIME a
                                  number, 'start' or 'end' (first/last row)
  rate(COLUMN[, A[, B]])          (x(B) - x(A)) / (B - A), e.g. a swimming speed
  mean(COLUMN[, A[, B]])          time average over [A, B] (trapezoid rule)
  max(COLUMN[, A[, B]]), min(...) extreme over [A, B]
  COLUMN: a column of probes.csv (<probe>_ux/_uy/_uz) or body.csv (centroid_x,
  elastic_energy, drag_power, ...); window bounds default to start and end.
  A time outside a finished run is an error; a quantity that a failed or
  interrupted run has no data for is an empty cell.
examples:
  rftfem collect results/sweep/* --quantity tip=tip_uz@end
  rftfem collect runs/a runs/b --out table.csv --quantity 'speed=rate(front_ux, 1, 2)' \\
      --quantity 'power=mean(drag_power, 1, 2)'
exit status: 0 table written (also with failed runs), 2 bad option, folder or
quantity"""

#: files of a run that hold time series (searched in this order)
SERIES_FILES = ("probes.csv", "body.csv")
#: files whose presence marks a folder as a run folder (without summary.json)
RUN_FILES = ("probes.csv", "steps.csv", "body.csv")
FUNCTIONS = ("rate", "mean", "max", "min")
#: seconds by which a CSV file may be newer than summary.json in a finished run
STALE_SUMMARY_S = 1.0
#: columns of every row, before the distinguishing keys and after them
LEAD_COLUMNS = ("folder", "status", "failure")
COUNT_COLUMNS = ("steps", "newton_iterations", "dt_cuts", "time_reached", "wall_total_s",
                 "dofs", "mpi_size")


class Unavailable(SceneError):
    """The run has no data for this quantity (no such file, or the time is past its
    last row): an empty cell in a run that did not finish, an error otherwise."""


# --- the quantity language --------------------------------------------------------

_TOKEN = re.compile(r"\s*(?:(?P<num>[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)"
                    r"|(?P<name>[A-Za-z_][A-Za-z0-9_-]*)|(?P<op>[(),@])|(?P<bad>\S))")


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

    def evaluate(self, run: "RunFolder | str | Path") -> float:
        run = run if isinstance(run, RunFolder) else RunFolder(run)
        t, x = run.series(self.column, self.text)
        if len(t) == 0:
            raise Unavailable(f"quantity '{self.text}': {run.dir}: no rows in "
                              f"{run.file_of(self.column)}")
        if self.func == "at":
            return value_at(t, x, _time(self.a, t, self.text, run))
        a, b = _time(self.a, t, self.text, run), _time(self.b, t, self.text, run)
        if not b > a:  # with b = end: the run stopped before a
            cls = Unavailable if self.b == "end" else SceneError
            raise cls(f"quantity '{self.text}': empty window [{a:g}, {b:g}] in {run.dir}")
        if self.func == "rate":
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
            raise SceneError(f"quantity '{text}': unknown function '{head}' "
                             f"(known: {', '.join(FUNCTIONS)})")
        take(value="(", what="'('")
        column = take("name", what="a column name")
        bounds = []
        while pos < len(toks) and toks[pos][1] == "," and len(bounds) < 2:
            take(value=",", what="','")
            bounds.append(time_value())
        take(value=")", what="')'" if len(bounds) < 2 else "')' (at most two times)")
        a, b = [*bounds, "start", "end"][:2] if len(bounds) != 1 else (bounds[0], "end")
        q = Quantity(text, head, column, a, b)
    elif head in FUNCTIONS and pos >= len(toks):
        raise SceneError(f"quantity '{text}': expected '(' after '{head}'")
    else:
        take(value="@", what="'@' and a time (e.g. tip_uz@end) or a function "
                            f"({', '.join(FUNCTIONS)})")
        q = Quantity(text, "at", head, time_value(), "end")
    if pos < len(toks):
        raise SceneError(f"quantity '{text}': unexpected '{toks[pos][1]}' after the expression")
    for bound in (q.a, q.b):
        if isinstance(bound, float) and not math.isfinite(bound):
            raise SceneError(f"quantity '{text}': times must be finite")
    if isinstance(q.a, float) and isinstance(q.b, float) and q.func != "at" and not q.b > q.a:
        raise SceneError(f"quantity '{text}': the window needs A < B")
    return q


def evaluate(expr: str, run_dir) -> float:
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
        raise cls(f"quantity '{text}': time {bound:g} is outside the run {run.dir} "
                  f"(rows from {t[0]:g} to {t[-1]:g})")
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


def rate(t, x, a: float, b: float) -> float:
    """Mean rate of change over [a, b]: (x(b) - x(a)) / (b - a)."""
    return (value_at(t, x, b) - value_at(t, x, a)) / (b - a)


def _window(t, x, a: float, b: float) -> tuple[np.ndarray, np.ndarray]:
    """The piecewise-linear x on [a, b]: interpolated ends and the rows between."""
    t, x = np.asarray(t, dtype=float), np.asarray(x, dtype=float)
    inside = (t > a) & (t < b)
    tw = np.concatenate(([a], t[inside], [b]))
    xw = np.concatenate(([value_at(t, x, a)], x[inside], [value_at(t, x, b)]))
    return tw, xw


def mean(t, x, a: float, b: float) -> float:
    """Time average of the piecewise-linear x over [a, b] (trapezoid rule)."""
    tw, xw = _window(t, x, a, b)
    return float(np.sum(0.5 * (xw[1:] + xw[:-1]) * np.diff(tw)) / (b - a))


def extreme(t, x, a: float, b: float, which: str = "max") -> float:
    """Largest (``which="max"``) or smallest value of x over [a, b]."""
    _, xw = _window(t, x, a, b)
    return float(xw.max() if which == "max" else xw.min())


# --- run folders -------------------------------------------------------------------


class RunFolder:
    """A results folder of ``rftfem run``: its summary (None if missing), its status,
    and its time series (read on demand)."""

    def __init__(self, path):
        self.dir = Path(path)
        if not self.dir.is_dir():
            raise SceneError(f"{self.dir}: no such folder" if not self.dir.exists()
                             else f"{self.dir}: not a folder")
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
            raise SceneError(f"{self.dir}: not a run folder (no summary.json, "
                             f"{', '.join(RUN_FILES)})")
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
        return any((self.dir / f).is_file()
                   and (self.dir / f).stat().st_mtime > written + STALE_SUMMARY_S
                   for f in RUN_FILES)

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
        return {name: [c for c in table[0] if c != "time"]
                for name in SERIES_FILES if (table := self._table(name)) is not None}

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
                raise Unavailable(f"quantity '{text}': {self.dir} has no "
                                  f"{' or '.join(SERIES_FILES)}")
            valid = ", ".join(c for cols in columns.values() for c in cols)
            raise SceneError(f"quantity '{text}': unknown column '{column}' in {self.dir} "
                             f"(valid: {valid})")
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


# --- the table ---------------------------------------------------------------------


def _flatten(value, prefix: str = "", out: dict | None = None) -> dict:
    """Scene keys by key path (``time.dt``, ``load.0.value``): tables and arrays of
    tables are walked, everything else is a leaf."""
    out = {} if out is None else out
    if isinstance(value, dict):
        for key, sub in value.items():
            _flatten(sub, f"{prefix}.{key}" if prefix else str(key), out)
    elif isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
        for i, sub in enumerate(value):
            _flatten(sub, f"{prefix}.{i}" if prefix else str(i), out)
    else:
        out[prefix] = value
    return out


def _cell(value) -> str:
    """A scene value as a table cell: numbers exactly (repr), true/false, strings
    as they are, arrays compact (``[8,1]``), absent or null as ''."""
    if value is None:
        return ""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(value)
    if isinstance(value, (int, str)):
        return str(value)
    return json.dumps(value, separators=(",", ":"))


def differing_keys(runs: list[RunFolder]) -> list[str]:
    """Scene key paths (and ``scene_file``) whose cells differ across the runs that
    have a summary, in the order of the scenes (``scene_file`` last)."""
    flat = [{k: _cell(v) for k, v in _flatten(run.summary.get("scene", {})).items()}
            for run in runs if run.summary is not None]
    files = [_cell(run.summary.get("scene_file")) for run in runs if run.summary is not None]
    order: dict[str, None] = {}
    for keys in flat:
        order.update(dict.fromkeys(keys))
    differ = [k for k in order if len({keys.get(k, "") for keys in flat}) > 1]
    return differ + (["scene_file"] if len(set(files)) > 1 else [])


def _number(value) -> str:
    if value is None:
        return ""
    if isinstance(value, float):
        return repr(value)
    return str(value)


def collect(dirs, quantities: list[tuple[str, Quantity]] = ()
            ) -> tuple[list[str], list[list[str]], list[RunFolder]]:
    """The table: header, rows of strings (one per folder), and the RunFolders.
    ``quantities`` is a list of (column name, Quantity)."""
    runs = [RunFolder(d) for d in dirs]
    keys = differing_keys(runs)
    fixed = [*LEAD_COLUMNS, *keys, "overrides", *COUNT_COLUMNS]
    names = [n for n, _ in quantities]
    for name in names:
        if names.count(name) > 1 or name in fixed:
            raise SceneError(f"--quantity: the name '{name}' is "
                             + ("given twice" if name not in fixed else "already a column"))
    header = [*fixed, *names]
    rows = []
    for d, run in zip(dirs, runs):
        s = run.summary or {}
        flat = {k: _cell(v) for k, v in _flatten(s.get("scene", {})).items()}
        flat["scene_file"] = _cell(s.get("scene_file"))
        failure = s.get("failure") or {}
        counts, wall = s.get("counts") or {}, s.get("wall_s") or {}
        row = [str(d), run.status, str(failure.get("reason", "") or "")]
        row += [flat.get(k, "") for k in keys]
        row.append(";".join(s.get("overrides", []) or []))
        row += [_number(counts.get("steps")), _number(counts.get("newton_iterations")),
                _number(counts.get("dt_cuts")), _number(s.get("time_reached")),
                _number(wall.get("total")), _number(s.get("dofs")), _number(s.get("mpi_size"))]
        for _, q in quantities:
            try:
                row.append(repr(q.evaluate(run)))
            except Unavailable:
                if run.status == "ok":
                    raise
                row.append("")
        rows.append(row)
    return header, rows, runs


def to_csv(header: list[str], rows: list[list[str]]) -> str:
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(header)
    writer.writerows(rows)
    return buf.getvalue()


def parse_option(option: str) -> tuple[str, Quantity]:
    """``NAME=EXPR`` (or a bare ``EXPR``, named by itself) of ``--quantity``."""
    name, sep, expr = option.partition("=")
    if not sep:
        name, expr = "".join(option.split()), option
    name = name.strip()
    if not name:
        raise SceneError(f"--quantity '{option}': no name before '=' (NAME=EXPR)")
    return name, parse(expr)


def summary_line(runs: list[RunFolder], dirs) -> str:
    """'3 runs: 2 ok, 1 failed (dir)': folders named for every status but ok."""
    by_status: dict[str, list[str]] = {}
    for d, run in zip(dirs, runs):
        by_status.setdefault(run.status, []).append(str(d))
    parts = []
    for status in ("ok", "failed", "running-or-interrupted", "missing-summary",
                   *sorted(set(by_status) - {"ok", "failed", "running-or-interrupted",
                                             "missing-summary"})):
        if status in by_status:
            names = "" if status == "ok" else f" ({', '.join(by_status[status])})"
            parts.append(f"{len(by_status[status])} {status}{names}")
    n = len(runs)
    return f"{n} run{'s' if n != 1 else ''}: " + ", ".join(parts)


# --- command line ------------------------------------------------------------------


def add_arguments(parser):
    import argparse

    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    parser.epilog = EPILOG
    parser.add_argument("dirs", nargs="+", metavar="DIR", help="run folders (rftfem run --out DIR)")
    parser.add_argument("--out", metavar="TABLE.csv", type=Path, default=None,
                        help="write the table there (default: print it)")
    parser.add_argument("--quantity", metavar="NAME=EXPR", action="append", default=[],
                        dest="quantities", help="a column computed from probes.csv or "
                        "body.csv (grammar below); repeatable")


def main(args, console) -> int:
    quantities = [parse_option(q) for q in args.quantities]
    header, rows, runs = collect(args.dirs, quantities)
    text = to_csv(header, rows)
    if args.out is None:
        console.out(text.rstrip("\n"))
    else:
        try:
            if args.out.parent != Path(""):
                args.out.parent.mkdir(parents=True, exist_ok=True)
            args.out.write_text(text, encoding="utf-8")
        except OSError as exc:
            raise SceneError(f"--out {args.out}: {exc.strerror or exc}") from None
    console.err(summary_line(runs, args.dirs)
                + (f"; table in {args.out}" if args.out is not None else ""))
    return 0
