"""A run's folder seen from Python: :class:`Result` (docs/python.md).

``rftfem.run`` returns one; ``rftfem.Result(folder)`` opens any run folder, also
one that failed or is still being written. The tables are read when first asked
for and parsed by rftfem's own CSV reader (the numbers are the bits the run
wrote; rows a killed run left incomplete are dropped). A result pickles as its
folder's path.
"""

from __future__ import annotations

import json
import os
import re
from pathlib import Path
from typing import TYPE_CHECKING

from rftfem.errors import SceneError

if TYPE_CHECKING:  # (pandas and pyvista are imported when first used)
    import pandas as pd
    import pyvista

__all__ = ["Result"]

#: the attribute, the file, and what it holds
_TABLES = {"probes": "probes.csv", "body": "body.csv", "steps": "steps.csv"}


class Result:
    """The outputs of one run in ``folder``: ``.probes``, ``.body`` and ``.steps``
    (pandas DataFrames with a ``time`` column), ``.summary`` (summary.json as a
    dict), ``.quantity(expr)``, ``.fields(t)`` and ``.render(...)``."""

    def __init__(self, folder: str | os.PathLike):
        self.folder = Path(folder)
        if not self.folder.is_dir():
            raise SceneError(
                f"{self.folder}: no such run folder"
                if not self.folder.exists()
                else f"{self.folder}: not a folder"
            )
        if not any((self.folder / f).is_file() for f in ("summary.json", *_TABLES.values())):
            raise SceneError(
                f"{self.folder}: not a run folder (no summary.json, {', '.join(_TABLES.values())})"
            )
        self._cache: dict = {}

    # --- tables ------------------------------------------------------------------

    def _table(self, name: str):
        if name not in self._cache:
            import pandas as pd

            from rftfem.outputs.quantities import read_csv

            path = self.folder / _TABLES[name]
            if not path.is_file():
                raise SceneError(f"{path}: this run wrote no {_TABLES[name]}")
            header, rows = read_csv(path)
            self._cache[name] = pd.DataFrame(rows, columns=header)
        return self._cache[name].copy()

    @property
    def probes(self) -> pd.DataFrame:
        """probes.csv: the probes' displacements at each output time."""
        return self._table("probes")

    @property
    def body(self) -> pd.DataFrame:
        """body.csv: the body's resultants (centroid, energies, fluid and reactions)."""
        return self._table("body")

    @property
    def steps(self) -> pd.DataFrame:
        """steps.csv: every time step's size, Newton iterations, residual and wall time."""
        return self._table("steps")

    @property
    def summary(self) -> dict:
        """summary.json (read again at each access: a running run rewrites it)."""
        path = self.folder / "summary.json"
        if not path.is_file():
            raise SceneError(f"{path}: missing (the run has not written its summary)")
        try:
            return json.loads(path.read_text(encoding="utf-8"))
        except ValueError as exc:
            raise SceneError(f"{path}: not valid JSON ({exc})") from None

    @property
    def status(self) -> str:
        """ "ok", "failed" or "interrupted", from the summary; "running" for a run that
        has not written its summary's last word: one still going, or one killed
        without a chance to (SIGKILL, a node that died).  A summary older than the
        tables is a newer run's in an old folder: "running" too (as ``rftfem
        collect``'s "running-or-interrupted")."""
        from rftfem.outputs.quantities import RunFolder

        try:
            status = RunFolder(self.folder).status
        except SceneError:  # summary.json half written
            return "running"
        return "running" if status in ("running-or-interrupted", "missing-summary") else status

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    def quantity(self, expr: str) -> float:
        """The value of a formula of quantities, as ``rftfem collect --quantity``
        computes it (``rate(front_ux, 1, 2)``, ``steady(front_ux)``,
        ``rate(c_x, 2, 4) / scene(magnetic.field.frequency)``, ...)."""
        from rftfem.outputs import formulas

        return formulas.parse(expr, "quantity").evaluate(self.folder)

    # --- fields and pictures -----------------------------------------------------

    @property
    def times(self) -> list[float]:
        """The times at which fields were written."""
        return [float(t) for t in self._fields().times]

    def _fields(self):
        if "fields" not in self._cache:
            try:
                from rftfem.outputs.render_view import RunFields
            except RuntimeError as exc:  # dolfinx came first (rftfem/outputs/compat_render.py)
                raise RuntimeError(
                    "Result.fields needs pyvista, which cannot join a process that imported "
                    "dolfinx before it on this stack: call rftfem.run (or import "
                    "rftfem.outputs.render) before importing dolfinx, or open the Result in "
                    f"another process ({exc})"
                ) from None

            self._cache["fields"] = RunFields(self.folder)
        return self._cache["fields"]

    def fields(self, t: float | None = None, warp: bool = False) -> pyvista.DataSet:
        """A pyvista mesh of the fields written at the output time nearest ``t``
        (default: the last), in reference coordinates with the point arrays
        ``displacement``, ``director`` (and ``magnetization``); ``warp=True`` moves
        the points to the deformed positions."""
        import numpy as np

        run = self._fields()
        i = len(run.times) - 1 if t is None else run.nearest(float(t))
        mesh = run.reference.copy()
        for name, values in run.frame(i).items():
            mesh.point_data[name] = values
        if warp:
            mesh.points = np.asarray(run.reference_points + mesh.point_data["displacement"])
        mesh.field_data["time"] = [float(run.times[i])]
        return mesh

    def render(self, out: str | os.PathLike | None = None, **options: str | float | None) -> Path:
        """Draw the run as ``rftfem render`` does and return the file: ``out``
        ending in .png is a picture (default render.png in the folder), .mp4 or .gif
        a film; ``options`` are render's, by their command-line names (``color``,
        ``time``, ``view``, ``trail``, ``scale``, ``fps``, ``every``, ``size`` as
        "WxH"). Drawn in this process if pyvista can join it, else in a child
        process (after dolfinx was imported first, see rftfem/outputs/compat_render.py)."""
        import argparse

        from rftfem.outputs import render_cli
        from rftfem.outputs.compat_render import import_pyvista

        class Parser(argparse.ArgumentParser):
            def error(self, message: str):  # one line, not argparse's usage and exit
                raise SceneError(f"render: {message}")

        out = Path(out) if out is not None else self.folder / "render.png"
        parser = Parser(prog="rftfem render", add_help=False, allow_abbrev=False)
        render_cli.add_arguments(parser)
        # by their exact names (argparse would take "col" for color)
        names = [a.dest for a in parser._actions if a.option_strings and a.dest != "out"]
        unknown = [name for name in options if name not in names]
        if unknown:
            raise SceneError(
                f"render: unknown option{'s' * (len(unknown) > 1)} "
                f"{', '.join(unknown)} (render takes {', '.join(names)})"
            )
        argv = [str(self.folder), "--out", str(out)]
        for name, value in options.items():
            if value is not None:
                argv += [f"--{name.replace('_', '-')}", str(value)]
        args = parser.parse_args(argv)
        try:
            import_pyvista()
        except RuntimeError:
            done = render_cli.draw_in_child(*argv[:1], out, *argv[3:])
            if done.returncode != 0:
                lines = (done.stderr or done.stdout).strip().splitlines()
                message = lines[-1] if lines else f"exit status {done.returncode}"
                raise SceneError(re.sub(r"^rftfem( render)?: error: ", "", message))
            return out
        render_cli.main(args, _Silent())
        return out

    # --- Python ------------------------------------------------------------------

    def __getstate__(self) -> dict:
        return {"folder": str(self.folder)}

    def __setstate__(self, state: dict) -> None:
        self.folder, self._cache = Path(state["folder"]), {}

    def __fspath__(self) -> str:
        return str(self.folder)

    def __repr__(self) -> str:
        try:
            status = self.status
        except SceneError:
            status = "no summary"
        return f"<rftfem.Result {str(self.folder)!r} ({status})>"


class _Silent:
    """A console that says nothing (render_cli.main reports through one)."""

    def out(self, text: str) -> None:
        pass
