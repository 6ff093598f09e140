"""Magnetic body couples (docs/model.md §5.5), the scene's ``[magnetic]``.

Hard-magnetic regions carry a remanent magnetization ``m q₀`` that turns with
the material (``q = F q₀ / |F q₀|``); a uniform applied field ``b(t)`` does the
virtual work ``∫ t m b·δq J dA₀`` on them (``forms.magnetic``).  The field ramps
up along a direction, then turns about an axis.  The component writes the
field and the body's total magnetic moment to body.csv and the magnetization
to fields.xdmf.
"""

from __future__ import annotations

import math

import numpy as np
import ufl

from rftfem.errors import SceneError
from rftfem.forms import kinematics, magnetic
from rftfem.triad import rotate
from rftfem.schema import (NONNEGATIVE, Array, Leaf, Num, Str, Table, Vec, check_unique, fmt,
                           unit_vector)
from rftfem.selectors import cells_of, check_region_ref

from .base import Effect


class Magnetic(Effect):
    name = "magnetic"
    keys = {
    "magnetic": Table({
        "parts": Array(Table({
            "region": Leaf(Str(name=True), required=True,
                            doc="The magnetized region; a cell takes one magnetization."),
            "magnetization": Leaf(NONNEGATIVE, required=True, unit="current/length",
                                   doc="The size of the remanent magnetization; 0 switches "
                                       "the part off."),
            "direction": Leaf(Vec(nonzero=True), required=True,
                               doc="The magnetization's direction in the reference state "
                                   "(normalised); it turns with the material fibre."),
        }), min_items=1, doc="The magnetized regions of the body."),
        "field": Table({
            "strength": Leaf(NONNEGATIVE, 0.0, unit="force/(current·length)",
                              doc="The size of the applied flux density once ramped up "
                                  "(tesla in SI units; 1 mT is 1e-6 N/(A·mm))."),
            "ramp_time": Leaf(NONNEGATIVE, 0.0, unit="time",
                               doc="The time the field takes to grow linearly from 0 to "
                                   "`strength` along `direction`; 0 starts at full "
                                   "strength."),
            "direction": Leaf(Vec(nonzero=True), [1.0, 0.0, 0.0],
                               doc="The field's direction during the ramp and when it starts "
                                   "to turn (normalised)."),
            "frequency": Leaf(Num(), 0.0, unit="1/time",
                               doc="Turns per unit time after `ramp_time` (Hz with "
                                   "seconds), right-handed about `rotation_axis`; negative "
                                   "turns the other way, 0 keeps the field still."),
            "rotation_axis": Leaf(Vec(nonzero=True), [0.0, 0.0, 1.0],
                                   doc="The axis the field turns about (normalised); not "
                                       "parallel to `direction` when the frequency is not "
                                       "0."),
        }, doc="The applied field, uniform in space: first it ramps up along a direction, "
               "then it turns about an axis."),
    }, optional=True,
        doc="Couples of an applied magnetic field on magnetized (hard-magnetic) regions."),
    }
    columns = ["field_x", "field_y", "field_z", "moment_x", "moment_y", "moment_z"]

    @classmethod
    def active(cls, scene):
        return bool(scene.get("magnetic"))

    @classmethod
    def check(cls, scene):
        if not scene["magnetic"]:
            return
        field = scene["magnetic"]["field"]
        if field["frequency"] != 0.0:  # a rotating field needs an axis across its direction
            b, a = unit_vector(field["direction"]), unit_vector(field["rotation_axis"])
            cross = (b[1] * a[2] - b[2] * a[1], b[2] * a[0] - b[0] * a[2],
                     b[0] * a[1] - b[1] * a[0])
            if math.hypot(*cross) <= 1e-9:
                raise SceneError(
                    f"magnetic.field.rotation_axis: expected an axis not parallel to "
                    f"magnetic.field.direction = {fmt(field['direction'])} (the field would "
                    f"not rotate at frequency = {fmt(field['frequency'])}), found "
                    f"{fmt(field['rotation_axis'])}")
        for i, part in enumerate(scene["magnetic"]["parts"]):
            check_region_ref(part["region"], f"magnetic.parts.{i}.region", scene)
        check_unique(scene["magnetic"]["parts"], "region", "magnetic.parts", "region")

    def __init__(self, model):
        """The remanent magnetization ``m q₀`` of every part is stored cellwise (DG0
        vector); the form is integrated over the magnetized cells only."""
        from dolfinx import fem
        from petsc4py import PETSc

        from rftfem import compat

        super().__init__(model)
        mag, mesh = self.scene["magnetic"], model.mesh
        V = compat.function_space(mesh, "DG", 0, (3,))
        self.remanence = fem.Function(V, name="remanent_magnetization")
        dofs = compat.cell_dofs(V)[:, 0]
        owner = {}
        for i, part in enumerate(mag["parts"]):
            cells = cells_of(model.body, [part["region"]], f"magnetic.parts.{i}.region")
            for j, other in owner.items():
                if model.comm.allreduce(int(np.isin(cells, other).sum())):
                    raise SceneError(f"magnetic.parts.{i}.region: '{part['region']}' overlaps "
                                     f"magnetic.parts.{j}.region; a cell has one magnetization")
            owner[i] = cells
            q0 = np.asarray(part["direction"], dtype=float)
            self.remanence.x.array.reshape(-1, 3)[dofs[cells]] = (
                part["magnetization"] * q0 / np.linalg.norm(q0))
        self.remanence.x.scatter_forward()
        # parts switched off (magnetization 0, e.g. in a sweep) are left out of
        # the measure: q = F q₀ needs q₀ = M/|M|
        magnetized = [owner[i] for i, part in enumerate(mag["parts"])
                      if part["magnetization"] > 0]
        cells = np.unique(np.concatenate(magnetized or [np.empty(0, np.int32)])).astype(np.int32)
        tags = compat.create_meshtags(mesh, mesh.topology.dim, cells,
                                      np.ones(len(cells), dtype=np.int32))
        self.dx = ufl.Measure("dx", domain=mesh, subdomain_data=tags,
                              metadata={"quadrature_degree": 4})(1)
        self.field = fem.Constant(mesh, np.zeros(3, dtype=PETSc.ScalarType))
        k = model.kinematics()
        M = self.remanence
        self.m = ufl.sqrt(ufl.dot(M, M))
        F = kinematics.deformation_gradient(k.g1, k.g2, k.d, k.G1, k.G2,
                                            kinematics.unit_normal(k.G1, k.G2))
        self.q = magnetic.magnetization_direction(F, M / self.m)
        self.magnetization = magnetic.magnetization(F, M)
        self.J = kinematics.area_ratio(k.g1, k.g2, k.G1, k.G2)
        self._moment_forms = None

    def forces(self):
        k, t = self.model.kinematics(), self.model.material["t"]
        dq = ufl.derivative(self.q, self.model.w, k.w_test)
        return -magnetic.magnetic_work(t, self.m, self.field, dq, self.J, self.dx)

    def set_time(self, t):
        self.field.value[:] = self.field_at(t)

    def field_at(self, t: float) -> np.ndarray:
        """The applied field ``b(t)`` of ``[magnetic.field]``.

        Phase 1 (``t ≤ ramp_time``): strength ramps linearly from 0 along
        ``direction``.  Phase 2: full strength, rotating right-handedly about
        ``rotation_axis`` at ``frequency`` turns per unit time from ``direction``.
        """
        f = self.scene["magnetic"]["field"]
        direction, axis = (np.array(unit_vector(f[key])) for key in ("direction", "rotation_axis"))
        ramp = f["ramp_time"]
        if t <= ramp:
            return f["strength"] * (t / ramp if ramp > 0 else 1.0) * direction
        angle = 2 * np.pi * f["frequency"] * (t - ramp)
        return f["strength"] * rotate(direction[None, :], angle * axis[None, :])[0]

    def moment(self) -> np.ndarray:
        """Total magnetic moment ``∫ t m q J dA₀`` of the current iterate (global).

        The field's torque on a rigid body is ``Q × b``; the field's work over a
        step is ``b·ΔQ`` to first order (the couple's virtual work is ``b·δq``).
        """
        m = self.model
        if self._moment_forms is None:
            self._moment_forms = [m.compile(c) for c in magnetic.magnetic_moment(
                m.material["t"], self.m, self.q, self.J, self.dx)]
        return np.array([m.assemble_scalar(f) for f in self._moment_forms])

    def force_scales(self):
        """The largest couple of one part, ``t m B A``, as a force over the length."""
        m, shell = self.model, self.scene["shell"]
        f = self.scene["magnetic"]["field"]
        return [shell["thickness"] * part["magnetization"] * f["strength"]
                * m.area(cells_of(m.body, [part["region"]])) / m.body.length
                for part in self.scene["magnetic"]["parts"]]

    def values(self, t):
        return [*self.field_at(t), *self.moment()]

    def fields(self):
        return {"magnetization": self.magnetization}  # m q, 0 off the parts
