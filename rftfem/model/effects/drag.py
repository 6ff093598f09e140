"""Resistive-force-theory drag (docs/model.md §5.4), ``[fluid] model = "rft"``.

The traction ``C̃ v`` per current area resists the local velocity; its virtual
work comes from ``forms.drag``.  The component also gives the drag's power
(a body.csv column), the total drag force and the rotational drag coefficient
of the current shape, which the demos and tests measure.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Sequence

import numpy as np
import ufl

from rftfem.errors import SceneError
from rftfem.forms import drag
from rftfem.model.effects import fluid
from rftfem.model.effects.base import FluidModel
from rftfem.model.ranks import gather_rows

if TYPE_CHECKING:
    from rftfem.model.body_parts import BodyPart
    from rftfem.model.shell_model import Model


class Drag(FluidModel):
    name = "drag"
    keys = {"fluid": fluid.SCHEMA}
    columns = ["drag_power"] + fluid.RESULTANT_COLUMNS

    @classmethod
    def active(cls, scene: dict) -> bool:
        return fluid.model_of(scene) == "rft"

    @classmethod
    def check(cls, scene: dict) -> None:
        fluid.check(scene)

    def __init__(self, model: Model):
        from dolfinx import fem
        from petsc4py import PETSc

        super().__init__(model)
        #: the coefficients [C1, C2, C3]: the scene's, or from its viscosity
        self.C = self._coefficients()
        #: C1 = C2: the liquid resists every tangent direction alike, and the drag needs
        #: no material axis (forms.drag.transverse_drag_tensor): a closed body can have it
        self.axis_free = self.C[0] == self.C[1]
        if model.triad.axis_along_normal and not self.axis_free:
            raise model.axis_error(
                "the drag frame needs a tangent axis where C1 and C2 "
                "differ; give fluid.drag with C1 = C2 for a body "
                "without one"
            )
        C = np.asarray(self.C, dtype=PETSc.ScalarType)
        self.coefficients = fem.Constant(model.mesh, C)
        self._forms = {}
        self._spin = None

    def describe(self) -> dict:
        """The coefficients the run uses and where they came from (``rftfem check``,
        summary.json's ``fluid``)."""
        given = fluid.settings(self.scene)
        source = (
            "fluid.drag"
            if given.drag is not None
            else f"fluid.viscosity = {given.viscosity:g} (slender-body drag of the "
            f"body's length and width along shell.axis)"
        )
        return {
            "model": "rft",
            "drag": [float(c) for c in self.C],
            "from": source,
            "axis_free": bool(self.axis_free),
        }

    def check_lines(self) -> list[str]:
        d = self.describe()
        return [
            f"fluid: drag coefficients [{', '.join(f'{c:.4g}' for c in d['drag'])}] "
            f"from {d['from']}"
        ]

    def _coefficients(self) -> list[float]:
        given = fluid.settings(self.scene)
        if given.drag is not None:
            return list(given.drag)
        m = self.model
        owned = m.Vu.dofmap.index_map.size_local
        x = gather_rows(m.Vu.tabulate_dof_coordinates()[:owned], m.comm)
        length, width = fluid.body_extents(x, self.scene["shell"]["axis"])
        if width <= 0.0:
            raise SceneError(
                "fluid.viscosity: the body has no width across shell.axis, so "
                "the slender-body drag is undefined; give fluid.drag"
            )
        return fluid.slender_body_drag(given.viscosity, length, width)

    def _term(self, term, *args):
        """A ``forms.drag`` term of the current iterate with the scene's coefficients."""
        m, C = self.model, self.coefficients
        k = m.kinematics()
        axis = None if self.axis_free else m.material_axis
        return term(
            [C[0], C[1], C[2]],
            k.F_s,
            axis,
            *args,
            k.g1,
            k.g2,
            k.G1,
            k.G2,
            m.dx(metadata={"quadrature_degree": 4}),
        )

    def forces(self) -> ufl.Form | None:
        k = self.model.kinematics()
        return self._term(drag.drag_work, self.model.velocity(k.u), k.du)

    def force_scales(self) -> list[float]:
        return fluid.force_scales(self)

    def _assembled(self, name, build):
        m = self.model
        if name not in self._forms:
            form = build()
            self._forms[name] = (
                [m.compile(f) for f in form] if isinstance(form, list) else m.compile(form)
            )
        return self._forms[name]

    def power(self) -> float:
        """Power dissipated by the drag, ``∫ (C̃ v)·v J dA₀`` (global), in the current
        configuration with the stored velocity ``v_n`` (after a step: its end state)."""
        return self.model.assemble_scalar(
            self._assembled("power", lambda: self._term(drag.drag_power, self.model.v_n))
        )

    def force(self) -> np.ndarray:
        """Total drag force on the body ``∫ C̃ v J dA₀`` (global), in the current
        configuration with the stored velocity ``v_n``."""
        forms = self._assembled("force", lambda: self._term(drag.drag_force, self.model.v_n))
        return np.array([self.model.assemble_scalar(f) for f in forms])

    def rotational(self, axis: Sequence[float] | np.ndarray) -> float:
        """RFT drag coefficient ``ζ`` of a rigid rotation of the current shape about
        ``axis`` through the centroid: the dissipated power at unit rate,
        ``∫ (C̃ v)·v J dA₀`` with ``v = a × (x − x_c)`` (force·length·time)."""
        from dolfinx import fem
        from petsc4py import PETSc

        m = self.model
        if self._spin is None:
            axis_c, centre = (
                fem.Constant(m.mesh, np.zeros(3, dtype=PETSc.ScalarType)) for _ in range(2)
            )
            x = ufl.SpatialCoordinate(m.mesh) + m.kinematics().u
            v = ufl.cross(axis_c, x - centre)
            self._spin = (axis_c, centre, m.compile(self._term(drag.drag_power, v)))
        axis_c, centre, form = self._spin
        axis = np.asarray(axis, dtype=float)
        axis_c.value[:] = axis / np.linalg.norm(axis)
        centre.value[:] = m.centroid()
        return m.assemble_scalar(form)

    def resultant(self) -> np.ndarray:
        """The liquid's force and moment about the origin on the body,
        ``−∫ C̃ v J dA₀`` and ``−∫ x × C̃ v J dA₀`` (global), with the stored velocity."""
        m = self.model
        forms = self._assembled(
            "moment",
            lambda: self._term(
                drag.drag_moment, m.v_n, ufl.SpatialCoordinate(m.mesh) + m.kinematics().u
            ),
        )
        moment = np.array([m.assemble_scalar(f) for f in forms])
        return -np.concatenate([self.force(), moment])

    def values(self, t: float) -> list[float]:
        return [self.power(), *self.resultant()]

    def resultant_on(self, part: BodyPart) -> np.ndarray:
        """:meth:`resultant` over one body's cells."""
        from rftfem.model.body_parts import restricted

        m, chi = self.model, part.chi
        x = ufl.SpatialCoordinate(m.mesh) + m.kinematics().u
        forms = self._assembled(
            f"resultant {part.name}",
            lambda: [
                restricted(f, chi)
                for f in self._term(drag.drag_force, m.v_n) + self._term(drag.drag_moment, m.v_n, x)
            ],
        )
        return -np.array([m.assemble_scalar(f) for f in forms])
