"""``rftfem render``: its options and their checks (light: pyvista is imported
only once the options are good, by :mod:`rftfem.outputs.render`)."""

from __future__ import annotations

import argparse
import math
import os
import subprocess
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from rftfem.errors import SceneError

if TYPE_CHECKING:
    from typing import Any

DESCRIPTION = (
    "Draw a finished (or failed, or running) run from its results folder: the deformed "
    "body coloured by a field, the reference body faintly, axes and the time. A .png "
    "shows one frame (the last by default); a .mp4 or .gif film shows every output "
    "frame (every Nth when there are many). Works the same on results of serial and "
    "mpirun runs. Renders off-screen: no display needed."
)

VIEWS = ("iso", "xy", "xz", "yz", "follow")
FORMATS = (".png", ".mp4", ".gif")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """``rftfem render``'s arguments, in the order its help lists them."""
    _add_file_arguments(parser)
    _add_picture_options(parser)
    _add_film_options(parser)
    _add_drawing_options(parser)


def _add_file_arguments(parser: argparse.ArgumentParser) -> None:
    """The results folder, and the picture or film to write."""
    parser.add_argument(
        "results",
        metavar="RESULTS_DIR",
        help="a run's output folder (with fields.xdmf and summary.json)",
    )
    parser.add_argument(
        "--out",
        metavar="FILE",
        type=Path,
        default=None,
        help="picture or film to write: .png, .mp4 or .gif (default: RESULTS_DIR/render.png)",
    )


def _add_picture_options(parser: argparse.ArgumentParser) -> None:
    """What a picture shows: the colour, the time, the view and the trail."""
    parser.add_argument(
        "--color",
        metavar="FIELD",
        default=None,
        help="colour by: displacement (magnitude), ux, uy, uz, director_x, "
        "director_y, director_z, magnetization (component along "
        "shell.axis, with arrows; magnetic runs only) or none "
        "(default: magnetization on magnetic runs, else displacement)",
    )
    parser.add_argument(
        "--time",
        metavar="T",
        type=float,
        default=None,
        help="for a .png: the output time to draw (the nearest written frame; default: the last)",
    )
    parser.add_argument(
        "--view",
        choices=VIEWS,
        default="iso",
        help="camera: iso (default), xy (from +z), xz (from -y), yz (from +x), "
        "or follow (iso, moving with the centroid)",
    )
    parser.add_argument(
        "--trail",
        metavar="PROBE",
        default=None,
        help="draw the path of the centroid (--trail centroid) or of a probe "
        "up to the frame's time, or none (default: the centroid with "
        "--view follow, none otherwise)",
    )


def _add_film_options(parser: argparse.ArgumentParser) -> None:
    """A film's frame rate and frames."""
    parser.add_argument(
        "--fps",
        metavar="N",
        type=float,
        default=None,
        help="film frame rate (default: so that the film lasts 4-12 s)",
    )
    parser.add_argument(
        "--every",
        metavar="N",
        type=int,
        default=None,
        help="film: use every Nth output frame (default: at most 360 frames in "
        "an MP4, 120 in a GIF)",
    )


def _add_drawing_options(parser: argparse.ArgumentParser) -> None:
    """How the body is drawn: magnified, and the picture's size."""
    parser.add_argument(
        "--scale",
        metavar="S",
        type=float,
        default=1.0,
        help="draw the displacements magnified S times (the body, probes and "
        "trail, as ParaView's warp by vector; the picture says so), so "
        "that a small deflection shows (default 1)",
    )
    parser.add_argument(
        "--size",
        metavar="WxH",
        default="1024x768",
        help="picture size in pixels (default 1024x768)",
    )


def _size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise SceneError(
            f"--size: expected WIDTHxHEIGHT in pixels (e.g. 1024x768), found '{text}'"
        ) from None
    if not (16 <= w <= 8192 and 16 <= h <= 8192):
        raise SceneError(f"--size: expected 16 to 8192 pixels each way, found '{text}'")
    if w % 2 or h % 2:
        raise SceneError(
            f"--size: expected even numbers of pixels (films need them), found '{text}'"
        )
    return w, h


def main(args: argparse.Namespace, console: Any) -> int:
    results = Path(args.results)
    if not results.is_dir():
        raise SceneError(f"results folder '{results}' not found")
    out = args.out if args.out is not None else results / "render.png"
    if out.suffix.lower() not in FORMATS:
        raise SceneError(f"--out {out}: expected a .png, .mp4 or .gif file name")
    if out.is_dir():
        raise SceneError(f"--out {out}: is a folder; expected a file name")
    if not out.parent.is_dir():
        raise SceneError(f"--out {out}: folder '{out.parent}' does not exist")
    if args.time is not None and out.suffix.lower() != ".png":
        raise SceneError("--time: only for a picture (.png); a film shows the whole run")
    if args.fps is not None and not (0.1 <= args.fps <= 120):
        raise SceneError(f"--fps: expected a number from 0.1 to 120, found {args.fps:g}")
    if args.every is not None and args.every < 1:
        raise SceneError(f"--every: expected an integer >= 1, found {args.every}")
    size = _size(args.size)
    if not (math.isfinite(args.scale) and args.scale > 0):
        raise SceneError(f"--scale: expected a number > 0, found {args.scale:g}")

    from rftfem.outputs.render import render  # pyvista and VTK: only now

    done = render(
        results,
        out,
        color=args.color,
        time=args.time,
        view=args.view,
        trail=args.trail,
        fps=args.fps,
        every=args.every,
        size=size,
        scale=args.scale,
    )
    console.out(f"rftfem render: wrote {out} ({done.describe()})")
    return 0


#: environment variables by which MPI launchers tell a process it is one of a job's ranks
_MPI_ENV_PREFIXES = (
    "OMPI_COMM_WORLD",
    "OMPI_MCA_orte",
    "OMPI_MCA_ess",
    "OMPI_FILE_LOCATION",
    "PMIX_",
    "PMI_",
    "HYDRA_",
    "MPI_LOCAL",
    "SLURM_PROCID",
)


def draw_in_child(
    results: str | Path, out: str | Path, *options: str
) -> subprocess.CompletedProcess:
    """Run ``rftfem render RESULTS --out OUT OPTIONS...`` in a child process.

    For scripts that have imported dolfinx (demos, a run's ``output.render``):
    pyvista cannot join such a process (see :mod:`rftfem.outputs.compat_render`). The
    child is not an MPI rank: the launcher's variables are left out of its
    environment. Returns the finished process (``returncode``, ``stderr``).
    """
    env = {k: v for k, v in os.environ.items() if not k.startswith(_MPI_ENV_PREFIXES)}
    cmd = [sys.executable, "-m", "rftfem", "render", str(results), "--out", str(out), *options]
    return subprocess.run(cmd, env=env, stdin=subprocess.DEVNULL, capture_output=True, text=True)


def draw_picture_and_film(results: str | Path, stem: str, *options: str) -> list[Path]:
    """``STEM.png`` (last frame) and ``STEM.mp4`` (whole run) in ``results``: what
    each demo leaves for a look. Prints one line per file; a failure is reported,
    not raised (the numbers of a demo matter more than its pictures)."""
    made = []
    for suffix in (".png", ".mp4"):
        out = Path(results) / f"{stem}{suffix}"
        done = draw_in_child(results, out, *options)
        if done.returncode == 0:
            made.append(out)
            print(f"drew {out}")
        else:
            lines = (done.stderr or done.stdout).strip().splitlines()
            print(f"could not draw {out}: {lines[-1] if lines else done.returncode}")
    return made
