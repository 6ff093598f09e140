"""What every effect component has: :class:`Effect`, and the keys all loads share.

An effect is one term of the virtual-work balance (docs/model.md §5), or one
kind of condition on the unknowns, together with everything a scene, a run and
its outputs need to know about it.  Its class says what it owns in a scene and
when the scene asks for it; an instance, built by the :class:`~rftfem.model.shell_model.Model`
only for a scene that asks for it, holds its coefficients and gives its UFL
terms, Dirichlet conditions and diagnostics.  Every method has a default that
does nothing, so a component writes only what its effect has.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from rftfem.scene.schema import Leaf, Pairs, Str, table_iff

if TYPE_CHECKING:  # (annotations only: the effects import no dolfinx at the top)
    import dolfinx.fem
    import ufl

    from rftfem.model.body_parts import BodyPart
    from rftfem.model.shell_model import Model


class Effect:
    """One effect: its scene keys and checks, its terms, its outputs."""

    #: the name ``rftfem check`` and summary.json list when the effect is active
    name = ""
    #: top-level scene keys the effect owns, ``{key: schema node}``
    keys: dict = {}
    #: the ``[[load]]`` kinds it handles: ``{kind: {key: Leaf}}``, and a sentence each
    load_kinds: dict = {}
    kind_docs: dict = {}

    # --- the scene (no mesh) -------------------------------------------------

    @classmethod
    def active(cls, scene: dict) -> bool:
        """Whether the scene asks for this effect (then the Model builds it)."""
        return False

    @classmethod
    def names(cls, scene: dict) -> list[str]:
        """The active effect names it reports, in order."""
        return [cls.name] if cls.name and cls.active(scene) else []

    @classmethod
    def check(cls, scene: dict) -> None:
        """Checks of its keys against the rest of the scene (after the schema)."""

    # --- the model ------------------------------------------------------------

    def __init__(self, model: Model):
        self.model = model
        self.scene = model.scene

    def energy(self) -> ufl.Form | None:
        """A stored energy (UFL scalar form) whose derivative is a force, or None."""

    def forces(self) -> ufl.Form | None:
        """Virtual work of its other non-inertial forces, internal minus external, or None."""

    def tangent_correction(self) -> ufl.Form | None:
        """A 0-form whose second derivative is added to the Newton tangent, not to the
        residual (the converged state is the same), or None."""

    def end_forces(self) -> ufl.Form | None:
        """Virtual work of forces taken in full at the step's end, not averaged with the
        last step's by ``α_f`` (contact: an averaged barrier force gains energy in an
        impact a step resolves badly), or None.  Not part of ``F`` or ``F_n``."""

    def inertia(self) -> ufl.Form | None:
        """Virtual work of inertial forces (not weighted by the scheme's 1 − α_f), or None."""

    def add_nodal_forces(self, F: np.ndarray) -> None:
        """Add forces given at nodes, not as a UFL form, to the local array of ``F``
        (internal minus external, like :meth:`forces`): a point force is the one case.
        Dead, so they add nothing to the Jacobian."""

    def bcs(self) -> list[dolfinx.fem.DirichletBC]:
        """Dirichlet conditions it imposes."""
        return []

    def reaction_dofs(self) -> list[tuple[str, np.ndarray]]:
        """``(name, local mixed-space dofs)`` of its named entries, whose reactions
        body.csv carries (reactions.py)."""
        return []

    #: whether its Dirichlet values change in time
    moving = False
    #: whether it is an applied load: switched off by ``Model.loads_on = False`` (the
    #: start of a run in time, docs/model.md §6.7), on by default
    is_load = False

    def loads_at_start(self) -> list[str]:
        """The key paths of its loads that are already on at t = 0 (a static run that
        fails says to ramp them)."""
        return []

    def set_time(self, t: float) -> None:
        """Set its time-dependent values to time ``t``."""

    def force_scales(self) -> list[float]:
        """Force scales it adds to the Newton tolerances (docs/model.md §7.3)."""
        return []

    def warnings(self) -> list[str]:
        """What a run warns of at its start and ``rftfem check`` lists (a wall too
        close, a body too large for its operator), one sentence each."""
        return []

    def holds_at_rest(self) -> bool:
        """Whether it may hold the body at rest at the current state (friction on a
        plane): the start of a run then finds the acceleration of a first step from
        rest with it (integration/impulses.py), not the frictionless one."""
        return False

    def after_step(self, t: float) -> list[str]:
        """A look at the converged state of an accepted step (time ``t``): raise
        :class:`~rftfem.errors.RunFailed` for a state it refuses (the run fails
        there, its rows kept), or return warnings for one it doubts."""
        return []

    # --- outputs ----------------------------------------------------------------

    #: its body.csv columns
    columns: list[str] = []

    def values(self, t: float) -> list[float]:
        """Its body.csv values at time ``t`` (global, on every rank)."""
        return []

    def fields(self) -> dict[str, dolfinx.fem.Function | ufl.core.expr.Expr]:
        """Extra fields.xdmf fields: ``{name: Function or UFL vector expression}``."""
        return {}


# ----------------------------------------------------------------- capabilities
# What some effects add to the local UFL effect above; the solver and the time loop
# ask for these classes (isinstance), never for an effect by name.


class FluidModel(Effect):
    """The liquid the body moves in (``[fluid]``; at most one per scene, the model's
    ``fluid``): its drag or flow is one of its terms, and it describes itself."""

    def describe(self) -> dict:
        """Its discretisation and where its values come from (summary.json's ``fluid``)."""
        raise NotImplementedError

    def check_lines(self) -> list[str]:
        """``rftfem check``'s lines about it."""
        return []

    def opening_lines(self) -> list[str]:
        """The lines a run prints about it when it starts."""
        return []

    def resultant_on(self, part: BodyPart) -> np.ndarray:
        """The liquid's force and moment about the origin on one body of several
        (``rftfem.model.body_parts``), as its whole-body columns give them."""
        raise NotImplementedError


class NonlocalEffect(Effect):
    """An effect that couples every node to every other (the Stokes flow).

    Its forces are nodal, added by :meth:`add_nodal_forces`, and its tangent ``T`` is
    a dense operator the Newton solver never assembles but applies by products
    (integration/coupled.py): the Krylov solver's operator is ``A + Σ (T − D)``,
    preconditioned by ``A + Σ D`` with ``D`` the effect's lumped nodal blocks, where
    ``A`` is the assembled tangent of every UFL term."""

    #: the components of each node's block of unknowns it acts on (0, 1, 2: the
    #: displacement; the director's two rotations follow them)
    unknowns: tuple[int, ...] = (0, 1, 2)

    def prepare_tangent(self, scale: float, exact: bool = False) -> np.ndarray:
        """Make the tangent of ``scale`` times its forces at the current iterate (with
        ``exact`` False an earlier one may stand for it, as in a Newton update; True
        where the exact one is needed), and return its lumped blocks for the owned
        nodes, (n_owned, k, k) with k = ``len(unknowns)``."""
        raise NotImplementedError

    def tangent_product(self, dx: np.ndarray) -> np.ndarray:
        """``T dx`` for a direction ``dx`` (N, k) of its unknowns at every node of every
        process (in rank order), as the owned nodes' rows (n_owned, k)."""
        raise NotImplementedError

    def residual_floor(self) -> float:
        """How far its last forces may be off (the norm over every node): an
        iterative solve's error, below which a Newton residual that stalls is
        converged (0: forces exact to round-off)."""
        return 0.0


class LimitsNewtonStep:
    """An effect that shortens a Newton update (or a step's prediction) that would
    carry the state where its forces are not defined (contact: through a barrier)."""

    def newton_step_fraction(self, x: np.ndarray, y: np.ndarray, keep: float = 0.2) -> float:
        """The part of the update ``x → x − y`` (owned arrays of ``w``) it allows, in
        (0, 1]; ``keep``: the part of each gap the update must leave open."""
        raise NotImplementedError


# --------------------------------------------------------------------- loads

LOAD_KIND_DOC = "What the load is; its kind decides its other keys (below)."
#: the keys every ``[[load]]`` has besides ``kind``, whatever its kind
RAMP = Leaf(
    Str(("linear", "constant", "table")),
    "linear",
    doc='The scale in time: "linear" t / time.end, "constant" 1, "table" interpolated in `table`.',
)
TABLE = Leaf(
    Pairs("scale"),
    unit="[time, 1]",
    default_doc='none: required only with ramp = "table"',
    doc="The scale, piecewise linear in time; before the first and after the last "
    "time it keeps the end value.",
)


class Load(Effect):
    """An effect made of the ``[[load]]`` entries of its ``load_kinds``: active when
    the scene has one, each entry's ramp checked, the entries kept as
    :attr:`entries` (``(index, entry)``, the index as in the scene)."""

    @classmethod
    def active(cls, scene: dict) -> bool:
        return bool(loads_of(scene, cls.load_kinds))

    @classmethod
    def check(cls, scene: dict) -> None:
        for i, load in loads_of(scene, cls.load_kinds):
            check_ramp(load, f"load.{i}")
            cls.check_entry(load, f"load.{i}", scene)

    @classmethod
    def check_entry(cls, load: dict, path: str, scene: dict) -> None:
        """Checks of one entry (at ``path``) against the rest of the scene."""

    def __init__(self, model: Model):
        super().__init__(model)
        self.entries = loads_of(self.scene, self.load_kinds)

    is_load = True

    def scale(self, load: dict, t: float) -> float:
        """The entry's ramp at time ``t`` (0 while the model's loads are off)."""
        if not self.model.loads_on:
            return 0.0
        return ramp_scale(load, t, self.scene["time"]["end"])

    def loads_at_start(self) -> list[str]:
        end = self.scene["time"]["end"]
        return [
            f"load.{i}"
            for i, ld in self.entries
            if ramp_scale(ld, 0.0, end) != 0.0 and np.any(np.asarray(ld["value"]) != 0.0)
        ]


def loads_of(scene: dict, kinds: dict) -> list[tuple[int, dict]]:
    """``(index, entry)`` of the scene's ``[[load]]`` entries of the given kinds."""
    return [(i, ld) for i, ld in enumerate(scene.get("load") or []) if ld.get("kind") in kinds]


def check_ramp(load: dict, path: str) -> None:
    """A ``table`` exactly when ``ramp = "table"``."""
    table_iff(load, path, "ramp", "table", "[t, scale] pairs")


def ramp_scale(load: dict, t: float, end: float) -> float:
    """Scale factor of a ``[[load]]`` at time ``t``: linear t / end, constant 1, or the table."""
    kind = load.get("ramp", "linear")
    if kind == "linear":
        return t / end
    if kind == "constant":
        return 1.0
    table = np.asarray(load["table"], dtype=float)
    return float(np.interp(t, table[:, 0], table[:, 1]))
