"""Prescribed motion, the scene's ``[[motion]]``: a displacement component given
in time on a selection, a moving Dirichlet condition (docs/model.md §5.7).

The value lives in a Function on the collapsed component space and is set at
every time the solver visits.  A degree of freedom takes one condition: a
motion where a ``[[boundary]]`` or another motion already holds the component
is refused.
"""

from __future__ import annotations

import numpy as np

from rftfem.errors import SceneError
from rftfem.schema import Array, Leaf, Num, Pairs, Str, Table, Where, table_iff
from rftfem.selectors import check_where, entities_of

from .base import Effect
from .boundary import DISPLACEMENT_COMPONENTS


class Motions(Effect):
    name = "prescribed-motion"
    moving = True
    keys = {
    "motion": Array(Table({
        "where": Leaf(Where(), "all",
                       doc="Where, as for `[[boundary]].where`."),
        "component": Leaf(Str(("ux", "uy", "uz")), required=True,
                           doc="The displacement component prescribed (global axes)."),
        "kind": Leaf(Str(("travelling-wave", "table")), "travelling-wave",
                      doc='"travelling-wave": u = amplitude sin(wavenumber (X − origin) + '
                          "angular_frequency t), with X each node's reference X coordinate; "
                          '"table": one value on the whole selection, interpolated in '
                          "`values`."),
        "amplitude": Leaf(Num(), 0.0, unit="length",
                           doc="The wave's amplitude (travelling-wave)."),
        "wavenumber": Leaf(Num(), 0.0, unit="rad/length",
                            doc="The wave number (travelling-wave); with a positive "
                                "angular_frequency the wave runs towards −X."),
        "angular_frequency": Leaf(Num(), 0.0, unit="rad/time",
                                   doc="The angular frequency (travelling-wave)."),
        "origin": Leaf(Num(), 0.0, unit="length",
                        doc="The reference X where the wave's phase is zero at t = 0 "
                            "(travelling-wave)."),
        "values": Leaf(Pairs("u"), unit="[time, length]",
                        default_doc='none: required only with kind = "table"',
                        doc="The displacement, piecewise linear in time; before the first "
                            "and after the last time it keeps the end value."),
    }), doc="A displacement component prescribed in time on a selection (a moving "
            "Dirichlet condition). A degree of freedom takes one condition: a motion where a "
            "`[[boundary]]` or another motion already holds the component is refused."),
    }

    @classmethod
    def active(cls, scene):
        return bool(scene.get("motion"))

    @classmethod
    def check(cls, scene):
        for i, motion in enumerate(scene["motion"]):
            check_where(motion["where"], f"motion.{i}.where", scene)
            table_iff(motion, f"motion.{i}", "kind", "values", "[t, u] pairs")

    def __init__(self, model):
        from dolfinx import fem

        super().__init__(model)
        self.motions = []
        for k, spec in enumerate(self.scene["motion"]):
            key = f"motion.{k}"
            dim, entities = entities_of(model.body, spec["where"], key + ".where")
            component = spec["component"]
            sub = model.W.sub(0).sub(DISPLACEMENT_COMPONENTS[component])
            V, _ = model.dirichlet.space(sub, component)
            dofs = fem.locate_dofs_topological((sub, V), dim, entities)
            if model.comm.allreduce(len(dofs[0])) == 0:
                raise SceneError(f"{key}.where: '{spec['where']}' matches no degree of freedom")
            for holder, other in model.dirichlet.held.get(component, []):
                clash = model.comm.allreduce(int(np.isin(dofs[0], other).sum()))
                if clash:
                    how = "fixed by" if holder.startswith("a ") else "already prescribed by"
                    raise SceneError(f"{key}: {component} is both prescribed here and {how} "
                                     f"{holder} at {clash} dofs; a dof takes one condition")
            model.dirichlet.hold(component, key, dofs[0])
            value = fem.Function(V, name=f"motion_{k}")
            X = V.tabulate_dof_coordinates()[np.asarray(dofs[1]), 0]
            self.motions.append(Motion(spec, value, np.asarray(dofs[1]), X,
                                       fem.dirichletbc(value, dofs, sub)))

    def bcs(self):
        return [m.bc for m in self.motions]

    def set_time(self, t):
        for motion in self.motions:
            motion.set(t)

    def speed_scale(self) -> float:
        """The fastest prescribed speed (for the drag's force scale)."""
        return max(m.speed_scale() for m in self.motions)


class Motion:
    """A prescribed displacement component and its Dirichlet value.

    ``travelling-wave``: ``u = amplitude sin(wavenumber (X − origin) + angular_frequency t)``
    with ``X`` the reference X coordinate of each dof; ``table``: piecewise linear
    in time, the same value at every selected dof.
    """

    def __init__(self, spec, value, value_dofs, X, bc):
        """``value_dofs``: the selected dofs of ``value``; ``X``: their reference X."""
        self.spec, self.value, self.value_dofs, self.X, self.bc = spec, value, value_dofs, X, bc
        if spec["kind"] == "table":
            self.table = np.asarray(spec["values"], dtype=float)

    def at(self, t: float, X):
        s = self.spec
        if s["kind"] == "table":
            return np.full_like(X, np.interp(t, self.table[:, 0], self.table[:, 1]))
        return s["amplitude"] * np.sin(s["wavenumber"] * (X - s["origin"])
                                       + s["angular_frequency"] * t)

    def set(self, t: float):
        self.value.x.array[self.value_dofs] = self.at(t, self.X)

    def speed_scale(self) -> float:
        """The largest speed this motion prescribes."""
        s = self.spec
        if s["kind"] == "table":
            table = self.table
            if len(table) < 2:
                return 0.0
            rates = np.abs(np.diff(table[:, 1]) / np.maximum(np.diff(table[:, 0]), 1e-300))
            return float(rates.max())
        return abs(s["amplitude"] * s["angular_frequency"])
