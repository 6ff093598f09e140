"""``rftfem collect``: one table row per run folder of a parameter study.

    rftfem collect DIR... [--out TABLE.csv] [--quantity NAME=EXPR ...]

Each DIR is a folder written by ``rftfem run --out DIR``.  The table (CSV, on
stdout without ``--out``) has one row per folder, in the order given:

* ``folder``, ``status`` and ``failure`` (the reason of a failed run).  The
  status is ``ok``, ``failed``, ``interrupted`` (stopped by SIGINT or SIGTERM;
  ``--restart`` goes on from its last checkpoint), ``running-or-interrupted`` (the summary says
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
* with runs of ``time.until = "periodic"``: ``steady.reached`` and
  ``steady.NAME`` for each extrapolated steady value (``steady.centroid_x_rate``,
  a swimming speed; ``steady.drag_power``), from summary.json;
* one column per ``--quantity``: an expression of :mod:`rftfem.outputs.quantities`
  (``tip_uz@end``, ``rate(front_ux, 1, 2)``, ``mean(drag_power, 1)``), named by
  ``NAME=`` or else by the expression.

A bad expression, an unknown column (the valid ones are listed) or a time outside
the rows of a run whose status is ``ok`` is an error (exit status 2, one line).
In a run that did not finish (failed, interrupted), a quantity it has no data for
is an empty cell.  The table is written whenever every folder could be read, also
with failed runs (exit status 0); one line on stderr sums the statuses up.

For other tools: ``collect(dirs, quantities) -> (header, rows, runs)``; the
quantity API (``parse``, ``evaluate``, ``RunFolder``, ``value_at``, ``rate``,
``mean``, ``extreme``) is importable from here as from :mod:`rftfem.outputs.quantities`.
"""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path
from typing import TYPE_CHECKING

from rftfem.errors import SceneError
from rftfem.outputs.quantities import (
    NotSteady,
    Quantity,
    RunFolder,
    Unavailable,
    evaluate,
    extreme,
    mean,
    parse,
    rate,
    value_at,
)

if TYPE_CHECKING:
    import argparse
    from collections.abc import Sequence
    from typing import Any

    from rftfem.outputs.formulas import Objective

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
  spin(PROBE_A, PROBE_B, AXIS[, A[, B]])
                                  mean turning rate of the line from probe A to
                                  probe B about AXIS (x, y or z), rad per unit time
  steady(NAME)                    a steady value of a time.until = "periodic" run
                                  (summary.json): NAME_rate for a position column,
                                  e.g. steady(centroid_x_rate); empty if the run
                                  reached time.end before it was steady
  COLUMN: a column of probes.csv (<probe>_ux/_uy/_uz) or body.csv (centroid_x,
  elastic_energy, drag_power, ...); window bounds default to start and end.
  A time before a run's first row is an error; a quantity a run has no data for
  (a window past its last row, a failed or interrupted run) is an empty cell, said
  on stderr for a finished run. Paths that are not run folders (a stray file in a
  glob) are skipped with a note.
