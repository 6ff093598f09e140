"""Magnetic couples and forces (docs/model.md §5.5), the scene's ``[magnetic]``.

Hard-magnetic regions carry a remanent magnetization ``M = m q₀`` that turns
with the material (``q = F q₀ / |F q₀|``).  Each part's ``m`` and ``q₀`` are
numbers, formulas of the reference coordinates or a profile file.

- A uniform applied field ``b(t)`` (``kind`` "rotating", "expression" of t,
  "table") does the virtual work ``∫ t m b·δq J dA₀``: couples only
  (``forms.magnetic.magnetic_work``).
- A nonuniform field ``B(x, t)`` ("expression" of x, y, z, t, or "dipole") enters
  as the potential energy ``−∫ t (F M)·B(x, t) dA₀`` at the current position
  ``x = X + u``; its derivative gives the couple and the gradient force together
  (``forms.magnetic.magnetic_energy``).
- Permanent magnets, ``[[magnetic.source]]`` (:mod:`rftfem.model.magnets`), add
  their fields to ``[magnetic.field]``: the sum is a nonuniform field.

The component writes the field and the body's total magnetic moment to
body.csv and the magnetization to fields.xdmf.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import ufl

from rftfem.errors import SceneError
from rftfem.forms import kinematics, magnetic
from rftfem.model.effects.base import Effect
from rftfem.model.effects.magnetic_keys import REFERENCE, SCHEMA
from rftfem.model.effects.magnetization import (
    cellwise_remanence,
    magnetized_measure,
    remanence_expression,
    varies,
)
from rftfem.model.magnetic_sources import (
    NonuniformField,
    UniformField,
    check_field,
    is_uniform,
    read_profile,
)
from rftfem.model.magnets import SourcedField, check_sources
from rftfem.scene.expressions import parse
from rftfem.scene.schema import (
    check_unique,
)
from rftfem.scene.selectors import cells_of, check_region_ref

if TYPE_CHECKING:
    from types import SimpleNamespace

    import dolfinx.fem
    import dolfinx.mesh

    from rftfem.model.shell_model import Model


class Magnetic(Effect):
    name = "magnetic"
    keys = {"magnetic": SCHEMA}
    columns = ["field_x", "field_y", "field_z", "moment_x", "moment_y", "moment_z"]

    @classmethod
    def active(cls, scene: dict) -> bool:
        return bool(scene.get("magnetic"))

    @classmethod
    def names(cls, scene: dict) -> list[str]:
        """ "magnetic", then what the scene adds to today's uniform couple: the field's
        kind, its gradient force, magnetization profiles."""
        if not cls.active(scene):
            return []
        mag = scene["magnetic"]
        kind = mag["field"]["kind"]
        out = ["magnetic"]
        if kind != "rotating":
            out.append(f"magnetic field: {kind}")
        out += [f"magnetic source: {s['kind']}" for s in mag.get("source") or []]
        if not is_uniform(mag["field"]) or mag.get("source"):
            out.append("magnetic gradient force")
        if any(varies(part) for part in mag["parts"]):
            out.append("magnetization profile")
        return out

    @classmethod
    def check(cls, scene: dict) -> None:
        if not scene["magnetic"]:
            return
        check_field(scene["magnetic"]["field"])
        check_sources(scene["magnetic"].get("source") or [])
        for i, part in enumerate(scene["magnetic"]["parts"]):
            where = f"magnetic.parts.{i}"
            check_region_ref(part["region"], f"{where}.region", scene)
            if part["profile"] is not None:
                for key in ("magnetization", "direction"):
                    if part[key] is not None:
                        raise SceneError(
                            f"{where}.{key}: not used with {where}.profile (the "
                            "profile file gives the magnetization vector)"
                        )
            else:
                for key in ("magnetization", "direction"):
                    if part[key] is None:
                        raise SceneError(
                            f"missing required key '{where}.{key}' (or give {where}.profile)"
                        )
        check_unique(scene["magnetic"]["parts"], "region", "magnetic.parts", "region")

    def __init__(self, model: Model):
        """The remanent magnetization ``M = m q₀``: with plain numbers stored cellwise
        (DG0 vector); with formulas or profiles a UFL expression ``Σ χ_p M_p(X)`` (χ_p
        the part's cells).  The forms are integrated over the magnetized cells only."""
        super().__init__(model)
        mag, mesh = self.scene["magnetic"], model.mesh
        self.parts = mag["parts"]
        self.part_cells = owner = self._cells_of_parts()
        plain = not any(varies(part) for part in self.parts)
        if plain:
            self.remanence, on = cellwise_remanence(mesh, self.parts, owner)
            M = self.remanence
        else:
            M, self.profile_fields = remanence_expression(mesh, self.scene, self.parts, owner)
            on = list(owner.values())
        self.dx = magnetized_measure(mesh, on)
        k = model.kinematics()
        self._magnetization_terms(k, M, plain)
        self._moment_forms = None
        self._applied_field(mag, mesh, k)

    def _cells_of_parts(self) -> dict[int, np.ndarray]:
        """Each part's cells, by its index; a cell in two parts is a SceneError."""
        model = self.model
        owner = {}
        for i, part in enumerate(self.parts):
            cells = cells_of(model.body, [part["region"]], f"magnetic.parts.{i}.region")
            for j, other in owner.items():
                if model.comm.allreduce(int(np.isin(cells, other).sum())):
                    raise SceneError(
                        f"magnetic.parts.{i}.region: '{part['region']}' overlaps "
                        f"magnetic.parts.{j}.region; a cell has one magnetization"
                    )
            owner[i] = cells
        return owner

    def _magnetization_terms(self, k: SimpleNamespace, M: ufl.core.expr.Expr, plain: bool) -> None:
        """``M``, ``m = |M|``, the deformation gradient ``F``, the carried direction ``q``,
        the magnetization ``F M`` as the material carries it and the area ratio ``J``."""
        self.M = M
        self.m = ufl.sqrt(ufl.dot(M, M))
        self.F = kinematics.deformation_gradient(
            k.g1, k.g2, k.d, k.G1, k.G2, kinematics.unit_normal(k.G1, k.G2)
        )
        self.q = (
            magnetic.magnetization_direction(self.F, M / self.m)
            if plain
            else magnetic.safe_direction(self.F * M)
        )
        self.magnetization = magnetic.magnetization(self.F, M)
        self.J = kinematics.area_ratio(k.g1, k.g2, k.G1, k.G2)

    def _applied_field(self, mag: dict, mesh: dolfinx.mesh.Mesh, k: SimpleNamespace) -> None:
        """The applied field: ``b(t)`` as a Constant, or ``B(x, t)`` in UFL at the current
        position (the magnets start outside the body)."""
        from dolfinx import fem
        from petsc4py import PETSc

        model = self.model
        field, sources = mag["field"], mag.get("source") or []
        # magnets make the field nonuniform: B_field (uniform or not) + Σ B_magnet
        self.uniform = is_uniform(field) and not sources
        if self.uniform:
            self.source = UniformField(field)
            self.field = fem.Constant(mesh, np.zeros(3, dtype=PETSc.ScalarType))
        else:
            base = UniformField(field) if is_uniform(field) else NonuniformField(field)
            self.source = SourcedField(base, sources) if sources else base
            x = ufl.SpatialCoordinate(mesh) + k.u  # the current mid-surface position
            #: 1, or 0 while the model's loads are off (a uniform field is set to 0)
            self.switch = fem.Constant(mesh, PETSc.ScalarType(1.0))
            self.field = self.switch * self.source.ufl(mesh, x)
            nodes = model.Vu.tabulate_dof_coordinates()
            self.source.check_outside(nodes, _largest_cell(mesh, model.comm), model.comm)

    def forces(self) -> ufl.Form | None:
        k, t = self.model.kinematics(), self.model.material["t"]
        if self.uniform:
            dq = ufl.derivative(self.q, self.model.z, k.w_test)
            return -magnetic.magnetic_work(t, self.m, self.field, dq, self.J, self.dx)
        energy = magnetic.magnetic_energy(t, self.F, self.M, self.field, self.dx)
        return ufl.derivative(energy, self.model.z, k.w_test)

    is_load = True

    def set_time(self, t: float) -> None:
        on = 1.0 if self.model.loads_on else 0.0
        if self.uniform:
            self.field.value[:] = on * self.source.at(t)
        else:
            self.switch.value = on
            self.source.set_time(t)

    def loads_at_start(self) -> list[str]:
        return ["magnetic.field"] if np.any(self.field_at(0.0) != 0.0) else []

    def field_at(self, t: float) -> np.ndarray:
        """The applied field at time ``t``: ``b(t)``, or a nonuniform field at the
        body's current centroid."""
        if self.uniform:
            return self.source.at(t)
        return self.source.at(self.model.centroid()[None, :], t)[0]

    def moment(self) -> np.ndarray:
        """Total magnetic moment ``∫ t m q J dA₀`` of the current iterate (global).

        The field's torque on a rigid body is ``Q × b``; the field's work over a
        step is ``b·ΔQ`` to first order (the couple's virtual work is ``b·δq``).
        """
        m = self.model
        if self._moment_forms is None:
            self._moment_forms = [
                m.compile(c)
                for c in magnetic.magnetic_moment(m.material["t"], self.m, self.q, self.J, self.dx)
            ]
        return np.array([m.assemble_scalar(f) for f in self._moment_forms])

    def force_scales(self) -> list[float]:
        """The largest couple of one part, ``t m B A``, as a force over the length."""
        m = self.model
        end = self.scene["time"]["end"]
        if self.uniform:
            strength = self.source.scale(end)
        else:
            strength = self.source.scale(m.Vu.tabulate_dof_coordinates(), end, m.comm)
        return [
            m.material_value("thickness", "shell")
            * self._largest_magnetization(i)
            * strength
            * m.area(self.part_cells[i])
            / m.body.length
            for i in range(len(self.parts))
        ]

    def _largest_magnetization(self, i: int) -> float:
        part = self.parts[i]
        if not varies(part):
            return part["magnetization"]
        # sampled at the part's P2 nodes (formulas) or the profile's points
        from rftfem import compat

        mesh = self.model.mesh
        V = compat.function_space(mesh, "DG", 0)  # cell midpoints suffice for a scale
        at = V.tabulate_dof_coordinates()[self.part_cells[i]]
        if part["profile"] is not None:
            path = (
                Path(self.scene.get("_folder") or Path(self.scene["_path"]).parent)
                / Path(part["profile"]).expanduser()
            )
            values = read_profile(path, f"magnetic.parts.{i}.profile")[1]
            local = float(np.linalg.norm(values, axis=1).max())
        else:
            env = {"X": at[:, 0], "Y": at[:, 1], "Z": at[:, 2]}
            m = parse(part["magnetization"], "m", REFERENCE).numbers(env)
            local = float(np.max(np.abs(m), initial=0.0))
        return self.model.comm.allreduce(local, op=_max())

    def values(self, t: float) -> list[float]:
        return [*self.field_at(t), *self.moment()]

    def fields(self) -> dict[str, dolfinx.fem.Function | ufl.core.expr.Expr]:
        return {"magnetization": self.magnetization}  # m q, 0 off the parts


def _largest_cell(mesh, comm) -> float:
    """The largest cell diameter (from the cells' geometry nodes)."""
    from rftfem import compat

    cells = compat.geometry_cells(mesh)[0]
    x = mesh.geometry.x[cells]
    local = (
        float(np.linalg.norm(x[:, :, None, :] - x[:, None, :, :], axis=-1).max())
        if len(cells)
        else 0.0
    )
    return comm.allreduce(local, op=_max())


def _max():
    from mpi4py import MPI

    return MPI.MAX
