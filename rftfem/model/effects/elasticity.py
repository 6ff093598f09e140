"""Elasticity of the shell (docs/model.md §3, §5.2): the stored energy Π of its
membrane, bending and transverse-shear strains.  Always active; the material
values come from ``[shell]`` and ``[[shell.parts]]`` (cellwise fields of the Model).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import ufl

from rftfem.forms import elasticity, kinematics
from rftfem.model.effects.base import Effect

if TYPE_CHECKING:
    from types import SimpleNamespace

    import dolfinx.mesh

    from rftfem.model.shell_model import Model


def cell_diameter(mesh: dolfinx.mesh.Mesh) -> ufl.core.expr.Expr:
    """h of the shear and membrane weight t²/h² (forms.elasticity): UFL's
    ``CellDiameter``, the largest distance between a cell's vertices, where UFL can
    compute it (straight cells); on curved cells (a second-order gmsh file) the same
    distance from the vertex nodes, as a cellwise field."""
    from dolfinx import fem

    from rftfem import compat

    cells, degree = compat.geometry_cells(mesh)
    if degree == 1:
        return ufl.CellDiameter(mesh)
    corners = 3 if mesh.topology.cell_type.name == "triangle" else 4
    x = mesh.geometry.x[cells[:, :corners]]  # vertices come first in each cell's nodes
    pairs = [(i, j) for i in range(corners) for j in range(i + 1, corners)]
    h = np.max([np.linalg.norm(x[:, i] - x[:, j], axis=1) for i, j in pairs], axis=0)
    V0 = compat.function_space(mesh, "DG", 0)
    field = fem.Function(V0, name="cell_diameter")
    field.x.array[compat.cell_dofs(V0)[: len(h), 0]] = h
    field.x.scatter_forward()
    return field


def material_law(
    mat: dict, G1: ufl.core.expr.Expr, G2: ufl.core.expr.Expr
) -> elasticity.Isotropic | elasticity.Orthotropic:
    """The plane-stress law of the Model's material fields (forms.elasticity)."""
    if "fibre" in mat:
        return elasticity.Orthotropic(
            *(mat[k] for k in ("E1", "E2", "G12", "nu12", "G13", "G23", "fibre")), G1, G2
        )
    return elasticity.Isotropic(mat["E"], mat["nu"])


class Elasticity(Effect):
    name = "elasticity"

    @classmethod
    def active(cls, scene: dict) -> bool:
        return True

    def __init__(self, model: Model):
        super().__init__(model)
        mat = model.material
        self.h = cell_diameter(model.mesh)
        k = model.kinematics()
        self.law = material_law(mat, k.G1, k.G2)
        self._energy = elasticity.stored_energy(
            self.strains(k), k.G1, k.G2, self.law, mat["t"], model.dx, self.h
        )

    def strains(
        self, k: SimpleNamespace
    ) -> tuple[ufl.core.expr.Expr, ufl.core.expr.Expr, ufl.core.expr.Expr]:
        """``(ε, κ, γ)`` of the kinematics ``k`` (Model.kinematics_of)."""
        D = kinematics.unit(self.model.D)
        return (
            kinematics.membrane_strain(k.g1, k.g2, k.G1, k.G2),
            kinematics.bending_strain(k.g1, k.g2, k.d, k.G1, k.G2, D),
            kinematics.shear_strain(k.g1, k.g2, k.d, k.G1, k.G2, D),
        )

    def energy(self) -> ufl.Form | None:
        return self._energy

    def tangent_correction(self) -> ufl.Form | None:
        """The mixed-integration-point term of the Newton tangent (docs/model.md §7.4):
        the membrane and shear strains' linearization defects between the previous
        Newton iterate and the current one (the Model's ``newton_*`` functions)."""
        m, mat = self.model, self.model.material
        previous = self.strains(m.kinematics_of(m.newton_previous))
        current = self.strains(m.kinematics_of(m.newton_current))
        # bending is left exact: its linearized moments made Newton slower (the strip
        # at 50 steps per period: 7.9 iterations a step against 4.9 without)
        defects = [
            current[i]
            - previous[i]
            - ufl.derivative(previous[i], m.newton_previous, m.newton_update)
            for i in (0, 2)
        ]
        k = m.kinematics()
        return elasticity.mixed_point_tangent(
            self.strains(k), defects, k.G1, k.G2, self.law, mat["t"], m.dx, self.h
        )

    def force_scales(self) -> list[float]:
        """The bending force ``D W / L²`` that bends the body by order one (the largest
        modulus, the mean thickness and ν)."""
        m, body = self.model, self.model.body
        t, nu = m.material_value("thickness", "shell"), m.material_value("nu", "shell")
        D = m.material_value("E") * t**3 / (12 * (1 - nu**2))
        return [D * max(body.width, 1e-300) / body.length**2]

    def membrane_force(self) -> float:
        """The membrane force ``E t W`` that stretches the body by order one (the
        largest modulus and thickness of its parts): its residual's round-off scale."""
        width = self.model.body.width
        m = self.model
        return m.material_value("E") * m.material_value("thickness") * max(width, 1e-300)