examples:
  rftfem collect results/sweep/* --quantity tip=tip_uz@end
  rftfem collect runs/a runs/b --out table.csv --quantity 'speed=rate(front_ux, 1, 2)' \\
      --quantity 'power=mean(drag_power, 1, 2)'
exit status: 0 table written (also with failed runs), 2 bad option, folder or
quantity"""

#: columns of every row, before the distinguishing keys and after them
LEAD_COLUMNS = ("folder", "status", "failure")
COUNT_COLUMNS = (
    "steps",
    "newton_iterations",
    "dt_cuts",
    "time_reached",
    "wall_total_s",
    "dofs",
    "mpi_size",
)


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
    flat = [
        {k: _cell(v) for k, v in _flatten(run.summary.get("scene", {})).items()}
        for run in runs
        if run.summary is not None
    ]
    files = [_cell(run.summary.get("scene_file")) for run in runs if run.summary is not None]
    order: dict[str, None] = {}
    for keys in flat:
        order.update(dict.fromkeys(keys))
    differ = [k for k in order if len({keys.get(k, "") for keys in flat}) > 1]
    return differ + (["scene_file"] if len(set(files)) > 1 else [])


def steady_columns(runs: list[RunFolder]) -> list[str]:
    """``steady.reached`` and ``steady.NAME`` for every steady value of the runs that
    stopped on ``time.until = "periodic"`` (summary.json's ``steady``), in order."""
    order: dict[str, None] = {}
    for run in runs:
        found = (run.summary or {}).get("steady")
        if found:
            order.update(
                dict.fromkeys(
                    ["steady.reached"] + [f"steady.{k}" for k in (found.get("values") or {})]
                )
            )
    return list(order)


def _number(value) -> str:
    if value is None:
        return ""
    if isinstance(value, float):
        return repr(value)
    return str(value)


def collect(
    dirs: Sequence[str | Path],
    quantities: Sequence[tuple[str, Quantity | Objective]] = (),
    notes: list | None = None,
) -> tuple[list[str], list[list[str]], list[RunFolder]]:
    """The table: header, rows of strings (one per run folder), and the RunFolders.
    ``quantities`` is a list of (column name, Quantity).  Paths that are not run
    folders are left out, and a quantity a run has no data for (a window past its
    last row) is an empty cell; each is said in ``notes`` (a list to append to)."""
    notes = [] if notes is None else notes
    dirs, runs = _run_folders(dirs, notes)
    keys = differing_keys(runs)
    steady = steady_columns(runs)
    fixed = [*LEAD_COLUMNS, *keys, "overrides", *COUNT_COLUMNS, *steady]
    names = [n for n, _ in quantities]
    for name in names:
        if names.count(name) > 1 or name in fixed:
            raise SceneError(
                f"--quantity: the name '{name}' is "
                + ("given twice" if name not in fixed else "already a column")
            )
    header = [*fixed, *names]
    rows = []
    for d, run in zip(dirs, runs):
        row = _summary_cells(d, run, keys, steady)
        for _, q in quantities:
            try:
                row.append(repr(q.evaluate(run)))
            except Unavailable as exc:
                if run.status == "ok" and not isinstance(exc, NotSteady):
                    notes.append(f"{exc}: an empty cell")
                row.append("")
        rows.append(row)
    return header, rows, runs


def _run_folders(
    dirs: Sequence[str | Path], notes: list
) -> tuple[list[str | Path], list[RunFolder]]:
    """The run folders among ``dirs`` (paths and RunFolders); the rest said in ``notes``."""
    runs, kept = [], []
    for d in dirs:
        try:
            runs.append(RunFolder(d))
            kept.append(d)
        except SceneError as exc:
            notes.append(f"skipped {exc}")
    if not runs:
        raise SceneError("no run folders among the paths given (" + "; ".join(notes) + ")")
    return kept, runs


def _summary_cells(d: str | Path, run: RunFolder, keys: list[str], steady: list[str]) -> list[str]:
    """A run's row up to its quantities: folder, status, failure, the distinguishing
    keys, overrides, counts and steady values (from summary.json)."""
    s = run.summary or {}
    flat = {k: _cell(v) for k, v in _flatten(s.get("scene", {})).items()}
    flat["scene_file"] = _cell(s.get("scene_file"))
    failure = s.get("failure") or {}
    counts, wall = s.get("counts") or {}, s.get("wall_s") or {}
    row = [str(d), run.status, str(failure.get("reason", "") or "")]
    row += [flat.get(k, "") for k in keys]
    row.append(";".join(s.get("overrides", []) or []))
    row += [
        _number(counts.get("steps")),
        _number(counts.get("newton_iterations")),
        _number(counts.get("dt_cuts")),
        _number(s.get("time_reached")),
        _number(wall.get("total")),
        _number(s.get("dofs")),
        _number(s.get("mpi_size")),
    ]
    found = s.get("steady") or {}
    row += [
        _cell(found.get("reached"))
        if c == "steady.reached"
        else _number((found.get("values") or {}).get(c[len("steady.") :]))
        for c in steady
    ]
    return row


def to_csv(header: list[str], rows: list[list[str]]) -> str:
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(header)
    writer.writerows(rows)
    return buf.getvalue()


def parse_option(option: str) -> tuple[str, Objective]:
    """``NAME=EXPR`` (or a bare ``EXPR``, named by itself) of ``--quantity``."""
    name, sep, expr = option.partition("=")
    if not sep:
        name, expr = "".join(option.split()), option
    name = name.strip()
    if not name:
        raise SceneError(f"--quantity '{option}': no name before '=' (NAME=EXPR)")
    from rftfem.outputs import formulas

    return name, formulas.parse(expr, "--quantity")


def summary_line(runs: list[RunFolder], dirs: Sequence[str | Path]) -> str:
    """'3 runs: 2 ok, 1 failed (dir)': folders named for every status but ok."""
    by_status: dict[str, list[str]] = {}
    for d, run in zip(dirs, runs):
        by_status.setdefault(run.status, []).append(str(d))
    parts = []
    for status in (
        "ok",
        "failed",
        "running-or-interrupted",
        "missing-summary",
        *sorted(set(by_status) - {"ok", "failed", "running-or-interrupted", "missing-summary"}),
    ):
        if status in by_status:
            names = "" if status == "ok" else f" ({', '.join(by_status[status])})"
            parts.append(f"{len(by_status[status])} {status}{names}")
    n = len(runs)
    return f"{n} run{'s' if n != 1 else ''}: " + ", ".join(parts)


# --- command line ------------------------------------------------------------------


def add_arguments(parser: argparse.ArgumentParser) -> None:
    import argparse

    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    parser.epilog = EPILOG
    parser.add_argument("dirs", nargs="+", metavar="DIR", help="run folders (rftfem run --out DIR)")
    parser.add_argument(
        "--out",
        metavar="TABLE.csv",
        type=Path,
        default=None,
        help="write the table there (default: print it)",
    )
    parser.add_argument(
        "--quantity",
        metavar="NAME=EXPR",
        action="append",
        default=[],
        dest="quantities",
        help="a column computed from probes.csv or body.csv (grammar below); repeatable",
    )


def main(args: argparse.Namespace, console: Any) -> int:
    quantities = [parse_option(q) for q in args.quantities]
    notes = []
    header, rows, runs = collect(args.dirs, quantities, notes)
    for note in notes:
        console.err(f"rftfem collect: {note}")
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
    console.err(
        summary_line(runs, [run.dir for run in runs])
        + (f"; table in {args.out}" if args.out is not None else "")
    )
    return 0


__all__ = [
    "collect",
    "differing_keys",
    "to_csv",
    "parse_option",
    "summary_line",
    "add_arguments",
    "main",
    "DESCRIPTION",
    "EPILOG",
    "LEAD_COLUMNS",
    "COUNT_COLUMNS",
    # re-exported from rftfem.outputs.quantities
    "Quantity",
    "RunFolder",
    "Unavailable",
    "parse",
    "evaluate",
    "value_at",
    "rate",
    "mean",
    "extreme",
]
