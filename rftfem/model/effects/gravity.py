"""Gravity: ``[[load]]`` of kind ``gravity``, a body force ``(ρ − ρ_f) t g`` per
reference area, with the fluid's density ρ_f for buoyancy (docs/model.md §5.6).

``ρ`` and ``t`` are the shell's cellwise density and thickness, so a part with
another density weighs differently.  The force is dead: it keeps its direction
and, per reference area, its size.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from rftfem.forms.gravity import body_force_work
from rftfem.model.effects.base import Load
from rftfem.scene.schema import NONNEGATIVE, Leaf, Vec

if TYPE_CHECKING:
    import ufl

    from rftfem.model.shell_model import Model

KIND = "gravity"


class Gravity(Load):
    name = KIND
    load_kinds = {
        KIND: {
            "value": Leaf(
                Vec(),
                required=True,
                unit="length/time²",
                doc="The acceleration of gravity g in global axes (e.g. [0, 0, -9810] "
                "in mm/s²), multiplied by the ramp's scale.",
            ),
            "fluid_density": Leaf(
                NONNEGATIVE,
                0.0,
                unit="mass/length³",
                doc="The density ρ_f of the fluid around the body: the body "
                "force is (ρ − ρ_f) t g (buoyancy); 0 in vacuum.",
            ),
        }
    }
    kind_docs = {
        KIND: "The weight of the shell, less its buoyancy: a body force "
        "(ρ − ρ_f) t g per reference area."
    }

    def __init__(self, model: Model):
        from dolfinx import fem
        from petsc4py import PETSc

        super().__init__(model)
        mat, k = model.material, model.kinematics()
        self.accelerations = [
            fem.Constant(model.mesh, np.zeros(3, dtype=PETSc.ScalarType)) for _ in self.entries
        ]
        terms = [
            body_force_work(
                mat["rho"] - ld["fluid_density"],
                mat["t"],
                g,
                k.du,
                model.dx(metadata={"quadrature_degree": 2}),
            )
            for (_, ld), g in zip(self.entries, self.accelerations)
        ]
        self._work = -sum(terms[1:], terms[0])

    def forces(self) -> ufl.Form | None:
        return self._work

    def set_time(self, t: float) -> None:
        for (_, ld), g in zip(self.entries, self.accelerations):
            g.value[:] = np.asarray(ld["value"], dtype=float) * self.scale(ld, t)

    def force_scales(self) -> list[float]:
        """The largest net weight |ρ − ρ_f| t |g| A over the shell and its parts."""
        m, shell = self.model, self.scene["shell"]

        def net(p, ld):  # a field's extremes of density, its largest thickness
            rho = {m.material_value("density", how, p["density"]) for how in ("min", "max")}
            return max(abs(r - ld["fluid_density"]) for r in rho) * m.material_value(
                "thickness", "max", p["thickness"]
            )

        return [
            max(net(p, ld) for p in [shell, *shell["parts"]])
            * float(np.linalg.norm(ld["value"]))
            * self.model.area()
            for _, ld in self.entries
        ]
