"""Conditions on the edges of the body, the scene's ``[[boundary]]`` (docs/model.md §5.7).

``fix`` holds displacement components and the director's rotation at zero for
the whole run. On a hinged body "rotation" holds each side's own rotation on
the selected entities of its panels: a clamped link leaves the director across
its hinge free.

``symmetry = n`` makes an edge lying in a coordinate plane (normal ``n``) a plane
of symmetry: ``u·n = 0``, and the director stays in the plane, ``d·n = 0``. The
rotations that keep it there are those about ``n``, so at each node the
increment θ must have no part along ``t = dₙ × n``. Where the nodal triad has
``a₁`` or ``a₂`` along ``t`` (a material axis along or across the plane, as on a
strip, a cylinder or a sphere cut by coordinate planes) that is ``θ¹ = 0`` or
``θ² = 0``, a Dirichlet condition; a symmetric deformation keeps the triad so.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from rftfem.errors import SceneError
from rftfem.model.effects.base import Effect
from rftfem.scene.bodies import BODY_KEY
from rftfem.scene.schema import Array, Fix, Leaf, Str, Table, Vec, Where, fmt
from rftfem.scene.selectors import check_where, entities_of

if TYPE_CHECKING:
    import dolfinx.fem

    from rftfem.model.shell_model import Model

#: the displacement components a scene names, and their index
DISPLACEMENT_COMPONENTS = {"ux": 0, "uy": 1, "uz": 2}
_EITHER = "none: give fix or symmetry"
#: how far from square (1 - cos) a plane of symmetry may cut the body, or a₁ / a₂ lie
#: from t: 5.7°. A curved mesh's nodal normals miss the plane by the geometry's
#: interpolation error, from O(h²) of an angle: on a quarter hemisphere 3.3° with one
#: 9-node cell across, 1° with 2, 0.2° with 4; a material axis at 45° is 0.29 off.
SQUARE = 5e-3


#: the ``name`` of a ``[[boundary]]`` or ``[[motion]]`` entry (reactions.py)
NAME = Leaf(
    Str(name=True),
    None,
    default_doc="none: no reaction written",
    doc="With a name, the force and moment the entry carries go to body.csv as "
    "NAME_Fx, NAME_Fy, NAME_Fz, NAME_Mx, NAME_My, NAME_Mz (the moment about "
    "the origin; the sign of a load on the body). Names are unique across "
    "[[boundary]] and [[motion]].",
)


class Boundaries(Effect):
    keys = {
        "boundary": Array(
            Table(
                {
                    "where": Leaf(
                        Where(),
                        required=True,
                        doc="Where: all, an edge (x=0, x=L, y=0, y=W, a gmsh physical "
                        "curve), a hinge line, a region or a gmsh physical point (to "
                        "hold a rigid motion); an edge for symmetry.",
                    ),
                    "body": BODY_KEY,
                    "name": NAME,
                    "fix": Leaf(
                        Fix(),
                        None,
                        default_doc=_EITHER,
                        doc="What is held at zero: the displacement components ux, uy, uz "
                        '(global axes) and "rotation" (the director keeps its reference '
                        'direction); "clamped" is all four.',
                    ),
                    "symmetry": Leaf(
                        Vec(nonzero=True),
                        None,
                        default_doc=_EITHER,
                        doc="The normal n of the coordinate plane the edge lies in "
                        "([1, 0, 0], [0, 1, 0] or [0, 0, 1], either sign): u·n = 0 "
                        "and the director stays in the plane, so the body modelled "
                        "is one half of a body symmetric about it. The material "
                        "axis (shell.axis) must lie along or across the plane at "
                        "the edge.",
                    ),
                }
            ),
            doc="Conditions on the body's edges for the whole run: degrees of freedom held "
            "at zero, or a plane of symmetry.",
        ),
    }

    @classmethod
    def active(cls, scene: dict) -> bool:
        return bool(scene.get("boundary"))

    @classmethod
    def check(cls, scene: dict) -> None:
        for i, item in enumerate(scene["boundary"]):
            check_where(item["where"], f"boundary.{i}.where", scene)
            if item["fix"] is None and item["symmetry"] is None:
                raise SceneError(
                    f"missing required key 'boundary.{i}.fix' (expected "
                    f"{Fix.expected}, or symmetry = [nx, ny, nz])"
                )
            if item["fix"] is not None and item["symmetry"] is not None:
                raise SceneError(
                    f"boundary.{i}: expected fix or symmetry, found both; give "
                    "each its own [[boundary]]"
                )
            n = item["symmetry"]
            if n is not None and sorted(abs(x) > 0 for x in n) != [False, False, True]:
                raise SceneError(
                    f"boundary.{i}.symmetry: expected the normal of a coordinate "
                    "plane ([1, 0, 0], [0, 1, 0] or [0, 0, 1], either sign), "
                    f"found {fmt(n)}"
                )

    def __init__(self, model: Model):
        super().__init__(model)
        self._bcs = []
        #: per entry, the local dofs of ``w`` it holds
        self._held = [[] for _ in self.scene["boundary"]]
        for k, bnd in enumerate(self.scene["boundary"]):
            if bnd["symmetry"] is not None:
                self._symmetry(k, bnd)
            else:
                self._fix(k, bnd)

    def _fix(self, k, bnd):
        from rftfem.model import hinges

        model = self.model
        key = f"boundary.{k}.where"
        dim, entities = entities_of(model.body, bnd["where"], key)
        fix = set(bnd["fix"])
        if "clamped" in fix:
            fix = {"ux", "uy", "uz", "rotation"}
        # (component, sub-space, its name, entities)
        subs = [
            (c, model.displacement_space(DISPLACEMENT_COMPONENTS[c]), c, entities)
            for c in sorted(fix)
            if c in DISPLACEMENT_COMPONENTS
        ]
        if "rotation" in fix:
            for c in range(model.n_colours):
                own = hinges.entities_of_colour(model, dim, entities, c)
                subs += [
                    (f"theta{i + 1}", model.rotation_space(c, i), f"theta{i + 1}_{c}", own)
                    for i in range(2)
                ]
        counts = {}
        for component, sub, name, ents in subs:
            bc, dofs = model.dirichlet.zero(sub, dim, ents, name, "a [[boundary]]")
            counts[component] = counts.get(component, 0) + len(dofs)
            self._held[k].append(dofs)
            self._bcs.append(bc)
        for n in counts.values():
            if model.comm.allreduce(n) == 0:
                raise SceneError(f"{key}: '{bnd['where']}' matches no degree of freedom")

    def _symmetry(self, k, bnd):
        """``u·n = 0``, and θ¹ = 0 or θ² = 0 node by node, whichever of a₁, a₂ lies
        along ``t = dₙ × n`` (one colour's triads at a time)."""
        from dolfinx import fem

        from rftfem.model import hinges

        model = self.model
        key = f"boundary.{k}"
        dim, entities = entities_of(model.body, bnd["where"], f"{key}.where")
        if dim != model.mesh.topology.dim - 1:
            what = "a point" if dim == 0 else "a surface region"
            raise SceneError(
                f"{key}.where: '{bnd['where']}' is {what}; a plane of symmetry is an edge"
            )
        axis = int(np.argmax(np.abs(bnd["symmetry"])))
        n = np.eye(3)[axis]
        bc, dofs = model.dirichlet.zero(
            model.displacement_space(axis),
            dim,
            entities,
            ("ux", "uy", "uz")[axis],
            "a [[boundary]]",
        )
        self._held[k].append(dofs)
        if model.comm.allreduce(len(dofs)) == 0:
            raise SceneError(f"{key}.where: '{bnd['where']}' matches no degree of freedom")
        self._bcs.append(bc)
        bad = 0
        for c, (a1, a2, dn) in enumerate(model.triads):
            own = hinges.entities_of_colour(model, dim, entities, c)
            frames = [f.x.array.reshape(-1, 3) for f in (a1, a2, dn)]
            # a θ dof of ``w`` -> its node of the u space: θ is stored in
            # (θ¹, θ²) pairs per node (Model.theta_dofs_of), the triad maps the nodes
            pair = np.full(len(model.w.x.array), -1, dtype=np.int64)
            pair[model.theta_dofs_of[c]] = np.arange(len(model.theta_dofs_of[c]))
            for i in range(2):
                sub = model.rotation_space(c, i)
                V, zero = model.dirichlet.space(sub, f"theta{i + 1}_{c}")
                dofs = fem.locate_dofs_topological((sub, V), dim, own)
                at = model.triad.node_maps[c][pair[np.asarray(dofs[0])] // 2]
                t = np.cross(frames[2][at], n)
                size = np.linalg.norm(t, axis=1)
                along = np.abs(np.sum(frames[i][at] * t, axis=1))
                keep = along > (1 - SQUARE) * size
                other = np.abs(np.sum(frames[1 - i][at] * t, axis=1)) > (1 - SQUARE) * size
                if i == 0:  # a node counted once, from its θ¹ dof
                    bad += int(np.sum(~keep & ~other | (size < 1e-6)))
                picked = [np.asarray(dofs[0])[keep], np.asarray(dofs[1])[keep]]
                model.dirichlet.hold(f"theta{i + 1}_{c}", "a [[boundary]]", picked[0])
                self._held[k].append(picked[0])
                self._bcs.append(fem.dirichletbc(zero, picked, sub))
        if model.comm.allreduce(bad):
            raise SceneError(
                f"{key}.symmetry: at {model.comm.allreduce(bad)} nodes of "
                f"'{bnd['where']}' the body does not cross the plane at right "
                "angles, or the material axis (shell.axis) lies neither along "
                "nor across it; the director could not be held in the plane"
            )

    def bcs(self) -> list[dolfinx.fem.DirichletBC]:
        return self._bcs

    def reaction_dofs(self) -> list[tuple[str, np.ndarray]]:
        return [
            (bnd["name"], np.concatenate(held) if held else np.empty(0, dtype=np.int64))
            for bnd, held in zip(self.scene["boundary"], self._held)
            if bnd["name"] is not None
        ]


def check_reaction_names(scene: dict) -> None:
    """``name`` unique across ``[[boundary]]`` and ``[[motion]]`` (their body.csv columns)."""
    seen = {}
    for table in ("boundary", "motion"):
        for i, item in enumerate(scene.get(table) or []):
            name = item.get("name")
            if name is None:
                continue
            if name in seen:
                raise SceneError(
                    f"{table}.{i}.name: expected a unique reaction name, found "
                    f"'{name}' a second time (also {seen[name]}.name)"
                )
            seen[name] = f"{table}.{i}"
