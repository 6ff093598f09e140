"""A results folder of ``rftfem run`` as the quantities read it: its summary, its
status and its time series (probes.csv, body.csv)."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np

from rftfem.errors import SceneError

#: files of a run that hold time series (searched in this order)
SERIES_FILES = ("probes.csv", "body.csv")
#: files whose presence marks a folder as a run folder (without summary.json)
RUN_FILES = ("probes.csv", "steps.csv", "body.csv")
#: seconds by which a CSV file may be newer than summary.json in a finished run
STALE_SUMMARY_S = 1.0


class Unavailable(SceneError):
    """The run has no data for this quantity (no such file, no rows, or the time is
    past its last row): an empty cell of ``rftfem collect`` in a run that did not
    finish, an error otherwise."""


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
