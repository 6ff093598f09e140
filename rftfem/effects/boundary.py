"""Fixed degrees of freedom, the scene's ``[[boundary]]``: displacement components
and the director's rotation held at zero for the whole run (docs/model.md §5.7).

On a hinged body "rotation" holds each side's own rotation on the selected
entities of its panels: a clamped link leaves the director across its hinge free.
"""

from __future__ import annotations

from rftfem.errors import SceneError
from rftfem.schema import Array, Fix, Leaf, Table, Where
from rftfem.selectors import check_where, entities_of

from .base import Effect

#: the displacement components a scene names, and their index
DISPLACEMENT_COMPONENTS = {"ux": 0, "uy": 1, "uz": 2}


class Boundaries(Effect):
    keys = {
    "boundary": Array(Table({
        "where": Leaf(Where(), required=True,
                       doc="Where: all, an edge (x=0, x=L, y=0, y=W, a gmsh physical "
                           "curve), a hinge line or a region."),
        "fix": Leaf(Fix(), required=True,
                     doc="What is held at zero: the displacement components ux, uy, uz "
                         '(global axes) and "rotation" (the director keeps its reference '
                         'direction); "clamped" is all four.'),
    }), doc="Degrees of freedom held at zero for the whole run."),
    }

    @classmethod
    def active(cls, scene):
        return bool(scene.get("boundary"))

    @classmethod
    def check(cls, scene):
        for i, item in enumerate(scene["boundary"]):
            check_where(item["where"], f"boundary.{i}.where", scene)

    def __init__(self, model):
        from rftfem import hinges

        super().__init__(model)
        self._bcs = []
        for k, bnd in enumerate(self.scene["boundary"]):
            key = f"boundary.{k}.where"
            dim, entities = entities_of(model.body, bnd["where"], key)
            fix = set(bnd["fix"])
            if "clamped" in fix:
                fix = {"ux", "uy", "uz", "rotation"}
            # (component, sub-space, its name, entities)
            subs = [(c, model.W.sub(0).sub(DISPLACEMENT_COMPONENTS[c]), c, entities)
                    for c in sorted(fix) if c in DISPLACEMENT_COMPONENTS]
            if "rotation" in fix:
                for c in range(model.n_colours):
                    own = hinges.entities_of_colour(model, dim, entities, c)
                    subs += [(f"theta{i + 1}", model.W.sub(1 + c).sub(i), f"theta{i + 1}_{c}",
                              own) for i in range(2)]
            counts = {}
            for component, sub, name, ents in subs:
                bc, n = model.dirichlet.zero(sub, dim, ents, name, "a [[boundary]]")
                counts[component] = counts.get(component, 0) + n
                self._bcs.append(bc)
            for n in counts.values():
                if model.comm.allreduce(n) == 0:
                    raise SceneError(f"{key}: '{bnd['where']}' matches no degree of freedom")

    def bcs(self):
        return self._bcs
