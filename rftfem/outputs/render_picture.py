"""What moves in a picture or film of a run (for :mod:`rftfem.outputs.render`): the
body coloured by a field, the magnetization's arrows and the trail.

Imports pyvista (never dolfinx; see :mod:`rftfem.outputs.compat_render`).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from rftfem.outputs.compat_render import import_pyvista
from rftfem.outputs.render_body import BodyDrawing
from rftfem.outputs.render_view import color_values

if TYPE_CHECKING:
    from rftfem.outputs.render_view import RunFields, Survey

pv = import_pyvista()

#: some ambient light, so that faces seen edge-on or from behind keep their colour
_LIGHTING = {"ambient": 0.3, "diffuse": 0.75, "specular": 0.1}
#: the trail of the centroid or a probe, drawn over the body
TRAIL_COLOR = "#d62728"
_LABELS = {"displacement": "u (magnitude)", "magnetization": "m along axis"}


def _tick_format(clim) -> str:
    """Enough significant digits that the colour bar's labels differ."""
    lo, hi = clim
    span, scale = hi - lo, max(abs(lo), abs(hi))
    digits = 3 if span <= 0 else max(3, min(7, math.ceil(math.log10(scale / span)) + 3))
    return f"%.{digits}g"


class Picture:
    """What moves: the body (coloured or plain, its cells' edges and outline), the
    magnetization's arrows and the trail, drawn at the ``first`` frame and moved to
    each next by :meth:`show`."""

    def __init__(
        self,
        plotter: pv.Plotter,
        run: RunFields,
        color: str,
        clim: tuple[float, float] | None,
        survey: Survey,
        path: tuple[np.ndarray, np.ndarray] | None,
        first: dict[str, np.ndarray],
    ):
        self.plotter, self.run, self.color, self.path = plotter, run, color, path
        self.drawing = BodyDrawing(run.reference)
        self._add_body(first, clim)
        self.arrows = None
        if color == "magnetization":  # arrows on the magnetized points only, as long as |m|
            self._add_arrows(first, survey)
        self.trail = self.here = None
        if path is not None:
            self._add_trail(path[1][:1])
        plotter.show_axes()

    def _add_body(self, first: dict[str, np.ndarray], clim: tuple[float, float] | None) -> None:
        """The body at the ``first`` frame, coloured (with the colour bar) or plain, its
        cells' edges and its outline."""
        plotter, run, color, drawing = self.plotter, self.run, self.color, self.drawing
        s = color_values(color, first, run)
        self.body = drawing.surface(run.shown(first), None if s is None else {color: s})
        if s is None:
            surface = plotter.add_mesh(self.body, color="#4a7fb5", smooth_shading=True, **_LIGHTING)
            edge_color = "#2a4f75"
        else:
            cmap = "coolwarm" if clim and clim[0] < 0 < clim[1] else "viridis"
            surface = plotter.add_mesh(
                self.body,
                scalars=color,
                clim=clim,
                cmap=cmap,
                smooth_shading=True,
                **_LIGHTING,
                scalar_bar_args={
                    "title": _LABELS.get(color, color),
                    "color": "black",
                    "fmt": _tick_format(clim),
                    "vertical": True,
                    "position_x": 0.86,
                    "position_y": 0.25,
                    "height": 0.5,
                    "width": 0.06,
                },
            )
            edge_color = "#303030"
        # the cells' edges, curved as the cells are (the surface pushed back a little in
        # depth so that the lines on it are not hidden), and the body's outline as lines:
        # visible also where the surface is seen edge-on (a flat sheet's wave from the side)
        surface.mapper.SetResolveCoincidentTopologyToPolygonOffset()
        surface.mapper.SetRelativeCoincidentTopologyPolygonOffsetParameters(2.0, 2.0)
        plotter.add_mesh(drawing.edges(run.shown(first)), color=edge_color, line_width=1)
        plotter.add_mesh(drawing.outline(run.shown(first)), color="#202020", line_width=2)

    def _add_arrows(self, first: dict[str, np.ndarray], survey: Survey) -> None:
        """The magnetization's arrows at the ``first`` frame."""
        strength = np.linalg.norm(first["magnetization"], axis=1)
        self.magnetized = strength > 0.0
        # the strongest magnetization's arrow is 5 % of the body's size
        self.arrow_length = 0.05 * survey.body_size / max(float(strength.max()), 1e-300)
        self.arrows = self.plotter.add_mesh(
            _arrows(
                self.run.points(first), first["magnetization"], self.magnetized, self.arrow_length
            ),
            color="black",
        )

    def _add_trail(self, start):
        plotter = self.plotter
        self.trail, self.here = pv.PolyData(start.copy()), pv.PolyData(start.copy())
        _on_top(
            plotter,
            [
                plotter.add_mesh(self.trail, color=TRAIL_COLOR, line_width=4),
                plotter.add_mesh(
                    pv.PolyData(start.copy()),
                    color="white",
                    point_size=11,
                    render_points_as_spheres=True,
                ),
                plotter.add_mesh(
                    pv.PolyData(start.copy()),
                    color=TRAIL_COLOR,
                    point_size=7,
                    render_points_as_spheres=True,
                ),
                plotter.add_mesh(
                    self.here, color=TRAIL_COLOR, point_size=11, render_points_as_spheres=True
                ),
            ],
        )

    def show(self, frame: dict[str, np.ndarray], t: float) -> None:
        """Move everything to ``frame`` (at time ``t``)."""
        run, color = self.run, self.color
        s = color_values(color, frame, run)
        u = run.shown(frame)
        moved = self.drawing.surface(u, None if s is None else {color: s})
        self.body.points = moved.points
        if s is not None:
            self.body.point_data[color] = moved.point_data[color]
        self.drawing.edges(u)
        self.drawing.outline(u)
        if self.arrows is not None:
            self.plotter.remove_actor(self.arrows, render=False)
            self.arrows = self.plotter.add_mesh(
                _arrows(
                    run.points(frame), frame["magnetization"], self.magnetized, self.arrow_length
                ),
                color="black",
                render=False,
            )
        if self.trail is not None:
            path = self.path
            keep = path[0] <= t + 1e-12 * max(1.0, abs(t))
            pts = path[1][keep] if keep.any() else path[1][:1]
            line = pv.lines_from_points(pts) if len(pts) > 1 else pv.PolyData(pts)
            self.trail.copy_from(line)
            self.here.points = pts[-1:]


def _arrows(points, vectors, where, length: float):
    """Arrows along ``vectors`` at the selected points, ``length`` times as long as
    the vectors."""
    cloud = pv.PolyData(np.asarray(points)[where])
    cloud["m"] = np.asarray(vectors)[where]
    return cloud.glyph(orient="m", scale="m", factor=length)


def _on_top(plotter, actors):
    """Move ``actors`` to a layer drawn over the body with the same camera: a trail
    runs through the body (a centroid lies inside a sheet), and would be hidden."""
    from vtkmodules.vtkRenderingCore import vtkRenderer

    overlay = vtkRenderer()
    overlay.SetLayer(1)
    overlay.SetActiveCamera(plotter.renderer.GetActiveCamera())
    overlay.InteractiveOff()
    window = plotter.ren_win
    window.SetNumberOfLayers(max(2, window.GetNumberOfLayers()))
    window.AddRenderer(overlay)
    for actor in actors:
        plotter.renderer.RemoveActor(actor)
        overlay.AddActor(actor)
    plotter._rftfem_overlay = overlay  # keep it alive with the plotter
