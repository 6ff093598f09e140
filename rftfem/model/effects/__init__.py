"""The effects a scene can switch on, one component per module (see base.py).

:data:`REGISTRY` is the one list of them.  Its order is the order of
``rftfem check``'s active effects, of the body.csv columns and of the terms'
sum; Dirichlet components come after the effects, ``[[boundary]]`` before
``[[motion]]`` (a motion may not take a dof a boundary holds).  The scene's
schema takes each component's ``keys`` and ``load_kinds`` from here.

Reading a scene imports this package, so the components import dolfinx inside
the methods that build on a mesh, never at the top.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from rftfem.model.effects.base import LOAD_KIND_DOC, RAMP, TABLE, Effect
from rftfem.model.effects.bodies import BodiesApart
from rftfem.model.effects.boundary import Boundaries, check_reaction_names
from rftfem.model.effects.contact import Contact
from rftfem.model.effects.drag import Drag
from rftfem.model.effects.edge_loads import EdgeLoads
from rftfem.model.effects.elasticity import Elasticity
from rftfem.model.effects.gravity import Gravity
from rftfem.model.effects.hinge import Hinges
from rftfem.model.effects.inertia import Inertia
from rftfem.model.effects.magnetic import Magnetic
from rftfem.model.effects.magnetic_interactions import MagneticInteractions
from rftfem.model.effects.motion import Motions
from rftfem.model.effects.point_force import PointForce
from rftfem.model.effects.pressure import Pressure
from rftfem.model.effects.stokes import Stokes

if TYPE_CHECKING:
    from rftfem.scene.schema import Kinds

REGISTRY: tuple[type[Effect], ...] = (
    Elasticity,
    Hinges,
    Inertia,
    Drag,
    Stokes,
    Magnetic,
    MagneticInteractions,
    EdgeLoads,
    PointForce,
    Pressure,
    Gravity,
    Contact,
    BodiesApart,
    Boundaries,
    Motions,
)


def scene_keys() -> dict:
    """Every top-level scene key an effect owns, ``{key: schema node}``, in registry order."""
    return {key: node for effect in REGISTRY for key, node in effect.keys.items()}


def load_schema() -> Kinds:
    """The ``[[load]]`` array: the common keys and each load component's kinds."""
    from rftfem.scene.bodies import BODY_KEY
    from rftfem.scene.schema import Kinds, Leaf, Str

    kinds = {kind: fields for effect in REGISTRY for kind, fields in effect.load_kinds.items()}
    docs = {kind: text for effect in REGISTRY for kind, text in effect.kind_docs.items()}
    common = {
        "kind": Leaf(Str(tuple(kinds)), required=True, doc=LOAD_KIND_DOC),
        "ramp": RAMP,
        "table": TABLE,
        "body": BODY_KEY,
    }
    return Kinds(
        common,
        kinds,
        docs,
        doc="Loads given in the scene, each with a ramp in "
        "time; the kind decides where and how it acts.",
    )


def active_effects(scene: dict) -> list[str]:
    """The names of the effects the scene asks for, in registry order."""
    return [name for effect in REGISTRY for name in effect.names(scene)]


def check(scene: dict) -> None:
    """Each component's checks of its keys against the rest of the scene."""
    for effect in REGISTRY:
        effect.check(scene)
    check_reaction_names(scene)
