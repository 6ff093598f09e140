"""The scene's ``[fluid]``: its keys, shared by the two liquid models.

``model = "rft"`` is resistive-force drag (drag.py), with the coefficients given
(``drag``) or made from the viscosity by the slender-body formula of
:func:`slender_body_drag`; ``model = "stokes"`` is the nonlocal Stokes flow of
regularized Stokeslets (stokes.py, docs/stokes.md).  Both report the liquid's
resultant force and moment on the body (``fluid_Fx`` … ``fluid_Mz``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Callable, Sequence

import numpy as np

from rftfem.errors import SceneError
from rftfem.scene.schema import NONNEGATIVE, POSITIVE, Int, Leaf, Str, Table, Vec

if TYPE_CHECKING:
    from rftfem.model.effects.drag import Drag
    from rftfem.model.effects.stokes import Stokes

OPERATORS = ("auto", "dense", "direct", "fmm")
METHODS = ("layer", "blobs")
FACTORS = ("kept", "every-update")


def _check_rft(fluid: dict) -> None:
    if (fluid.get("drag") is None) == (fluid.get("viscosity") is None):
        raise SceneError(
            "fluid: give either fluid.drag or fluid.viscosity with model = "
            '"rft"' + (", not both" if fluid.get("drag") is not None else "")
        )


def _check_stokes(fluid: dict) -> None:
    if fluid.get("drag") is not None:
        raise SceneError(
            'fluid.drag: not used with fluid.model = "stokes" (the Stokes flow '
            "has no drag coefficients); give fluid.viscosity only: drop "
            "the drag with --unset fluid.drag (Python: del "
            'scene["fluid.drag"])'
        )
    if fluid.get("viscosity") is None:
        raise SceneError('fluid.viscosity: required with fluid.model = "stokes"')
    operator = fluid.get("operator")
    if operator in ("direct", "fmm") and fluid.get("method", "layer") == "layer":
        raise SceneError(
            f'fluid.operator: "{operator}" needs fluid.method = "blobs" in this '
            "version (the integrated layer is dense); use operator = "
            '"dense" (or "auto"), or method = "blobs"'
        )
    if fluid.get("refine") and fluid.get("method", "layer") != "layer":
        raise SceneError(
            'fluid.refine: only with fluid.method = "layer" (the blobs sit '
            "at the nodes: refine the mesh)"
        )


@dataclass(frozen=True)
class FluidModelEntry:
    """A liquid model a scene can name in ``fluid.model``: the keys of ``[fluid]`` that
    only it takes (``{key: (what it is, its default)}``, refused with the other models),
    the name the refusal gives the model, and its own check of the table."""

    keys: dict
    called: str
    check: Callable[[dict], None]


#: the liquid models, in the order the docs list them (one entry each; the effect
#: component that a model builds says ``fluid.model_of(scene) == name`` in ``active``)
MODELS = {
    "rft": FluidModelEntry({"drag": ("drag coefficients", None)}, "local drag", _check_rft),
    "stokes": FluidModelEntry(
        {
            "regularization": ("blob", None),
            "wall": ("wall", None),
            "method": ("discretised layer", "layer"),
            "refine": ("discretised layer", 0),
            "factors": ("discretised layer", "kept"),
            "operator": ("nonlocal operator", "auto"),
        },
        "the Stokes flow",
        _check_stokes,
    ),
}


@dataclass(frozen=True)
class FluidSettings:
    """``[fluid]`` parsed once, its defaults filled in (the effects read this, not the
    table): the model, the liquid's viscosity (None for RFT with drag coefficients),
    the drag coefficients (RFT, None from the viscosity), the Stokes discretisation
    and operator, and the wall ``(point, normal)`` or None."""

    model: str
    viscosity: float | None
    drag: tuple[float, float, float] | None
    method: str = "layer"
    regularization: float | None = None
    refine: int = 0
    operator: str = "auto"
    factors: str = "kept"
    wall: tuple[tuple[float, ...], tuple[float, ...]] | None = None


def settings(scene: dict) -> FluidSettings | None:
    """The scene's ``[fluid]`` as :class:`FluidSettings` (None without one)."""
    given = scene.get("fluid")
    if not given:
        return None
    wall = given.get("wall")
    return FluidSettings(
        model=given.get("model", "rft"),
        viscosity=None if given.get("viscosity") is None else float(given["viscosity"]),
        drag=None if given.get("drag") is None else tuple(float(c) for c in given["drag"]),
        method=given.get("method") or "layer",
        regularization=given.get("regularization"),
        refine=int(given.get("refine") or 0),
        operator=given.get("operator") or "auto",
        factors=given.get("factors") or "kept",
        wall=(tuple(wall["point"]), tuple(wall["normal"])) if wall else None,
    )


