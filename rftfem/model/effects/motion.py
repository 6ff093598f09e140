"""Prescribed motion, the scene's ``[[motion]]``: a displacement component given
in time on a selection, a moving Dirichlet condition (docs/model.md §5.7).

The value lives in a Function on the collapsed component space and is set at
every time the solver visits.  A degree of freedom takes one condition: a
motion where a ``[[boundary]]`` or another motion already holds the component
is refused.

In second-order schemes (generalized-α, HHT) the driven dofs' velocity and
acceleration are the motion's own derivatives, not Newmark's differences of
the prescribed values (docs/model.md §6.10): Newmark's velocity of a displacement
with a kink rings about the slope's jump (1.995, 0.017, 1.963, 0.061, … per unit
jump, decaying by 0.9 a step under HHT α = −0.05), and the driven edges then jolt
the body at every step.  :meth:`Motions.drive_step` puts the exact left-sided
rates at the step's end into its α-weighted residual, :meth:`Motions.drive_state`
stores the right-sided ones after it.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, Sequence

import numpy as np

from rftfem.errors import SceneError
from rftfem.model.effects.base import Effect
from rftfem.model.effects.boundary import DISPLACEMENT_COMPONENTS, NAME
from rftfem.model.rates import scheme_velocity
from rftfem.scene.bodies import BODY_KEY
from rftfem.scene.schema import Array, Leaf, Num, Pairs, Str, Table, Vec, Where, table_iff
from rftfem.scene.selectors import check_where, entities_of

if TYPE_CHECKING:
    import dolfinx.fem

    from rftfem.model.shell_model import Model


class Motions(Effect):
    name = "prescribed-motion"
    moving = True
    keys = {
        "motion": Array(
            Table(
                {
                    "where": Leaf(Where(), "all", doc="Where, as for `[[boundary]].where`."),
                    "body": BODY_KEY,
                    "name": NAME,
                    "component": Leaf(
                        Str(("ux", "uy", "uz")),
                        required=True,
                        doc="The displacement component prescribed (global axes).",
                    ),
                    "kind": Leaf(
                        Str(("travelling-wave", "table", "rotation")),
                        "travelling-wave",
                        doc='"travelling-wave": u = amplitude sin(wavenumber (X − origin) + '
                        "angular_frequency t + phase), with X each node's reference X "
                        "coordinate; "
                        '"table": one value on the whole selection, interpolated in '
                        "`values`; "
                        '"rotation": the component of a rigid turn, u = (R(φ) − I)(X − '
                        "centre) with R(φ) the turn by φ = angular_frequency t + phase "
                        "about rotation_axis (one entry per component: three turn the "
                        "selection rigidly).",
                    ),
                    "amplitude": Leaf(
                        Num(), 0.0, unit="length", doc="The wave's amplitude (travelling-wave)."
                    ),
                    "wavenumber": Leaf(
                        Num(),
                        0.0,
                        unit="rad/length",
                        doc="The wave number (travelling-wave); with a positive "
                        "angular_frequency the wave runs towards −X.",
                    ),
                    "angular_frequency": Leaf(
                        Num(), 0.0, unit="rad/time", doc="The angular frequency (travelling-wave)."
                    ),
                    "origin": Leaf(
                        Num(),
                        0.0,
                        unit="length",
                        doc="The reference X where the wave's phase is zero at t = 0 "
                        "(travelling-wave).",
                    ),
                    "ramp_time": Leaf(
                        Num(lo=0.0),
                        0.0,
                        unit="time",
                        doc="A smooth start (travelling-wave): the amplitude grows as "
                        "(1 − cos(π t / ramp_time)) / 2 up to ramp_time, so the body "
                        "starts at rest from its reference shape; 0: no ramp.",
                    ),
                    "rotation_axis": Leaf(
                        Vec(nonzero=True),
                        [0.0, 0.0, 1.0],
                        doc="The axis of the turn (rotation), right-handed.",
                    ),
                    "centre": Leaf(
                        Vec(),
                        [0.0, 0.0, 0.0],
                        unit="length",
                        doc="A point of the axis of the turn (rotation).",
                    ),
                    "phase": Leaf(
                        Num(),
                        0.0,
                        unit="rad",
                        doc="The phase added to the wave's (travelling-wave): with "
                        "wavenumber = 0, a sinusoidal motion of the whole selection "
                        "lagging another by the difference of their phases.",
                    ),
                    "values": Leaf(
                        Pairs("u"),
                        unit="[time, length]",
                        default_doc='none: required only with kind = "table"',
                        doc="The displacement, piecewise linear in time; before the first "
                        "and after the last time it keeps the end value.",
                    ),
                }
            ),
            doc="A displacement component prescribed in time on a selection (a moving "
            "Dirichlet condition). A degree of freedom takes one condition: a motion where a "
            "`[[boundary]]` or another motion already holds the component is refused.",
        ),
    }

    @classmethod
    def active(cls, scene: dict) -> bool:
        return bool(scene.get("motion"))

    @classmethod
    def check(cls, scene: dict) -> None:
        for i, motion in enumerate(scene["motion"]):
            check_where(motion["where"], f"motion.{i}.where", scene)
            table_iff(motion, f"motion.{i}", "kind", "values", "[t, u] pairs")

    def __init__(self, model: Model):
        from dolfinx import fem

        super().__init__(model)
        self.motions = []
        for k, spec in enumerate(self.scene["motion"]):
            key = f"motion.{k}"
            dim, entities = entities_of(model.body, spec["where"], key + ".where")
            component = spec["component"]
            sub = model.displacement_space(DISPLACEMENT_COMPONENTS[component])
            V, _ = model.dirichlet.space(sub, component)
            dofs = fem.locate_dofs_topological((sub, V), dim, entities)
            if model.comm.allreduce(len(dofs[0])) == 0:
                raise SceneError(f"{key}.where: '{spec['where']}' matches no degree of freedom")
            for holder, other in model.dirichlet.held.get(component, []):
                clash = model.comm.allreduce(int(np.isin(dofs[0], other).sum()))
                if clash:
                    how = "fixed by" if holder.startswith("a ") else "already prescribed by"
                    raise SceneError(
                        f"{key}: {component} is both prescribed here and {how} "
                        f"{holder} at {clash} dofs; a dof takes one condition"
                    )
            model.dirichlet.hold(component, key, dofs[0])
            value = fem.Function(V, name=f"motion_{k}")
            X = V.tabulate_dof_coordinates()[np.asarray(dofs[1])]
            X = X if spec["kind"] == "rotation" else X[:, 0]
            motion = Motion(spec, value, np.asarray(dofs[1]), X, fem.dirichletbc(value, dofs, sub))
            motion.u_index = self._displacement_index(np.asarray(dofs[0]))
            motion.dofs = np.asarray(dofs[0])
            self.motions.append(motion)

    def _displacement_index(self, mixed_dofs):
        """The positions in the displacement arrays (``u_n``, ``v_n``, ``a_n``) of these
        dofs of ``w``."""
        m = self.model
        where = np.full(len(m.w.x.array), -1, dtype=np.int64)
        where[m.u_dofs] = np.arange(len(m.u_dofs))
        return where[mixed_dofs]

    def bcs(self) -> list[dolfinx.fem.DirichletBC]:
        return [m.bc for m in self.motions]

    def reaction_dofs(self) -> list[tuple[str, np.ndarray]]:
        return [(m.spec["name"], m.dofs) for m in self.motions if m.spec["name"] is not None]

    def set_time(self, t: float) -> None:
        for motion in self.motions:
            motion.set(t)

    def speed_scale(self) -> float:
        """The fastest prescribed speed (for the drag's force scale)."""
        return max(m.speed_scale() for m in self.motions)

    def drive_step(self, t: float | None, coefficients: Any) -> None:
        """The corrections ``model.drive`` that make the velocity ``v_{n+1}`` and the
        blended acceleration ``a_{n+1−α_m}`` of the step ending at ``t`` exact on the
        driven dofs: ``v(t⁻)`` and ``(1 − α_m) a(t⁻) + α_m a_n``, where Newmark's
        relations (``coefficients``) would give them from the prescribed ``u(t)``.
        With ``t`` None (a scheme without inertia) the corrections are zero."""
        v_fix, a_fix = (f.x.array for f in self.model.drive)
        v_fix[:] = 0.0
        a_fix[:] = 0.0
        if t is None:
            return
        c, m = coefficients, self.model
        for motion in self.motions:
            i = motion.u_index
            du = motion.at(t, motion.X) - m.u_n.x.array[i]
            v_n, a_n = m.v_n.x.array[i], m.a_n.x.array[i]
            v, a = motion.rates(t, side=-1)
            v_fix[i] = v - scheme_velocity(du, v_n, a_n, c.cv, c.cv_v, c.cv_a)
            a_fix[i] = (
                (1 - c.alpha_m) * a + c.alpha_m * a_n - (c.ca * du + c.ca_v * v_n + c.ca_a * a_n)
            )

    def drive_state(self, t: float) -> None:
        """The stored velocity and acceleration of the driven dofs at ``t``: the
        motion's right-sided derivatives (after a kink, the new slope)."""
        m = self.model
        for motion in self.motions:
            v, a = motion.rates(t, side=+1)
            m.v_n.x.array[motion.u_index] = v
            m.a_n.x.array[motion.u_index] = a


def reach(scene: dict, direction: Sequence[float] | np.ndarray) -> float:
    """How far the scene's ``[[motion]]`` entries may move a node along the unit
    ``direction``: each one's largest displacement along it, added (a bound, for the
    Stokes wall's closest gap)."""
    total = 0.0
    for spec in scene.get("motion") or []:
        if spec["kind"] == "table":
            size = max((abs(float(v)) for _, v in spec["values"]), default=0.0)
        elif spec["kind"] == "rotation":
            continue  # a turn's reach is the body's own size: the run's gap check watches it
        else:
            size = abs(float(spec.get("amplitude", 0.0)))
        total += size * abs(float(direction[DISPLACEMENT_COMPONENTS[spec["component"]]]))
    return total


class Motion:
    """A prescribed displacement component and its Dirichlet value.

    ``travelling-wave``: ``u = s(t) amplitude sin(wavenumber (X − origin) + angular_frequency t
    + phase)``, ``s = (1 − cos(π t / ramp_time)) / 2`` up to ``ramp_time``, 1 after
    with ``X`` the reference X coordinate of each dof; ``table``: piecewise linear
    in time, the same value at every selected dof; ``rotation``: the component of
    ``(R(φ) − I)(X − centre)``, ``φ = angular_frequency t + phase``.
    """

    def __init__(
        self,
        spec: dict,
        value: dolfinx.fem.Function,
        value_dofs: np.ndarray,
        X: np.ndarray,
        bc: dolfinx.fem.DirichletBC,
    ):
        """``value_dofs``: the selected dofs of ``value``; ``X``: their reference X (a
        rotation: their reference positions, (n, 3))."""
        self.spec, self.value, self.value_dofs, self.X, self.bc = spec, value, value_dofs, X, bc
        if spec["kind"] == "table":
            self.table = np.asarray(spec["values"], dtype=float)
        if spec["kind"] == "rotation":
            axis = np.asarray(spec["rotation_axis"], dtype=float)
            self.axis = axis / np.linalg.norm(axis)
            self.arm = X - np.asarray(spec["centre"], dtype=float)[None, :]
            self.index = DISPLACEMENT_COMPONENTS[spec["component"]]

    def _turned(self, t: float) -> np.ndarray:
        """The turned arms ``R(φ(t)) (X − centre)`` (rotation), by Rodrigues."""
        phi = self.spec["angular_frequency"] * t + self.spec["phase"]
        k, r = self.axis, self.arm
        return (
            r * math.cos(phi)
            + np.cross(k, r) * math.sin(phi)
            + np.outer(r @ k, k) * (1 - math.cos(phi))
        )

    def at(self, t: float, X: np.ndarray) -> np.ndarray:
        s = self.spec
        if s["kind"] == "rotation":
            return (self._turned(t) - self.arm)[:, self.index]
        if s["kind"] == "table":
            return np.full_like(X, np.interp(t, self.table[:, 0], self.table[:, 1]))
        ramp = self.ramp(t)[0]
        return (
            ramp
            * s["amplitude"]
            * np.sin(s["wavenumber"] * (X - s["origin"]) + s["angular_frequency"] * t + s["phase"])
        )

    def ramp(self, t: float) -> tuple[float, float, float]:
        """The amplitude's factor ``s(t)`` and its first two derivatives."""
        tau = self.spec["ramp_time"]
        if tau <= 0.0 or t >= tau:
            return 1.0, 0.0, 0.0
        if t <= 0.0:
            return 0.0, 0.0, 0.0
        k = np.pi / tau
        return (0.5 * (1 - np.cos(k * t)), 0.5 * k * np.sin(k * t), 0.5 * k**2 * np.cos(k * t))

    def set(self, t: float) -> None:
        self.value.x.array[self.value_dofs] = self.at(t, self.X)

    def rates(self, t: float, side: int) -> tuple[np.ndarray, np.ndarray]:
        """``(u̇, ü)`` at time ``t`` on the selected dofs: exact derivatives, taken
        from the left (``side`` −1) or the right (+1) at a corner of a table.  A
        table's acceleration is zero between corners (its impulse at a corner is
        the jump between the two sides' velocities)."""
        s = self.spec
        if s["kind"] == "rotation":  # v = ω k × r, a = ω² k × (k × r), r the turned arm
            w, r = s["angular_frequency"], self._turned(t)
            kr = np.cross(self.axis, r)
            return w * kr[:, self.index], w**2 * np.cross(self.axis, kr)[:, self.index]
        if s["kind"] == "table":
            times, values = self.table[:, 0], self.table[:, 1]
            slope = 0.0
            if len(times) > 1:
                # the segment containing t, the one after a corner for side +1; before
                # the first and after the last time the value is constant
                tol = 1e-12 * max(1.0, float(np.abs(times).max()))
                k = (
                    np.searchsorted(times, t + tol, side="right")
                    if side > 0
                    else np.searchsorted(times, t - tol, side="left")
                )
                if 0 < k < len(times):
                    slope = (values[k] - values[k - 1]) / (times[k] - times[k - 1])
            return np.full_like(self.X, slope), np.zeros_like(self.X)
        phase = s["wavenumber"] * (self.X - s["origin"]) + s["angular_frequency"] * t + s["phase"]
        w, b = s["angular_frequency"], s["amplitude"]
        r, dr, ddr = self.ramp(t)
        u, du, ddu = b * np.sin(phase), b * w * np.cos(phase), -b * w**2 * np.sin(phase)
        return r * du + dr * u, r * ddu + 2 * dr * du + ddr * u

    def speed_scale(self) -> float:
        """The largest speed this motion prescribes."""
        s = self.spec
        if s["kind"] == "rotation":
            return abs(s["angular_frequency"]) * float(
                np.linalg.norm(self.arm, axis=1).max(initial=0.0)
            )
        if s["kind"] == "table":
            table = self.table
            if len(table) < 2:
                return 0.0
            rates = np.abs(np.diff(table[:, 1]) / np.maximum(np.diff(table[:, 0]), 1e-300))
            return float(rates.max())
        return abs(s["amplitude"] * s["angular_frequency"])
