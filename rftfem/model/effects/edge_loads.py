"""Dead edge loads (docs/model.md §5.6): ``[[load]]`` of kind ``edge-force`` and
``edge-moment``, a force or a couple per unit reference length of a boundary edge.

The value is the total over the edge, spread evenly over its reference length;
it keeps its direction as the body moves.  The couple acts on the director
(``forms.loads.edge_moment_work``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import ufl

from rftfem.errors import SceneError
from rftfem.forms import loads
from rftfem.model.effects.base import Load, loads_of
from rftfem.scene.schema import Leaf, Vec, Where
from rftfem.scene.selectors import check_where, facets_of

if TYPE_CHECKING:
    from rftfem.model.shell_model import Model

_WHERE = Leaf(
    Where(),
    required=True,
    doc="The boundary edge: x=0, x=L, y=0, y=W or a gmsh physical curve (not a "
    "hinge or another line inside the body).",
)
_VALUE_DOC = (
    "The total over the edge in global axes, spread evenly along the edge's "
    "reference length and multiplied by the ramp's scale. The load keeps its "
    "direction as the body moves (dead load)."
)
KINDS = ("edge-moment", "edge-force")


class EdgeLoads(Load):
    name = "edge-loads"
    load_kinds = {
        "edge-moment": {
            "where": _WHERE,
            "value": Leaf(Vec(), required=True, unit="force·length", doc=_VALUE_DOC),
        },
        "edge-force": {
            "where": _WHERE,
            "value": Leaf(Vec(), required=True, unit="force", doc=_VALUE_DOC),
        },
    }
    kind_docs = {
        "edge-moment": "A couple on the edge's directors (its part about the director does "
        "nothing).",
        "edge-force": "A force on the edge.",
    }

    @classmethod
    def names(cls, scene: dict) -> list[str]:
        kinds = {ld["kind"] for _, ld in loads_of(scene, KINDS)}
        return [k for k in ("edge-force", "edge-moment") if k in kinds]

    @classmethod
    def check_entry(cls, load: dict, path: str, scene: dict) -> None:
        check_where(load["where"], f"{path}.where", scene)

    def __init__(self, model: Model):
        """Edge forces and moments, per unit reference length of their edge."""
        from dolfinx import fem
        from dolfinx import mesh as dmesh
        from petsc4py import PETSc

        from rftfem import compat

        super().__init__(model)
        mesh, comm = model.mesh, model.comm
        first = {}  # where -> the index of its first load, for messages
        for i, ld in self.entries:
            first.setdefault(ld["where"], i)
        wheres = sorted(first)
        facet_sets = {w: facets_of(model.body, w, f"load.{first[w]}.where") for w in wheres}
        boundary = dmesh.exterior_facet_indices(mesh.topology)
        for w, facets in facet_sets.items():
            if comm.allreduce(int((~np.isin(facets, boundary)).sum())):
                raise SceneError(
                    f"load.{first[w]}.where: '{w}' runs inside the body (a hinge "
                    "or an interior curve); edge loads act on the body's boundary "
                    "edges"
                )
        all_facets = np.concatenate(list(facet_sets.values()))
        if comm.allreduce(int(len(np.unique(all_facets)) != len(all_facets))):
            raise SceneError("load: edge loads on overlapping edges must use the same 'where'")
        tags = np.concatenate([np.full(len(facet_sets[w]), i + 1) for i, w in enumerate(wheres)])
        ft = compat.create_meshtags(mesh, mesh.topology.dim - 1, all_facets, tags)
        ds = ufl.Measure("ds", domain=mesh, subdomain_data=ft, metadata={"quadrature_degree": 4})
        k = model.kinematics()
        dd = ufl.derivative(k.d, model.z, k.w_test)
        one = fem.Constant(mesh, PETSc.ScalarType(1.0))
        #: (scene entry, its Constant, its edge's reference length); the value per unit
        #: length is read from the entry at each set_time, as the other loads do (so
        #: that sensitivity.py finds the Constant's derivative by a load value)
        self.per_length, terms = [], []
        for _, ld in self.entries:
            tag = wheres.index(ld["where"]) + 1
            length = model.assemble_scalar(model.compile(one * ds(tag)))
            value = fem.Constant(mesh, np.zeros(3, dtype=PETSc.ScalarType))
            self.per_length.append((ld, value, length))
            if ld["kind"] == "edge-force":
                terms.append(loads.edge_force_work(value, k.du, ds(tag)))
            else:
                terms.append(loads.edge_moment_work(value, k.d, dd, ds(tag)))
        self._work = -sum(terms[1:], terms[0])

    def forces(self) -> ufl.Form | None:
        return self._work

    def set_time(self, t: float) -> None:
        for ld, value, length in self.per_length:
            value.value[:] = np.asarray(ld["value"], dtype=float) / length * self.scale(ld, t)

    def force_scales(self) -> list[float]:
        """Each total edge force, and each edge moment over the length."""
        L = self.model.body.length
        return [
            float(np.linalg.norm(ld["value"])) / (1.0 if ld["kind"] == "edge-force" else L)
            for ld, _, _ in self.per_length
        ]
