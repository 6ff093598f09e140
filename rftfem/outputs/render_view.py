"""What a picture or film of a run shows, and from where (for :mod:`rftfem.outputs.render`).

:class:`RunFields` reads a run's results folder one frame at a time (and its CSV
logs, for trails and probes); :func:`color_values` gives the colour field of a
frame. Before anything is drawn, :func:`film_plan` picks a film's frames and
:func:`survey_frames` passes over the run for the box to show and the colour range;
:func:`place_camera` aims the camera at that box, or at a ball around the
centroid for ``view="follow"``.

Imports pyvista (never dolfinx; see :mod:`rftfem.outputs.compat_render`).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from rftfem.errors import SceneError
from rftfem.outputs.compat_render import import_pyvista
from rftfem.outputs.quantities import read_csv
from rftfem.outputs.rigid_fit import magnified
from rftfem.outputs.xdmf_repair import readable

pv = import_pyvista()

if TYPE_CHECKING:
    from collections.abc import Sequence

#: the largest number of frames a film gets without --every (an MP4 is streamed to
#: ffmpeg; a GIF is held in memory by its encoder until it is written: fewer)
MAX_FILM_FRAMES = 360
MAX_GIF_FRAMES = 120
#: each view's direction (from the focal point towards the camera) and up vector
_VIEWS = {
    "iso": ((1.0, -1.6, 1.1), (0.0, 0.0, 1.0)),
    "follow": ((1.0, -1.6, 1.1), (0.0, 0.0, 1.0)),
    "xy": ((0.0, 0.0, 1.0), (0.0, 1.0, 0.0)),
    "xz": ((0.0, -1.0, 0.0), (0.0, 0.0, 1.0)),
    "yz": ((1.0, 0.0, 0.0), (0.0, 0.0, 1.0)),
}


# ------------------------------------------------------------------ the run


class RunFields:
    """The fields a run wrote, one frame at a time."""

    def __init__(self, folder: Path, scale: float = 1.0):
        self.folder = Path(folder)
        #: the factor the deformation is drawn magnified by (render --scale)
        self.scale = float(scale)
        #: the rigid fit of the last frame drawn with a scale (``shown``)
        self._fit = (np.eye(3), np.zeros(3), np.zeros(3))
        xdmf = self.folder / "fields.xdmf"
        if not xdmf.is_file():
            raise SceneError(
                f"{self.folder}: no fields.xdmf here (not a results folder, "
                "or the run had output.fields = false)"
            )
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
            raise SceneError(
                f"{xdmf}: cannot be read as XDMF ({' '.join(str(exc).split())})"
            ) from None
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
        """``xdmf``, or a repaired copy of it (:func:`rftfem.outputs.xdmf_repair.readable`),
        kept while this object lives."""
        path, folder = readable(xdmf)
        if folder is not None:
            self._tmp = folder
        return path

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

    def shown(self, frame: dict) -> np.ndarray:
        """The displacement drawn in ``frame``: with ``scale`` 1 the computed one; for
        a body held in place (``held``) all of it magnified; else the frame's best-fit
        rigid motion as it is and the deformation from it magnified (``magnified``),
        so that a swimmer's or walker's travel stays true and only its shape change is
        scaled.  The fit is kept for the probes."""
        u = frame["displacement"]
        if self.scale == 1.0:
            return u
        if self.held:  # a body held in place has no rigid motion: all of u is shape
            return self.scale * u
        drawn, self._fit = magnified(self.reference_points, u, self.scale)
        return drawn - self.reference_points

    @property
    def held(self) -> bool:
        """Whether the scene holds the body in place (a ``[[boundary]]``): then --scale
        magnifies its whole displacement, about the reference."""
        return bool(self.scene.get("boundary"))

    def points(self, frame: dict) -> np.ndarray:
        """The nodes where they are drawn in ``frame``."""
        return self.reference_points + self.shown(frame)

    def nearest(self, t: float) -> int:
        lo, hi = self.times[0], self.times[-1]
        tol = 1e-9 * max(1.0, abs(hi))
        if not lo - tol <= t <= hi + tol:
            raise SceneError(f"--time {t:g}: outside the run's output times [{lo:g}, {hi:g}]")
        return int(np.argmin(np.abs(self.times - t)))

    def _log(self, name: str, why: str) -> tuple[list[str], np.ndarray]:
        """Header and rows of the run's ``name`` CSV log; a missing or headerless
        file is a one-line error naming ``why`` it was wanted."""
        path = self.folder / name
        if not path.is_file():
            raise SceneError(f"{why}: {path} is missing")
        return read_csv(path)

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
                x = xs[int(np.argmin(np.abs(times - t)))]
                at = np.asarray(p["at"], dtype=float)
                if self.scale == 1.0:
                    out[p["name"]] = x
                elif self.held:
                    out[p["name"]] = at + self.scale * (x - at)
                else:  # as the body is drawn: the last drawn frame's rigid fit
                    R, c_ref, c_now = self._fit
                    rigid = R @ (at - c_ref) + c_now
                    out[p["name"]] = rigid + self.scale * (x - rigid)
        return out


# ---------------------------------------------------------------- colouring


def _unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


def color_fields(run: RunFields) -> list[str]:
    """The names a picture of this run can be coloured by (``--color``)."""
    names = ["displacement", "ux", "uy", "uz", "none"]
    if "director" in run.fields:
        names += ["director_x", "director_y", "director_z"]
    if "magnetization" in run.fields:
        names.append("magnetization")
    return names


def color_values(name: str, frame: dict, run: RunFields) -> np.ndarray | None:
    """The colour field ``name`` at the points of ``frame`` (None for "none")."""
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


# ---------------------------------------------------------- frames and survey


def film_plan(
    n: int, every: int | None, fps: float | None, most: int = MAX_FILM_FRAMES
) -> tuple[np.ndarray, float]:
    """The frames a film of a run with ``n`` output frames shows (every ``every``th,
    else at most about ``most``; always the last) and its frame rate."""
    stride = every or max(1, math.ceil(n / most))
    idx = np.arange(0, n, stride)
    if idx[-1] != n - 1:
        idx = np.append(idx, n - 1)  # the film always ends on the last frame
    if fps is None:
        fps = float(min(30.0, max(2.0, len(idx) / 4.0)))
    return idx, fps


@dataclass
class Survey:
    """What a pass over the frames finds, before anything is drawn."""

    lo: np.ndarray  # box of everything drawn: reference, deformed body, trail
    hi: np.ndarray
    body_size: float  # largest diagonal of the deformed body (the follow camera)
    srange: tuple[float, float]  # range of the colour field over the run


def survey_frames(
    run: RunFields, idx: np.ndarray, color: str, path: tuple[np.ndarray, np.ndarray] | None
) -> Survey:
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
        s = color_values(color, frame, run)
        if s is not None and len(s):
            smin, smax = min(smin, float(s.min())), max(smax, float(s.max()))
        if i in drawn:
            x = run.points(frame)
            lo, hi = np.minimum(lo, x.min(axis=0)), np.maximum(hi, x.max(axis=0))
            body_size = max(body_size, float(np.linalg.norm(np.ptp(x, axis=0))))
    if path is not None:
        t_last = float(run.times[max(drawn)])
        shown = path[1][path[0] <= t_last + 1e-12 * max(1.0, abs(t_last))]
        if len(shown):
            lo, hi = np.minimum(lo, shown.min(axis=0)), np.maximum(hi, shown.max(axis=0))
    return Survey(lo, hi, max(body_size, 1e-12), (smin, smax))


def color_limits(color: str, smin: float, smax: float) -> tuple[float, float] | None:
    """The colour bar's range for values in [smin, smax] (None without values)."""
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


# ------------------------------------------------------------------- camera


#: the part of the picture's width the body may use (the colour bar has the rest)
_USABLE_WIDTH = 0.8


def place_camera(
    plotter: pv.Plotter,
    view: str,
    lo: np.ndarray | None,
    hi: np.ndarray | None,
    center: np.ndarray | None = None,
    size: float | None = None,
) -> None:
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
        corners = (
            np.array(
                [[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]
            )
            - center
        )
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
    cam.clipping_range = (
        max(distance - 2 * depth - half, 1e-6 * distance),
        distance + 2 * depth + half,
    )


def pixel_of(plotter: pv.Plotter, point: np.ndarray | Sequence[float]) -> tuple[float, float]:
    """Display coordinates of a world point (column, row counted from the top)."""
    ren = plotter.renderer
    ren.SetWorldPoint(*[float(c) for c in point], 1.0)
    ren.WorldToDisplay()
    x, y, _ = ren.GetDisplayPoint()
    return float(x), float(plotter.window_size[1] - y)
