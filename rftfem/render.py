"""Pictures and films of a run, drawn off-screen with pyvista from its results folder.

The input is what a run writes (``fields.xdmf``/``.h5``, ``summary.json``,
``probes.csv``, ``body.csv``), so a run of one process and a run under
``mpirun`` render alike, and a failed run renders up to its last good step.
Frames are read one at a time and drawn into one scene whose points and colours
are replaced in place: memory does not grow with the number of frames.

A film is drawn with a fixed camera that sees the body at every frame (a first
pass over the frames finds their bounds and the colour range), or with
``view="follow"`` with a camera that keeps its distance and direction and moves
with the centroid.

Import order matters (see :mod:`rftfem.compat_render`):
this module imports pyvista, and must be imported before dolfinx in a process
(``rftfem render`` never imports dolfinx; a run that renders at its end starts
``rftfem render`` as a child process).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from rftfem.collect import read_csv as _read_csv
from rftfem.compat_render import import_pyvista
from rftfem.errors import SceneError

pv = import_pyvista()

BACKGROUND = "white"
#: some ambient light, so that faces seen edge-on or from behind keep their colour
_LIGHTING = {"ambient": 0.3, "diffuse": 0.75, "specular": 0.1}
REFERENCE_COLOR = "#b0b0b0"
#: the largest number of frames a film gets without --every (an MP4 is streamed to
#: ffmpeg; a GIF is held in memory by its encoder until it is written: fewer)
MAX_FILM_FRAMES = 360
MAX_GIF_FRAMES = 120
#: iso view direction (from the focal point towards the camera) and up vector
_VIEWS = {
    "iso": ((1.0, -1.6, 1.1), (0.0, 0.0, 1.0)),
    "follow": ((1.0, -1.6, 1.1), (0.0, 0.0, 1.0)),
    "xy": ((0.0, 0.0, 1.0), (0.0, 1.0, 0.0)),
    "xz": ((0.0, -1.0, 0.0), (0.0, 0.0, 1.0)),
    "yz": ((1.0, 0.0, 0.0), (0.0, 0.0, 1.0)),
}


# ------------------------------------------------------------------ the run

_XINCLUDE = 'xmlns:xi="http://www.w3.org/2001/XInclude"'
_BAD_XINCLUDE = 'xmlns:xi="https://www.w3.org/2001/XInclude"'


class RunFields:
    """The fields a run wrote, one frame at a time."""

    def __init__(self, folder: Path):
        self.folder = Path(folder)
        xdmf = self.folder / "fields.xdmf"
        if not xdmf.is_file():
            raise SceneError(f"{self.folder}: no fields.xdmf here (not a results folder, "
                             "or the run had output.fields = false)")
        if not (self.folder / "fields.h5").is_file():
            raise SceneError(f"{self.folder}: fields.xdmf is here but fields.h5 is missing")
        summary = self.folder / "summary.json"
        try:
            self.summary = json.loads(summary.read_text(encoding="utf-8"))
        except FileNotFoundError:
            self.summary = {}
        except (OSError, ValueError) as exc:
            raise SceneError(f"{summary}: cannot be read ({exc})") from None
        self.scene = self.summary.get("scene") or {}
        xdmf = self._readable(xdmf)
        try:
            self.reader = pv.get_reader(str(xdmf))
            self.times = np.array(self.reader.time_values, dtype=float)
        except Exception as exc:  # VTK says little; keep it to one line
            raise SceneError(f"{xdmf}: cannot be read as XDMF ({' '.join(str(exc).split())})") \
                from None
        if len(self.times) == 0:
            raise SceneError(f"{xdmf}: no time steps written yet")
        self.reader.set_active_time_point(0)
        blocks = self.reader.read()
        names = [blocks.get_block_name(i) for i in range(blocks.n_blocks)]
        if "displacement" not in names:
            raise SceneError(f"{xdmf}: no displacement field")
        self.fields = [n for n in names if n != "mesh"]
        self.reference = blocks[names.index("displacement")].copy()
        self.reference.clear_data()
        self.reference_points = np.array(self.reference.points, dtype=float)

    def _readable(self, xdmf: Path) -> Path:
        """``xdmf``, or a repaired copy of it in a temporary folder.

        Some dolfinx versions write the XInclude namespace as ``https://...``;
        XML parsers know only ``http://www.w3.org/2001/XInclude``, leave every
        time step without its mesh, and VTK's reader then crashes. rftfem
        repairs its own files when a run closes them; a run that stopped
        before that (killed, or written by an older rftfem) is read through a
        repaired copy whose data paths point at the original ``fields.h5``.
        """
        text = xdmf.read_text(encoding="utf-8", errors="replace")
        if _BAD_XINCLUDE not in text:
            return xdmf
        import tempfile

        self._tmp = tempfile.TemporaryDirectory(prefix="rftfem-render-")
        h5 = str((xdmf.parent / "fields.h5").resolve())
        text = text.replace(_BAD_XINCLUDE, _XINCLUDE).replace(">fields.h5:", f">{h5}:")
        copy = Path(self._tmp.name) / "fields.xdmf"
        copy.write_text(text, encoding="utf-8")
        return copy

    def frame(self, i: int) -> dict[str, np.ndarray]:
        """The point fields of frame ``i`` (float arrays of shape (n_points, 3))."""
        self.reader.set_active_time_point(int(i))
        blocks = self.reader.read()
        out = {}
        for k in range(blocks.n_blocks):
            name = blocks.get_block_name(k)
            if name in self.fields:
                out[name] = np.asarray(blocks[k].point_data[name], dtype=float)
        return out

    def nearest(self, t: float) -> int:
        lo, hi = self.times[0], self.times[-1]
        tol = 1e-9 * max(1.0, abs(hi))
        if not lo - tol <= t <= hi + tol:
            raise SceneError(f"--time {t:g}: outside the run's output times "
                             f"[{lo:g}, {hi:g}]")
        return int(np.argmin(np.abs(self.times - t)))

    def _log(self, name: str, why: str) -> tuple[list[str], np.ndarray]:
        """Header and rows of the run's ``name`` CSV log; a missing or headerless
        file is a one-line error naming ``why`` it was wanted."""
        path = self.folder / name
        if not path.is_file():
            raise SceneError(f"{why}: {path} is missing")
        return _read_csv(path)

    def path_of(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        """(times, positions) of the centroid or of a probe, from the CSV logs."""
        if name == "centroid":
            header, rows = self._log("body.csv", "--trail centroid")
            cols = [header.index(f"centroid_{c}") for c in "xyz"]
            return rows[:, 0], rows[:, cols]
        probes = {p["name"]: p["at"] for p in (self.scene.get("output") or {}).get("probes", [])}
        if name not in probes:
            known = ", ".join(["centroid", *probes]) or "centroid"
            raise SceneError(f"--trail {name}: no such probe in this run (known: {known})")
        header, rows = self._log("probes.csv", f"--trail {name}")
        cols = [header.index(f"{name}_u{c}") for c in "xyz"]
        return rows[:, 0], rows[:, cols] + np.asarray(probes[name], dtype=float)

    def probe_positions(self, t: float) -> dict[str, np.ndarray]:
        """Current positions of every probe at the probe row nearest ``t``."""
        out = {}
        for p in (self.scene.get("output") or {}).get("probes", []):
            try:
                times, xs = self.path_of(p["name"])
            except SceneError:  # no probes.csv (yet): nothing to report, the picture stands
                return {}
            if len(times):
                out[p["name"]] = xs[int(np.argmin(np.abs(times - t)))]
        return out


# ---------------------------------------------------------------- colouring


def _unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


def color_fields(run: RunFields) -> list[str]:
    names = ["displacement", "ux", "uy", "uz", "none"]
    if "director" in run.fields:
        names += ["director_x", "director_y", "director_z"]
    if "magnetization" in run.fields:
        names.append("magnetization")
    return names


def _scalars(name: str, frame: dict, run: RunFields) -> np.ndarray | None:
    u = frame["displacement"]
    if name == "none":
        return None
    if name == "displacement":
        return np.linalg.norm(u, axis=1)
    if name in ("ux", "uy", "uz"):
        return u[:, "xyz".index(name[1])].copy()
    if name.startswith("director_"):
        return frame["director"][:, "xyz".index(name[-1])].copy()
    if name == "magnetization":
        axis = _unit((run.scene.get("shell") or {}).get("axis", [1.0, 0.0, 0.0]))
        return frame["magnetization"] @ axis
    raise AssertionError(name)


_LABELS = {"displacement": "u (magnitude)", "magnetization": "m along axis"}


# ---------------------------------------------------------------- rendering


@dataclass
class Rendered:
    """What :func:`render` drew: for messages and for checking the picture."""

    out: Path
    frames: int
    times: list[float]
    color: str
    size: tuple[int, int]
    fps: float | None = None
    #: pixel (column, row from the top) of each probe's position at the last frame drawn
    probe_pixels: dict[str, tuple[float, float]] = field(default_factory=dict)
    #: pixel of each probe's reference position (where it would be undeformed)
    reference_pixels: dict[str, tuple[float, float]] = field(default_factory=dict)

    def describe(self) -> str:
        if self.fps is None:
            return f"t = {self.times[-1]:.6g}, colour {self.color}"
        return (f"{self.frames} frames, t = {self.times[0]:.6g} to {self.times[-1]:.6g}, "
                f"{self.fps:g} frames/s, colour {self.color}")


def _film_plan(n: int, every: int | None, fps: float | None,
               most: int = MAX_FILM_FRAMES) -> tuple[np.ndarray, float]:
    stride = every or max(1, math.ceil(n / most))
    idx = np.arange(0, n, stride)
    if idx[-1] != n - 1:
        idx = np.append(idx, n - 1)  # the film always ends on the last frame
    if fps is None:
        fps = float(min(30.0, max(2.0, len(idx) / 4.0)))
    return idx, fps


@dataclass
class _Survey:
    """What a pass over the frames finds, before anything is drawn."""

    lo: np.ndarray          # box of everything drawn: reference, deformed body, trail
    hi: np.ndarray
    body_size: float        # largest diagonal of the deformed body (the follow camera)
    srange: tuple[float, float]  # range of the colour field over the run


def _survey(run: RunFields, idx, color: str, path) -> _Survey:
    """Box of the frames drawn, and the colour range over the whole run (a still
    picture and a film of the same run share their colours)."""
    lo, hi = run.reference_points.min(axis=0), run.reference_points.max(axis=0)
    body_size = 0.0
    n = len(run.times)
    every = np.arange(0, n, max(1, math.ceil(n / MAX_FILM_FRAMES)))
    drawn = set(int(i) for i in idx)
    smin, smax = np.inf, -np.inf
    for i in sorted(drawn | set(int(i) for i in every) | {n - 1}):
        frame = run.frame(i)
        s = _scalars(color, frame, run)
        if s is not None and len(s):
            smin, smax = min(smin, float(s.min())), max(smax, float(s.max()))
        if i in drawn:
            x = run.reference_points + frame["displacement"]
            lo, hi = np.minimum(lo, x.min(axis=0)), np.maximum(hi, x.max(axis=0))
            body_size = max(body_size, float(np.linalg.norm(np.ptp(x, axis=0))))
    if path is not None:
        t_last = float(run.times[max(drawn)])
        shown = path[1][path[0] <= t_last + 1e-12 * max(1.0, abs(t_last))]
        if len(shown):
            lo, hi = np.minimum(lo, shown.min(axis=0)), np.maximum(hi, shown.max(axis=0))
    return _Survey(lo, hi, max(body_size, 1e-12), (smin, smax))


def _clim(color: str, smin: float, smax: float):
    if not math.isfinite(smin):
        return None
    if color in ("ux", "uy", "uz", "magnetization") or color.startswith("director_"):
        m = max(abs(smin), abs(smax), 1e-30)
        return (-m, m)  # signed: symmetric about zero
    if color == "displacement":
        smin = 0.0  # a magnitude: from zero, not from round-off
    if smax - smin < 1e-12 * max(1.0, abs(smax)):
        return (smin, smin + max(1e-12, abs(smin) * 1e-6))
    return (smin, smax)


def _tick_format(clim) -> str:
    """Enough significant digits that the colour bar's labels differ."""
    lo, hi = clim
    span, scale = hi - lo, max(abs(lo), abs(hi))
    digits = 3 if span <= 0 else max(3, min(7, math.ceil(math.log10(scale / span)) + 3))
    return f"%.{digits}g"