def check(scene: dict) -> None:
    """The model's own check, then the keys that only another model takes (one line
    each, exit 2)."""
    fluid = scene.get("fluid")
    if not fluid:
        return
    name = fluid.get("model", "rft")
    entry = MODELS[name]
    entry.check(fluid)
    for other, owner in MODELS.items():
        for key, (what, default) in owner.keys.items():
            if other != name and key not in entry.keys and fluid.get(key) not in (None, default):
                raise SceneError(
                    f'fluid.{key}: only with fluid.model = "{other}" ({entry.called} has no {what})'
                )


SCHEMA = Table(
    {
        "model": Leaf(
            Str(tuple(MODELS)),
            "rft",
            doc='The liquid: "rft" local resistive-force drag, "stokes" the nonlocal '
            "Stokes flow of regularized Stokeslets on the mid-surface (sees every "
            "part of the body and a wall; docs/stokes.md).",
        ),
        "drag": Leaf(
            Vec(
                item=NONNEGATIVE,
                some_positive=True,
                expected="3 numbers >= 0 [along axis, across, normal], at least one > 0",
            ),
            unit="force·time/length³",
            default_doc='none: with model = "rft" give `drag` or `viscosity`',
            doc='The drag coefficients [C1, C2, C3] (model = "rft"): along the '
            "material axis (`shell.axis`) as the body carries it, across it in the "
            "surface, and along the current normal. The traction per current area "
            "is the sum of Ci (ei·v) ei over the three directions. With C1 = C2 "
            "no material axis is needed (a closed body can have such drag).",
        ),
        "viscosity": Leaf(
            POSITIVE,
            unit="force·time/length²",
            default_doc='none: required with model = "stokes"',
            doc='The liquid\'s dynamic viscosity μ. With model = "rft" (instead of '
            "`drag`) the three coefficients come from slender-body theory for "
            "the body's length and width (docs/stokes.md §RFT from the "
            "viscosity).",
        ),
        "method": Leaf(
            Str(METHODS),
            "layer",
            doc='How the Stokes single layer is discretised (model = "stokes"): '
            '"layer" a force density on the shell\'s own elements, the kernel '
            "integrated over each element (singular and near-singular rules), "
            'no slip at the nodes; "blobs" point forces at the nodes with blobs '
            "of the node spacing (first order; the fast multipole operator "
            "needs it); docs/stokes.md §Two discretisations.",
        ),
        "regularization": Leaf(
            POSITIVE,
            unit="length",
            default_doc='method "layer": 0, the Stokeslet itself (integrated '
            'exactly); method "blobs": the local node spacing, '
            "half of it on free edges",
            doc="The blob size ε of the regularized Stokeslets (model = "
            '"stokes"), the same everywhere.',
        ),
        "refine": Leaf(
            Int(0),
            0,
            doc='The liquid\'s own resolution (method "layer"): the force density '
            "lives on the shell's elements each cut into 2^refine × 2^refine on "
            "the shell's own surface (the shell mesh untouched; the dense "
            "operator grows 16× a level). `rftfem study --refine fluid` makes the "
            "liquid's convergence table; `rftfem check` estimates its error.",
        ),
        "operator": Leaf(
            Str(OPERATORS),
            "auto",
            doc='How the Stokes operator is applied (model = "stokes"): "dense" '
            "assembles and factorises the mobility (exact, memory 144 N² bytes "
            'for N nodes); "direct" is matrix-free (method "blobs"): compiled '
            "direct sums of the kernel, with the wall's images, shared out by rows "
            "under mpirun, inside preconditioned conjugate gradients, memory O(N); "
            '"fmm" is matrix-free by fast multipoles (fmm3dpy; the wall\'s images '
            "as multipole sources too; run on the first process, threaded; for "
            'bodies beyond some 400 000 nodes); "auto" is dense up to 5000 nodes, '
            "direct above (docs/stokes.md §Cost and scale).",
        ),
        "factors": Leaf(
            Str(FACTORS),
            "kept",
            doc='When the layer\'s dense operator is factorised (method "layer"): '
            '"kept" (default) keeps a configuration\'s LU factors across residuals '
            "and steps, solving each residual's no slip by GMRES on the current "
            "operator preconditioned by them (to 1e-13) and taking them and their "
            "derivative as the Newton tangent, refreshed when GMRES needs more "
            'than 10 iterations; "every-update" factorises at every residual (the '
            "exact tangent; the same converged answer; docs/stokes.md §Cost). "
            'The same for the blobs\' direct sums (operator = "direct") up to 6000 '
            "nodes, whose preconditioner is then the whole mobility's Cholesky "
            "factors (conjugate gradients to 1e-11 on kept factors).",
        ),
        "wall": Table(
            {
                "point": Leaf(
                    Vec(), required=True, unit="length", doc="A point of the no-slip plane."
                ),
                "normal": Leaf(
                    Vec(nonzero=True),
                    required=True,
                    doc="The plane's normal, towards the body's side.",
                ),
            },
            optional=True,
            doc='A no-slip plane wall (model = "stokes"), by the images of the '
            "Stokeslets in the plane (docs/stokes.md).",
        ),
    },
    optional=True,
    doc="The liquid around the body: local resistive-force drag or Stokes flow.",
)


