"""The bodies of a scene of several (``[[body]]`` tables, one combined mesh): each
one's cells as an indicator and its nodes, and the measures that body.csv gives per
body: centroid, mean velocity, stored energy and the liquid's resultant on it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import ufl
from dolfinx import fem
from petsc4py import PETSc

from rftfem import compat
from rftfem.forms import inertia
from rftfem.model.effects.base import FluidModel
from rftfem.model.effects.fluid import RESULTANT_COLUMNS
from rftfem.scene.selectors import cells_of

if TYPE_CHECKING:
    from rftfem.model.shell_model import Model


@dataclass
class BodyPart:
    """One body of the combined mesh: its ``name``, the indicator ``chi`` (1 on its
    cells, a DG0 field) and ``nodes``, the mask of this process's owned nodes of
    the displacement space that are its own."""

    name: str
    chi: fem.Function
    nodes: np.ndarray


def body_parts(model: Model) -> list[BodyPart]:
    """The scene's bodies (none for a scene of one ``[mesh]``), made once per model."""
    made = model.__dict__.get("_body_parts")
    if made is not None:
        return made
    model.__dict__["_body_parts"] = parts = _made(model)
    return parts


def body_part(model: Model, name: str) -> BodyPart:
    """The body called ``name``."""
    return next(p for p in body_parts(model) if p.name == name)


def _made(model: Model) -> list[BodyPart]:
    mesh = model.scene["mesh"]
    if mesh["kind"] != "bodies":
        return []
    Q = compat.function_space(model.mesh, "DG", 0)
    tdim = model.mesh.topology.dim
    owned = model.Vu.dofmap.index_map.size_local
    parts = []
    for body in mesh["bodies"]:
        cells = cells_of(model.body, [body["name"]], f"body {body['name']}")
        chi = fem.Function(Q, name=f"{body['name']}_indicator")
        chi.x.array[:] = 0.0
        chi.x.array[fem.locate_dofs_topological(Q, tdim, cells)] = 1.0
        nodes = np.zeros(owned, dtype=bool)
        dofs = fem.locate_dofs_topological(model.Vu, tdim, cells)
        nodes[dofs[dofs < owned]] = True
        parts.append(BodyPart(body["name"], chi, nodes))
    return parts


def restricted(form: ufl.Form, chi: fem.Function) -> ufl.Form:
    """``form`` over the cells where ``chi`` is 1: each integrand times ``chi`` (its
    ``+`` side on interior facets)."""
    out = []
    for integral in form.integrals():
        weight = chi("+") if integral.integral_type() == "interior_facet" else chi
        out.append(integral.reconstruct(integrand=integral.integrand() * weight))
    return ufl.Form(out)


class PartMeasures:
    """body.csv's block of one body: ``NAME_centroid_*``, ``NAME_velocity_*`` (the
    area-weighted means of the positions and the velocities ``∫ · dA₀ / ∫ dA₀``
    over its cells), ``NAME_elastic_energy``, with inertia ``NAME_kinetic_energy``,
    with a liquid its resultant on the body ``NAME_fluid_*``
    (``FluidModel.resultant_on``) and, with contact planes, their force on it
    ``NAME_contact_F*``."""

    def __init__(self, model: Model, part: BodyPart):
        self.model, self.part = model, part
        m, chi = model, part.chi
        x = ufl.SpatialCoordinate(m.mesh) + m.kinematics().u
        one = fem.Constant(m.mesh, PETSc.ScalarType(1.0))
        self._area = m.assemble_scalar(m.compile(one * chi * m.dx))
        self._position = [m.compile(x[i] * chi * m.dx) for i in range(3)]
        self._velocity = [m.compile(m.v_n[i] * chi * m.dx) for i in range(3)]
        self._energy = m.compile(restricted(m.energy, chi))
        self.fluid = m.fluid if isinstance(m.fluid, FluidModel) else None
        name = part.name
        self.columns = [f"{name}_centroid_{c}" for c in "xyz"]
        self.columns += [f"{name}_velocity_{c}" for c in "xyz"]
        self.columns.append(f"{name}_elastic_energy")
        #: with inertia, its kinetic energy
        self._kinetic = None
        if m.get("inertia") is not None:
            rho, t = m.material["rho"], m.material["t"]
            self._kinetic = m.compile(inertia.kinetic_energy(rho * chi, t, m.v_n, m.dx))
            self.columns.append(f"{name}_kinetic_energy")
        if self.fluid is not None:
            self.columns += [f"{name}_{c}" for c in RESULTANT_COLUMNS]
        #: the contact planes' force on it
        self.contact = m.get("contact")
        if self.contact is not None:
            self.columns += [f"{name}_contact_F{c}" for c in "xyz"]

    def values(self) -> list[float]:
        m = self.model
        row = [m.assemble_scalar(f) / self._area for f in self._position]
        row += [m.assemble_scalar(f) / self._area for f in self._velocity]
        row.append(m.assemble_scalar(self._energy))
        if self._kinetic is not None:
            row.append(m.assemble_scalar(self._kinetic))
        if self.fluid is not None:
            row += list(self.fluid.resultant_on(self.part))
        if self.contact is not None:
            row += self.contact.resultant_on(self.part)
        return row