#: the part of the picture's width the body may use (the colour bar has the rest)
_USABLE_WIDTH = 0.8


def _place_camera(plotter, view: str, lo, hi, center=None, size: float | None = None):
    """Aim the camera along the view's direction so that the box [lo, hi] (or, with
    ``center`` and ``size``, a ball of diameter ``size`` there) fills the picture
    left of the colour bar. Axis views are parallel projections."""
    cam = plotter.camera
    direction, up = _VIEWS[view]
    d, up = _unit(direction), _unit(up)
    right = np.cross(up, d)
    right /= np.linalg.norm(right)
    up = np.cross(d, right)
    if center is None:
        center = (np.asarray(lo) + np.asarray(hi)) / 2
        corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                            for z in (lo[2], hi[2])]) - center
        half_w = float(np.abs(corners @ right).max())
        half_h = float(np.abs(corners @ up).max())
        depth = float(np.abs(corners @ d).max())
    else:
        center = np.asarray(center)
        half_w = half_h = depth = 0.5 * size
    w, h = plotter.window_size
    aspect = _USABLE_WIDTH * w / h
    half = max(half_h, half_w / aspect, 1e-9) * 1.08
    parallel = view in ("xy", "xz", "yz")
    cam.SetParallelProjection(parallel)
    if parallel:
        cam.parallel_scale = half
        distance = 2.0 * depth + half
    else:
        distance = depth + half / math.tan(math.radians(cam.view_angle / 2))
    cam.focal_point = tuple(center)
    cam.position = tuple(center + distance * d)
    cam.up = tuple(up)
    # the body drawn left of centre, clear of the colour bar on the right
    cam.SetWindowCenter(1.0 - _USABLE_WIDTH, 0.0)
    cam.clipping_range = (max(distance - 2 * depth - half, 1e-6 * distance),
                          distance + 2 * depth + half)