def model_of(scene: dict) -> str | None:
    """``"rft"``, ``"stokes"`` or None (no ``[fluid]``)."""
    fluid = scene.get("fluid")
    return fluid.get("model", "rft") if fluid else None


def slender_body_drag(viscosity: float, length: float, width: float) -> list[float]:
    """RFT coefficients per unit area ``[C1, C2, C3]`` of a flat ribbon of ``length``
    along the axis and ``width`` across (docs/stokes.md).

    Slender-body theory for a straight filament of length L and radius b gives per
    unit length ``c∥ = 2πμ / (ln(2L/b) − ½)`` and ``c⊥ = 4πμ / (ln(2L/b) + ½)``; a flat
    ribbon of width w moves like a filament of radius b = w/4 (the equivalent radius of
    a flat plate in two-dimensional Stokes flow, for both directions across it).  Per
    unit area: ``C1 = c∥/w`` along the axis, ``C2 = C3 = c⊥/w`` across and normal."""
    L, w = max(length, width), min(length, width)
    log = math.log(2.0 * L / (w / 4.0))
    c_par = 2.0 * math.pi * viscosity / (log - 0.5)
    c_perp = 4.0 * math.pi * viscosity / (log + 0.5)
    if length >= width:
        return [c_par / w, c_perp / w, c_perp / w]
    return [c_perp / w, c_par / w, c_perp / w]


def body_extents(x: np.ndarray, axis: Sequence[float] | np.ndarray) -> tuple[float, float]:
    """The extent of the reference nodes ``x`` along ``axis`` and across it in the
    body's plane (its largest extent normal to the axis)."""
    axis = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    along = x @ axis
    rest = x - np.outer(along, axis)
    centre = rest.mean(axis=0)
    spread = rest - centre
    if len(x) > 1:
        _, s, vt = np.linalg.svd(spread, full_matrices=False)
        across = spread @ vt[0]
    else:
        across = np.zeros(1)
    return float(np.ptp(along)), float(np.ptp(across))


def force_scales(component: Drag | Stokes) -> list[float]:
    """A liquid component's force scale for the Newton tolerances: its drag
    coefficients ``C`` (the slender-body ones of a Stokes flow's viscosity) on the
    whole body moving at the fastest prescribed speed."""
    motion = component.model.get("prescribed-motion")
    if motion is None:
        return []
    return [max(component.C) * component.model.area() * motion.speed_scale()]


RESULTANT_COLUMNS = ["fluid_Fx", "fluid_Fy", "fluid_Fz", "fluid_Mx", "fluid_My", "fluid_Mz"]
