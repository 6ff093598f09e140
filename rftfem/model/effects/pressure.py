"""A follower pressure: ``[[load]]`` of kind ``pressure``.

The pressure ``p`` acts along the current normal of the surface on the current
area, so per reference area it is ``p g₁ × g₂ / |G₁ × G₂|`` and its virtual work
is ``∫ p (g₁ × g₂)·δu / |G₁ × G₂| dA₀`` over the region (docs/model.md §5.6).
It turns and stretches with the surface; its load stiffness comes from
``ufl.derivative`` of this term, like every other Jacobian.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from rftfem.errors import SceneError
from rftfem.forms.pressure import follower_pressure_work
from rftfem.model.effects.base import Load
from rftfem.scene.schema import Leaf, Num, Where
from rftfem.scene.selectors import check_where, entities_of, indicator

if TYPE_CHECKING:
    import ufl

    from rftfem.model.shell_model import Model

KIND = "pressure"


class Pressure(Load):
    name = KIND
    load_kinds = {
        KIND: {
            "where": Leaf(
                Where('"all" or a region name'),
                "all",
                doc="The surface it acts on: all of it, or a region.",
            ),
            "value": Leaf(
                Num(),
                required=True,
                unit="force/length²",
                doc="The pressure, multiplied by the ramp's scale; positive pushes "
                "along the current normal (the side the reference normal points "
                "to).",
            ),
        }
    }
    kind_docs = {
        KIND: "A pressure on a surface region, normal to the current surface and "
        "acting on its current area (a follower load)."
    }

    @classmethod
    def check_entry(cls, load: dict, path: str, scene: dict) -> None:
        check_where(load["where"], f"{path}.where", scene)

    def __init__(self, model: Model):
        from dolfinx import fem
        from petsc4py import PETSc

        super().__init__(model)
        tdim = model.mesh.topology.dim
        k = model.kinematics()
        dx = model.dx(metadata={"quadrature_degree": 4})
        self.pressures, terms = [], []
        for i, ld in self.entries:
            dim, cells = entities_of(model.body, ld["where"], f"load.{i}.where")
            if dim != tdim:
                what = "a point" if dim == 0 else "an edge"
                raise SceneError(
                    f"load.{i}.where: '{ld['where']}' is {what}; a pressure "
                    'acts on a surface: "all" or a region'
                )
            # the region as a 0/1 field, so that every load (and the magnetic parts' own
            # measure) can share one form
            region = indicator(model.mesh, cells, f"pressure_{i}_region")
            p = fem.Constant(model.mesh, PETSc.ScalarType(0.0))
            self.pressures.append(p)
            terms.append(follower_pressure_work(p * region, k.g1, k.g2, k.G1, k.G2, k.du, dx))
        self._work = -sum(terms[1:], terms[0])

    def forces(self) -> ufl.Form | None:
        return self._work

    def set_time(self, t: float) -> None:
        for (_, ld), value in zip(self.entries, self.pressures):
            value.value = ld["value"] * self.scale(ld, t)

    def force_scales(self) -> list[float]:
        """The pressure times the body's area."""
        return [abs(ld["value"]) * self.model.area() for _, ld in self.entries]