def _pixel(plotter, point) -> tuple[float, float]:
    """Display coordinates of a world point (column, row counted from the top)."""
    ren = plotter.renderer
    ren.SetWorldPoint(*[float(c) for c in point], 1.0)
    ren.WorldToDisplay()
    x, y, _ = ren.GetDisplayPoint()
    return float(x), float(plotter.window_size[1] - y)


def render(results, out, color: str | None = None, time: float | None = None,
           view: str = "iso", trail: str | None = None, fps: float | None = None,
           every: int | None = None, size=(1024, 768)) -> Rendered:
    """Draw the run in ``results`` to ``out`` (.png: one frame; .mp4/.gif: a film)."""
    run = RunFields(Path(results))
    out = Path(out)
    film = out.suffix.lower() in (".mp4", ".gif")
    if color is None:
        color = "magnetization" if "magnetization" in run.fields else "displacement"
    if color not in color_fields(run):
        raise SceneError(f"--color {color}: not a field of this run "
                         f"(choose from {', '.join(color_fields(run))})")
    if trail is None and view == "follow":
        trail = "centroid" if (run.folder / "body.csv").is_file() else None
    path = run.path_of(trail) if trail and trail != "none" else None

    if film:
        most = MAX_GIF_FRAMES if out.suffix.lower() == ".gif" else MAX_FILM_FRAMES
        idx, fps = _film_plan(len(run.times), every, fps, most)
    else:
        idx, fps = np.array([len(run.times) - 1 if time is None else run.nearest(time)]), None
    survey = _survey(run, idx, color, path)
    clim = _clim(color, *survey.srange)

    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        with open(out, "wb"):
            pass
    except OSError as exc:
        raise SceneError(f"--out {out}: cannot write here ({exc.strerror or exc})") from None

    plotter = pv.Plotter(off_screen=True, window_size=list(size))
    try:
        return _draw(plotter, run, out, film, idx, fps, color, clim, view, survey, path, size)
    except Exception:
        out.unlink(missing_ok=True)
        raise
    finally:
        plotter.close()


