"""A dead force at a material point: ``[[load]]`` of kind ``point-force``.

Its virtual work is ``f·δu(X_p)``: the force times the displacement shape
functions at the point, a nodal force vector found once (the shape functions
are evaluated where the point lies in its cell) and added to the assembled
forces at the ramp's scale.  A dead load adds nothing to the Jacobian.  On a
shell, a force at a point is a singular load: the deflection under it grows
with mesh refinement (logarithmically, from the transverse shear), while
deflections away from it converge (docs/model.md §5.6).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from rftfem.errors import SceneError
from rftfem.model.effects.base import Load
from rftfem.scene.schema import Leaf, Vec, fmt
from rftfem.scene.selectors import check_on_body, owned_cells

if TYPE_CHECKING:
    from rftfem.model.shell_model import Model

KIND = "point-force"


class PointForce(Load):
    name = KIND
    load_kinds = {
        KIND: {
            "at": Leaf(
                Vec(),
                required=True,
                unit="length",
                doc="The material point, in reference coordinates (like a probe); on a "
                "strip or three-link body it must lie on the body (z = 0); on a gmsh "
                "body within 5 % of a cell's size of its surface (the nearest point "
                "is taken).",
            ),
            "value": Leaf(
                Vec(),
                required=True,
                unit="force",
                doc="The force in global axes, multiplied by the ramp's scale; it keeps "
                "its direction as the body moves (dead load).",
            ),
        }
    }
    kind_docs = {
        KIND: "A force at a material point (the pinched cylinder and hemisphere "
        "benchmarks); the displacement right under it depends on the mesh."
    }

    @classmethod
    def check_entry(cls, load: dict, path: str, scene: dict) -> None:
        check_on_body(load["at"], f"{path}.at", "point", scene)

    def __init__(self, model: Model):
        from dolfinx import fem

        from rftfem import compat

        super().__init__(model)
        points = np.array([ld["at"] for _, ld in self.entries], dtype=float)
        cells, on_body = owned_cells(model.mesh, points)
        node_dofs = compat.cell_dofs(model.Vu)
        probe = fem.Function(model.Vu)
        #: per load: the W dofs of its cell's nodes for ux, uy, uz (nodes, 3) and the
        #: shape function values there; empty on processes that do not own the point
        self.weights = []
        for (i, ld), cell, inside, X in zip(self.entries, cells, on_body, points):
            if not inside:
                raise SceneError(f"load.{i}.at: point {fmt(ld['at'])} is outside the body")
            dofs, phi = np.empty((0, 3), dtype=np.int64), np.empty(0)
            if cell is not None:
                nodes = node_dofs[cell]
                phi = np.empty(len(nodes))
                for k, node in enumerate(nodes):  # φ_k(X): the field that is 1 at node k
                    probe.x.array[:] = 0.0
                    probe.x.array[3 * node] = 1.0
                    phi[k] = probe.eval(X, np.array([cell], dtype=np.int32))[0]
                dofs = model.u_dofs[3 * nodes[:, None] + np.arange(3)[None, :]]
            self.weights.append((dofs, phi))
        self.t = 0.0

    def set_time(self, t: float) -> None:
        self.t = t

    def add_nodal_forces(self, F: np.ndarray) -> None:
        for (_, ld), (dofs, phi) in zip(self.entries, self.weights):
            force = self.scale(ld, self.t) * np.asarray(ld["value"], dtype=float)
            np.add.at(F, dofs, -phi[:, None] * force[None, :])

    def force_scales(self) -> list[float]:
        return [float(np.linalg.norm(ld["value"])) for _, ld in self.entries]
