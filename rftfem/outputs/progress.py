"""What a run tells while it runs: the progress line or bar and its warnings
(:class:`Progress`), and the picture a run draws at its end (``output.render``)."""

from __future__ import annotations

import math
import os
import sys
import time as _time
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from collections.abc import Callable
    from typing import TextIO

    from mpi4py import MPI


class Progress:
    """What a run tells while it runs, on rank 0.

    - on a terminal: a progress bar redrawn in place after every step;
    - elsewhere (CI, cluster logs, a pipe): a plain line at most every
      ``interval`` seconds (default 5 s, or ``RFTFEM_LOG_INTERVAL``), so a run of
      many cheap steps does not fill its log;
    - ``quiet``: only what :meth:`warn` says (on stderr, or to ``warn``); errors go to
      stderr as always.

    Notices (:meth:`log`: the opening line, step cuts) are printed unless quiet.
    A hand-written bar rather than tqdm or rich: it is twenty lines, works the
    same on both stacks and under MPI (one rank prints), and needs no package.
    """

    def __init__(
        self,
        end: float,
        comm: MPI.Comm,
        quiet: bool = False,
        stream: TextIO | None = None,
        interval: float | None = None,
        label: str = "t",
        warn: Callable[[str], object] | None = None,
    ):
        self.end, self.label = end, label
        #: where a quiet run's warnings go instead of stderr (the Python API's
        #: ``warnings.warn``)
        self.warn_to = warn
        self.stream = stream or sys.stdout
        self.active = comm.rank == 0
        self.quiet = quiet
        self.bar = self.active and not quiet and self.stream.isatty()
        if interval is None:
            try:
                interval = float(os.environ.get("RFTFEM_LOG_INTERVAL", "5"))
            except ValueError:
                interval = 5.0
        self.interval = interval
        self.t0 = _time.perf_counter()
        self.last_line = -math.inf
        #: every warning said, in order
        self.warnings: list[str] = []

    def _write(self, text: str):
        if self.bar:
            self.stream.write("\r\033[K")
        self.stream.write(text + "\n")
        self.stream.flush()

    def log(self, text: str) -> None:
        """A notice: printed unless quiet."""
        if self.active and not self.quiet:
            self._write(text)

    def warn(self, text: str) -> None:
        """A warning: printed even when quiet (then on stderr), and kept in
        :attr:`warnings` (summary.json's ``warnings``)."""
        self.warnings.append(text)
        if self.active:
            if self.quiet and self.warn_to is not None:
                self.warn_to(text)
            elif self.quiet:
                print(text, file=sys.stderr, flush=True)
            else:
                self._write(text)

    def final(self, text: str) -> None:
        """The run's last line: printed unless quiet."""
        if self.active and not self.quiet:
            self.close()
            self._write(text)

    def update(self, t: float, step: int, newton: int, residual: float) -> None:
        if not self.active or self.quiet:
            return
        now = _time.perf_counter()
        elapsed = now - self.t0
        eta = elapsed * (self.end - t) / t if t > 0 else float("nan")
        if self.bar:
            width = 30
            done = int(width * min(t / self.end, 1.0))
            self.stream.write(
                f"\r[{'#' * done}{'.' * (width - done)}] {self.label} = "
                f"{t:.4g}/{self.end:.4g}"
                f"  step {step}  newton {newton}  eta {eta:.0f} s\033[K"
            )
            self.stream.flush()
        elif now - self.last_line >= self.interval:
            self.last_line = now
            self._write(
                f"{self.label} = {t:.6g}/{self.end:.6g}  step {step}  newton {newton}  "
                f"residual {residual:.3e}  elapsed {elapsed:.1f} s  eta {eta:.0f} s"
            )

    def close(self) -> None:
        if self.bar:
            self.stream.write("\n")
            self.stream.flush()
            self.bar = False


def render_in_child(folder: Path, kind: str, comm: MPI.Comm, progress: Progress) -> None:
    """``output.render``: draw ``folder/render.<kind>`` with ``rftfem render`` in a
    child process of rank 0 (pyvista must not share a process with dolfinx, see
    :mod:`rftfem.outputs.compat_render`). A failed drawing is reported, and the run's
    own status is kept."""
    from rftfem.outputs.render_cli import draw_in_child

    if comm.rank == 0:
        out = Path(folder) / f"render.{kind}"
        proc = draw_in_child(folder, out)
        if proc.returncode == 0:
            progress.log(f"rendered {out}")
        else:
            lines = (proc.stderr or proc.stdout).strip().splitlines()
            why = lines[-1] if lines else f"exit status {proc.returncode}"
            print(
                f"rftfem: warning: output.render: {out} not drawn: {why}",
                file=sys.stderr,
                flush=True,
            )
    comm.Barrier()