def _draw(plotter, run, out, film, idx, fps, color, clim, view, survey: _Survey, path,
          size) -> Rendered:
    plotter.set_background(BACKGROUND)
    title = run.scene.get("title", run.folder.name)
    plotter.add_text(title, position="upper_edge", font_size=9, color="black")
    stamp = plotter.add_text("", position="lower_right", font_size=12, color="black")
    reference_edges = run.reference.extract_feature_edges(
        boundary_edges=True, feature_edges=False, manifold_edges=False, non_manifold_edges=False)
    plotter.add_mesh(reference_edges, color=REFERENCE_COLOR, line_width=1, opacity=0.5)

    body = run.reference.copy()
    first = run.frame(idx[0])
    body.points = run.reference_points + first["displacement"]
    s = _scalars(color, first, run)
    if s is None:
        plotter.add_mesh(body, color="#4a7fb5", smooth_shading=True, show_edges=True,
                         edge_color="#2a4f75", **_LIGHTING)
    else:
        body.point_data[color] = s
        cmap = "coolwarm" if clim and clim[0] < 0 < clim[1] else "viridis"
        plotter.add_mesh(body, scalars=color, clim=clim, cmap=cmap, smooth_shading=True,
                         show_edges=True, edge_color="#303030", **_LIGHTING,
                         scalar_bar_args={"title": _LABELS.get(color, color), "color": "black",
                                          "fmt": _tick_format(clim),
                                          "vertical": True, "position_x": 0.86,
                                          "position_y": 0.25, "height": 0.5, "width": 0.06})
    # the body's outline as lines: visible also where the surface is seen edge-on
    # (a flat sheet's wave from the side)
    outline = reference_edges.copy()
    where = {tuple(p): k for k, p in enumerate(run.reference_points)}
    outline_ids = np.array([where.get(tuple(p), 0) for p in np.asarray(outline.points, float)],
                           dtype=int)
    outline.points = body.points[outline_ids]
    plotter.add_mesh(outline, color="#202020", line_width=2)
    arrows = None
    if color == "magnetization":  # arrows on the magnetized points only
        magnetized = np.linalg.norm(first["magnetization"], axis=1) > 0.0
        arrow_length = 0.05 * survey.body_size
        arrows = plotter.add_mesh(_arrows(body.points, first["magnetization"], magnetized,
                                          arrow_length), color="black")
    trail_mesh = None
    if path is not None:
        trail_mesh = pv.PolyData(path[1][:1].copy())
        plotter.add_mesh(trail_mesh, color="#d62728", line_width=3, render_lines_as_tubes=False)
    plotter.show_axes()
    follow = view == "follow"

    def aim(points):
        if follow:
            _place_camera(plotter, view, None, None, _centroid(points), 1.15 * survey.body_size)
        else:
            _place_camera(plotter, view, survey.lo, survey.hi)

    aim(body.points)

    if film:
        if out.suffix.lower() == ".gif":
            plotter.open_gif(str(out), fps=fps)
        else:
            # even sizes suffice for H.264; the default (16) would resize the frames
            plotter.open_movie(str(out), framerate=fps, quality=6, macro_block_size=2)
    times = []
    for n, i in enumerate(idx):
        t = float(run.times[i])
        frame = first if n == 0 else run.frame(i)
        body.points = run.reference_points + frame["displacement"]
        outline.points = body.points[outline_ids]
        s = _scalars(color, frame, run)
        if s is not None:
            body.point_data[color] = s
        if arrows is not None:
            plotter.remove_actor(arrows, render=False)
            arrows = plotter.add_mesh(_arrows(body.points, frame["magnetization"], magnetized,
                                              arrow_length), color="black", render=False)
        if trail_mesh is not None:
            keep = path[0] <= t + 1e-12 * max(1.0, abs(t))
            pts = path[1][keep] if keep.any() else path[1][:1]
            line = pv.lines_from_points(pts) if len(pts) > 1 else pv.PolyData(pts)
            trail_mesh.copy_from(line)
        if follow:
            aim(body.points)
        stamp.SetText(1, f"t = {t:.4g}")
        times.append(t)
        if film:
            plotter.write_frame()
    probe_pixels = {}
    if not film:
        plotter.render()
        plotter.screenshot(str(out))
    for name, x in run.probe_positions(times[-1]).items():
        probe_pixels[name] = _pixel(plotter, x)
    reference_pixels = {p["name"]: _pixel(plotter, p["at"])
                        for p in (run.scene.get("output") or {}).get("probes", [])}
    return Rendered(out=out, frames=len(times), times=times, color=color, size=tuple(size),
                    fps=fps, probe_pixels=probe_pixels, reference_pixels=reference_pixels)


def _arrows(points, vectors, where, length: float):
    """Arrows of one length along ``vectors`` at the selected points."""
    cloud = pv.PolyData(np.asarray(points)[where])
    cloud["m"] = np.asarray(vectors)[where]
    return cloud.glyph(orient="m", scale=False, factor=length)


def _centroid(points) -> np.ndarray:
    return np.asarray(points, dtype=float).mean(axis=0)


def render_after_run(folder: Path, kind: str) -> Path:
    """``output.render``: the picture or film of a run that has just ended."""
    out = Path(folder) / f"render.{kind}"
    render(folder, out)
    return out


__all__ = ["render", "RunFields", "Rendered", "render_after_run", "color_fields",
           "MAX_FILM_FRAMES"]
