"""Elasticity of the shell (docs/model.md §3, §5.2): the stored energy Π of its
membrane, bending and transverse-shear strains.  Always active; the material
values come from ``[shell]`` and ``[[shell.parts]]`` (cellwise fields of the Model).
"""

from __future__ import annotations

import ufl

from rftfem.forms import elasticity, kinematics

from .base import Effect


class Elasticity(Effect):
    name = "elasticity"

    @classmethod
    def active(cls, scene):
        return True

    def __init__(self, model):
        super().__init__(model)
        k, mat = model.kinematics(), model.material
        D = kinematics.unit(model.D)
        strains = (kinematics.membrane_strain(k.g1, k.g2, k.G1, k.G2),
                   kinematics.bending_strain(k.g1, k.g2, k.d, k.G1, k.G2, D),
                   kinematics.shear_strain(k.g1, k.g2, k.d, k.G1, k.G2, D))
        self._energy = elasticity.stored_energy(strains, k.G1, k.G2, mat["E"], mat["nu"],
                                                mat["t"], model.dx, ufl.CellDiameter(model.mesh))

    def energy(self):
        return self._energy

    def force_scales(self):
        """The bending force ``D W / L²`` that bends the body by order one."""
        shell, body = self.scene["shell"], self.model.body
        E = max([shell["E"]] + [p["E"] for p in shell.get("parts", []) if "E" in p])
        D = E * shell["thickness"] ** 3 / (12 * (1 - shell["nu"] ** 2))
        return [D * max(body.width, 1e-300) / body.length**2]
