"""What a contact plane's defaults rest on (the slip velocity's time, the stiffness's
reference pressure) and the check that the body starts on the planes' side."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from rftfem.errors import SceneError
from rftfem.model.effects.contact_updates import cell_thickness

if TYPE_CHECKING:
    import ufl

    from rftfem.model.effects.contact import Plane
    from rftfem.model.shell_model import Model

#: how far below the plane (a share of δ) a node's lower face may start: round-off
START_DEPTH = 1.0e-3


def time_scale(scene: dict) -> float:
    """The scene's shortest periodic drive (a travelling wave, a rotating field, a
    field periodic in t), else ``time.end``: the default slip velocity's time."""
    from rftfem.scene.scales import drive_periods

    periods = [d.period for d in drive_periods(scene) if not d.table]
    return min(periods) if periods else float(scene["time"]["end"])


def reference_pressure(
    m: Model,
    dx: ufl.Measure,
    size: float,
    normal: np.ndarray,
    within: ufl.core.expr.Expr,
    chi: ufl.core.expr.Expr | None = None,
) -> float:
    """The pressure the default stiffness rests on the plane: the body's weight
    along the plane's normal under the scene's gravity (net of buoyancy) over the
    area of its lower face within the barrier's reach at the start (``within``, a
    UFL area density), or over its whole area if none is; all of the weight if
    gravity lies in the plane.  Without gravity the pressure D t / L⁴ that bends
    the body by its thickness.  ``chi``: the indicator of the one body the plane
    acts on (weight and area are that body's), or None.  ``dx``: the contact's
    measure."""
    one = 1.0 if chi is None else chi
    gravity = [ld for ld in m.scene.get("load") or [] if ld["kind"] == "gravity"]
    if gravity:
        rho, t = m.material["rho"], m.material["t"]
        mass = m.assemble_scalar(m.compile(rho * t * one * dx))
        volume = m.assemble_scalar(m.compile(t * one * dx))
        along = max(
            abs(mass - ld["fluid_density"] * volume)
            * abs(float(np.asarray(ld["value"], dtype=float) @ normal))
            for ld in gravity
        )
        whole = max(
            abs(mass - ld["fluid_density"] * volume) * float(np.linalg.norm(ld["value"]))
            for ld in gravity
        )
        weight = along or whole
        if weight > 0.0:
            touching = m.assemble_scalar(m.compile(within * dx))
            area = m.area() if chi is None else m.assemble_scalar(m.compile(chi * dx))
            return weight / (touching if touching > 0.0 else area)
    t, E, nu = (m.material_value(k, "shell") for k in ("thickness", "E", "nu"))
    return E * t**3 / (12 * (1 - nu**2)) * t / size**4


def check_start(m: Model, entries: list[dict], planes: list[Plane]) -> None:
    """No node's lower face may start below a plane (beyond round-off)."""
    X = m.Vu.tabulate_dof_coordinates()
    D = m.D.x.array.reshape(-1, 3)
    cells, t_cell = cell_thickness(m)
    all_faces = X[cells] - 0.5 * t_cell[:, None, None] * D[cells]
    for i, (entry, plane) in enumerate(zip(entries, planes)):
        faces = all_faces[_cells_of(m, entry)].reshape(-1, 3)
        g = (faces - plane.point) @ plane.normal
        low = float(g.min()) if len(g) else np.inf
        low, where = min(
            m.comm.allgather((low, faces[int(np.argmin(g))].tolist() if len(g) else None)),
            key=lambda pair: pair[0],
        )
        if low < -START_DEPTH * plane.reach:
            at = ", ".join(f"{c:.4g}" for c in where)
            raise SceneError(
                f"contact.{i}: the body starts through the plane: its lower "
                f"face is {-low:.4g} below it at ({at}) (the normal points to "
                "the side the body stays on; the lower face is the mid-surface "
                "less half the thickness along the director)"
            )


def _cells_of(m: Model, entry: dict) -> np.ndarray | slice:
    """The local cells a plane's entry acts on (rows of ``cell_thickness``)."""
    from rftfem import compat
    from rftfem.model.body_parts import body_part

    if entry.get("body") is None:
        return slice(None)
    chi = body_part(m, entry["body"]).chi
    return chi.x.array[compat.cell_dofs(chi.function_space)[:, 0]] == 1.0
