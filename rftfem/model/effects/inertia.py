"""Translational inertia (docs/model.md §5.3): ``∫ ρ t a·δu dA₀``.

Active when some part of the shell has density and the time scheme is second
order (generalized-alpha or HHT); it adds the kinetic energy to body.csv.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from rftfem.forms import inertia
from rftfem.model.effects.base import Effect
from rftfem.scene.time_rules import has_density, resolved_scheme

if TYPE_CHECKING:
    import ufl

    from rftfem.model.shell_model import Model


class Inertia(Effect):
    name = "inertia"
    columns = ["kinetic_energy"]

    @classmethod
    def active(cls, scene: dict) -> bool:
        return has_density(scene) and resolved_scheme(scene) in ("generalized-alpha", "hht")

    def __init__(self, model: Model):
        super().__init__(model)
        mat = model.material
        self._work = inertia.inertia_work(
            mat["rho"],
            mat["t"],
            model.acceleration(model.kinematics().u),
            model.kinematics().du,
            model.dx(metadata={"quadrature_degree": 4}),
        )
        self._kinetic_form = None

    def inertia(self) -> ufl.Form | None:
        return self._work

    def kinetic_energy(self) -> float:
        """``½ ∫ ρ t v·v dA₀`` of the stored velocity ``v_n``."""
        m = self.model
        if self._kinetic_form is None:
            self._kinetic_form = m.compile(
                inertia.kinetic_energy(m.material["rho"], m.material["t"], m.v_n, m.dx)
            )
        return m.assemble_scalar(self._kinetic_form)

    def values(self, t: float) -> list[float]:
        return [self.kinetic_energy()]
