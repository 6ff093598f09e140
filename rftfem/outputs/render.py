"""Pictures and films of a run, drawn off-screen with pyvista from its results folder.

The input is what a run writes (``fields.xdmf``/``.h5``, ``summary.json``,
``probes.csv``, ``body.csv``), so a run of one process and a run under
``mpirun`` render alike, and a failed run renders up to its last good step.
Frames are read one at a time and drawn into one scene whose points and colours
are replaced in place: memory does not grow with the number of frames.

A film is drawn with a fixed camera that sees the body at every frame (a first
pass over the frames finds their bounds and the colour range), or with
``view="follow"`` with a camera that keeps its distance and direction and moves
with the centroid. Reading the run, that survey and the camera are in
:mod:`rftfem.outputs.render_view`, what moves from frame to frame in
:mod:`rftfem.outputs.render_picture`; this module draws and writes.

Import order matters (see :mod:`rftfem.outputs.compat_render`):
this module imports pyvista, and must be imported before dolfinx in a process
(``rftfem render`` never imports dolfinx; a run that renders at its end starts
``rftfem render`` as a child process).
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from rftfem.errors import SceneError
from rftfem.outputs.compat_render import import_pyvista
from rftfem.outputs.render_picture import (  # noqa: F401  (_arrows, TRAIL_COLOR: as before)
    TRAIL_COLOR,
    Picture,
    _arrows,
)
from rftfem.outputs.render_view import (
    MAX_FILM_FRAMES,
    MAX_GIF_FRAMES,
    RunFields,
    Survey,
    color_fields,
    color_limits,
    film_plan,
    pixel_of,
    place_camera,
    survey_frames,
)

pv = import_pyvista()

BACKGROUND = "white"
REFERENCE_COLOR = "#b0b0b0"
#: a no-slip wall of the scene ([fluid.wall]), drawn translucent under the body
WALL_COLOR = "#8c7b6b"


@dataclass
class Rendered:
    """What :func:`render` drew: for messages and for checking the picture."""

    out: Path
    frames: int
    times: list[float]
    color: str
    size: tuple[int, int]
    fps: float | None = None
    #: the factor the displacements were drawn magnified by
    scale: float = 1.0
    #: pixel (column, row from the top) of each probe's position at the last frame drawn
    probe_pixels: dict[str, tuple[float, float]] = field(default_factory=dict)
    #: pixel of each probe's reference position (where it would be undeformed)
    reference_pixels: dict[str, tuple[float, float]] = field(default_factory=dict)
    #: what the scale magnified: "displacements × S" (a held body), "deformation × S
    #: (the rigid motion true)" (a free one)
    magnified: str = ""

    def describe(self) -> str:
        magnified = "" if self.scale == 1.0 else f", {self.magnified}"
        if self.fps is None:
            return f"t = {self.times[-1]:.6g}, colour {self.color}{magnified}"
        return (
            f"{self.frames} frames, t = {self.times[0]:.6g} to {self.times[-1]:.6g}, "
            f"{self.fps:g} frames/s, colour {self.color}{magnified}"
        )


def render(
    results: str | Path,
    out: str | Path,
    color: str | None = None,
    time: float | None = None,
    view: str = "iso",
    trail: str | None = None,
    fps: float | None = None,
    every: int | None = None,
    size: tuple[int, int] = (1024, 768),
    scale: float = 1.0,
) -> Rendered:
    """Draw the run in ``results`` to ``out`` (.png: one frame; .mp4/.gif: a film),
    its displacements magnified ``scale`` times (ParaView's warp by vector: the
    body, the probes and the trail; colours keep the true values)."""
    if not (isinstance(scale, (int, float)) and math.isfinite(scale) and scale > 0):
        raise SceneError(f"--scale: expected a number > 0, found {scale}")
    scale = float(scale)
    run = RunFields(Path(results), scale)
    out = Path(out)
    film = out.suffix.lower() in (".mp4", ".gif")
    if color is None:
        color = "magnetization" if "magnetization" in run.fields else "displacement"
    if color not in color_fields(run):
        raise SceneError(
            f"--color {color}: not a field of this run (choose from {', '.join(color_fields(run))})"
        )
    path = _trail_path(run, trail, view)
    if film:
        most = MAX_GIF_FRAMES if out.suffix.lower() == ".gif" else MAX_FILM_FRAMES
        idx, fps = film_plan(len(run.times), every, fps, most)
    else:
        idx, fps = np.array([len(run.times) - 1 if time is None else run.nearest(time)]), None
    survey = survey_frames(run, idx, color, path)
    clim = color_limits(color, *survey.srange)
    _claim(out)

    # Films are drawn without multisampling: on a machine without a GPU (Mesa's
    # software rasterizer) the 8 samples of a still picture double a frame's cost
    # for a difference hard to see in a moving picture (docs/running.md)
    theme = copy.deepcopy(pv.global_theme)
    theme.multi_samples = 0 if film else 8
    plotter = pv.Plotter(off_screen=True, window_size=list(size), theme=theme)
    try:
        return _draw(plotter, run, out, film, idx, fps, color, clim, view, survey, path, size)
    except Exception:
        out.unlink(missing_ok=True)
        raise
    finally:
        plotter.close()


def _trail_path(
    run: RunFields, trail: str | None, view: str
) -> tuple[np.ndarray, np.ndarray] | None:
    """(times, positions) of the trail drawn (the centroid's by default with ``view``
    "follow"), as the body is drawn magnified; None for no trail."""
    if trail is None and view == "follow":
        trail = "centroid" if (run.folder / "body.csv").is_file() else None
    path = run.path_of(trail) if trail and trail != "none" else None
    if path is not None and run.scale != 1.0 and run.held:
        # a held body's displacement is magnified about the reference, the trail too;
        # a free body's trail is drawn true (its rigid motion is not magnified)
        path = (path[0], path[1][:1] + run.scale * (path[1] - path[1][:1]))
    return path


def _claim(out: Path) -> None:
    """Make ``out``'s folder and an empty ``out``: a folder it cannot be written in is a
    one-line error before anything is drawn."""
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        with open(out, "wb"):
            pass
    except OSError as exc:
        raise SceneError(f"--out {out}: cannot write here ({exc.strerror or exc})") from None


def _draw(
    plotter, run, out, film, idx, fps, color, clim, view, survey: Survey, path, size
) -> Rendered:
    stamp = _add_setting(plotter, run, survey)
    first = run.frame(idx[0])
    picture = Picture(plotter, run, color, clim, survey, path, first)
    follow = view == "follow"

    def aim(points):
        if follow:
            place_camera(plotter, view, None, None, _centroid(points), 1.15 * survey.body_size)
        else:
            place_camera(plotter, view, survey.lo, survey.hi)

    aim(picture.body.points)
    if film:
        if out.suffix.lower() == ".gif":
            plotter.open_gif(str(out), fps=fps)
        else:
            # even sizes suffice for H.264; the default (16) would resize the frames
            plotter.open_movie(str(out), framerate=fps, quality=6, macro_block_size=2)
    times = []
    for n, i in enumerate(idx):
        t = float(run.times[i])
        picture.show(first if n == 0 else run.frame(i), t)
        if follow:
            aim(picture.body.points)
        stamp.SetText(1, f"t = {t:.4g}")
        times.append(t)
        if film:
            plotter.write_frame()
    if not film:
        plotter.render()
        plotter.screenshot(str(out))
    probe_pixels = {
        name: pixel_of(plotter, x) for name, x in run.probe_positions(times[-1]).items()
    }
    reference_pixels = {
        p["name"]: pixel_of(plotter, p["at"])
        for p in (run.scene.get("output") or {}).get("probes", [])
    }
    return Rendered(
        out=out,
        frames=len(times),
        times=times,
        color=color,
        size=tuple(size),
        fps=fps,
        probe_pixels=probe_pixels,
        reference_pixels=reference_pixels,
        scale=run.scale,
        magnified=_magnified(run),
    )


def _add_setting(plotter, run, survey: Survey):
    """What does not move: the background, the title, the magnification's note, the
    reference body's outline and the planes; returns the time stamp's text."""
    plotter.set_background(BACKGROUND)
    title = run.scene.get("title", run.folder.name)
    plotter.add_text(title, position="upper_edge", font_size=9, color="black")
    stamp = plotter.add_text("", position="lower_right", font_size=12, color="black")
    if run.scale != 1.0:
        plotter.add_text(_magnified(run), position="lower_edge", font_size=10, color="#b22222")
    reference_edges = run.reference.extract_feature_edges(
        boundary_edges=True, feature_edges=False, manifold_edges=False, non_manifold_edges=False
    )
    plotter.add_mesh(reference_edges, color=REFERENCE_COLOR, line_width=1, opacity=0.5)
    for plane, arrow in _planes(run, survey):
        plotter.add_mesh(plane, color=WALL_COLOR, opacity=0.35, show_edges=False)
        plotter.add_mesh(arrow, color=WALL_COLOR)
    return stamp


def _magnified(run) -> str:
    if run.scale == 1.0:
        return ""
    if run.held:
        return f"displacements × {run.scale:g}"
    return f"deformation × {run.scale:g} (the rigid motion true)"


def _planes(run, survey: Survey) -> list:
    """The scene's no-slip wall (``[fluid.wall]``) and contact floors (``[[contact]]``
    of kind "plane"), each as a square across the whole run's extent with an arrow
    along its normal, on the side the body and the liquid are: ``(plane, arrow)``."""
    given = [(run.scene.get("fluid") or {}).get("wall")]
    given += [c for c in (run.scene.get("contact") or []) if c.get("kind", "plane") == "plane"]
    middle = 0.5 * (np.asarray(survey.lo) + np.asarray(survey.hi))
    size = (
        1.2 * float(np.linalg.norm(np.asarray(survey.hi) - np.asarray(survey.lo)))
        + survey.body_size
    )
    out = []
    for plane in given:
        if not plane:
            continue
        normal = np.asarray(plane["normal"], dtype=float)
        normal /= np.linalg.norm(normal)
        point = np.asarray(plane["point"], dtype=float)
        centre = middle - np.dot(middle - point, normal) * normal
        out.append(
            (
                pv.Plane(center=centre, direction=normal, i_size=size, j_size=size),
                pv.Arrow(
                    start=centre + 0.4 * size * _across(normal), direction=normal, scale=0.12 * size
                ),
            )
        )
    return out


def _across(normal) -> np.ndarray:
    """A unit vector in the plane of ``normal`` (where its arrow stands, off the body)."""
    other = np.array([1.0, 0.0, 0.0]) if abs(normal[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    v = np.cross(normal, other)
    return v / np.linalg.norm(v)


def _centroid(points) -> np.ndarray:
    return np.asarray(points, dtype=float).mean(axis=0)


def render_after_run(folder: Path, kind: str) -> Path:
    """``output.render``: the picture or film of a run that has just ended."""
    out = Path(folder) / f"render.{kind}"
    render(folder, out)
    return out


__all__ = ["render", "RunFields", "Rendered", "render_after_run", "color_fields", "MAX_FILM_FRAMES"]
