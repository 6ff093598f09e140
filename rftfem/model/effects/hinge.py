"""Hinges (``[[hinge]]`` and the three-link mesh's built-in lines) and their
rotational springs (docs/model.md §5.8).

A hinge line lets the director jump: the Model gives each colour of panels its
own rotation field (rftfem/model/hinges.py finds panels and colours).  What this
component adds is the spring of a hinge with ``stiffness`` k > 0, the energy
``Σ ½ k ∫ φ² ds`` of the fold angle φ along its line (``forms.hinge``), and the
checks of the ``[[hinge]]`` lines against the body.
"""

from __future__ import annotations

import re
from typing import TYPE_CHECKING

import ufl

from rftfem.errors import SceneError
from rftfem.forms import hinge as hinge_forms
from rftfem.forms import kinematics
from rftfem.model.effects.base import Effect
from rftfem.scene.bodies import BODY_KEY
from rftfem.scene.mesh_keys import MOMENT_PER_LENGTH_RAD
from rftfem.scene.schema import NONNEGATIVE, Array, Leaf, Table, Where, err, fmt
from rftfem.scene.selectors import LINED_KINDS, THREE_LINK_HINGES, hinge_line

if TYPE_CHECKING:
    from rftfem.model.shell_model import Model


class Hinges(Effect):
    name = "hinge-spring"
    keys = {
        "hinge": Array(
            Table(
                {
                    "where": Leaf(
                        Where(
                            'a hinge line: "x=c" or "y=c" (c a number), or a physical curve name'
                        ),
                        required=True,
                        doc='The line: "x=c" or "y=c" strictly inside a strip or three-link '
                        "body (the mesh is cut there), or a named physical curve of a "
                        "gmsh mesh, straight or curved. One hinge per line.",
                    ),
                    "body": BODY_KEY,
                    "stiffness": Leaf(
                        NONNEGATIVE,
                        0.0,
                        unit=MOMENT_PER_LENGTH_RAD,
                        doc="Rotational spring on the fold angle, per unit length of the "
                        "line; 0 is a free hinge.",
                    ),
                }
            ),
            doc="Lines along which the body folds: the displacement stays continuous, each side "
            "has its own director, so the line passes forces but no moment about itself "
            "(unless it has a spring). The name of the line (its `where`) is then a `where` "
            "selector as well.",
        ),
    }

    @classmethod
    def names(cls, scene: dict) -> list[str]:
        hinges = scene.get("hinge") or []
        mesh = scene.get("mesh") or {}
        three = mesh.get("kind") == "three-link"
        return (["hinge"] if hinges or three else []) + (
            ["hinge-spring"] if cls.active(scene) else []
        )

    @classmethod
    def active(cls, scene: dict) -> bool:
        """A hinge with a spring (the hinges themselves are the Model's topology)."""
        mesh = scene.get("mesh") or {}
        built_in = mesh.get("kind") == "three-link" and (mesh.get("hinge_stiffness") or 0.0) > 0
        return built_in or any((h.get("stiffness") or 0.0) > 0.0 for h in scene.get("hinge") or [])

    @classmethod
    def check(cls, scene: dict) -> None:
        """[[hinge]] lines: well formed, inside the body, one hinge per line."""
        mesh = scene["mesh"]
        kind = mesh["kind"]
        lined = kind in LINED_KINDS
        three = kind == "three-link"
        extent = {"x": mesh["length"], "y": mesh["width"]}
        # (axis, c, description) of each hinge line
        hinged = _built_in_lines(mesh["link_width"]) if three else []
        named: dict[str, int] = {}  # gmsh physical curve names
        for i, hinge in enumerate(scene["hinge"]):
            where = hinge["where"]
            path = f"hinge.{i}.where"
            if three and where in THREE_LINK_HINGES:
                w = mesh["link_width"] * (1.0 if where == "hinge-left" else 2.0)
                raise SceneError(
                    f"{path}: two hinges on one line ({fmt(where)} and the built-in "
                    f"{where} at y = {fmt(w)}){_BUILT_IN_HINT}"
                )
            on_boundary = (
                f"{path}: {fmt(where)} lies on the body's boundary; a hinge joins two sides"
            )
            if where in ("x=L", "y=W"):
                axis = where[0]
                raise SceneError(
                    on_boundary
                    + (f" (expected {axis}=c with 0 < c < {fmt(extent[axis])})" if lined else "")
                )
            line = hinge_line(where)
            if line is None:
                _check_named_curve(path, where, lined, named)
                named[where] = i
                continue
            axis, c = line
            tol = _check_inside(path, where, axis, c, extent[axis], on_boundary) if lined else 0.0
            _check_one_per_line(path, where, axis, c, tol, hinged)
            hinged.append((axis, c, f"hinge.{i}.where = {fmt(where)}"))

    def __init__(self, model: Model):
        from dolfinx import fem
        from petsc4py import PETSc

        from rftfem.model import hinges

        super().__init__(model)
        dS = hinges.facet_measure(model.mesh, model.hinges)
        k = model.kinematics()
        N = kinematics.unit_normal(k.G1, k.G2)
        tangent = hinge_forms.hinge_tangent(k.F_s("+"), N("+"), ufl.FacetNormal(model.mesh)("+"))
        angle = hinge_forms.fold_angle(k.d("-"), k.d("+"), tangent)
        #: the fold angle along the hinge lines, and their measure (hinge i is dS(i + 1))
        self.fold_angle = (angle, dS)
        self.stiffness = [
            fem.Constant(model.mesh, PETSc.ScalarType(h.stiffness)) for h in model.hinges
        ]
        self._energy = sum(
            hinge_forms.hinge_spring_energy(s, angle, dS(i + 1))
            for i, (h, s) in enumerate(zip(model.hinges, self.stiffness))
            if h.stiffness > 0
        )

    def energy(self) -> ufl.Form | None:
        return self._energy


#: what a second hinge on a three-link mesh's built-in line is told
_BUILT_IN_HINT = (
    "; the three-link mesh hinges it already: set mesh.hinge_stiffness for its built-in hinges"
)


def _built_in_lines(w: float) -> list[tuple[str, float, str]]:
    """The three-link mesh's two hinge lines (links of width ``w``), as ``check`` lists them."""
    return [
        ("y", w, f"the built-in hinge-left at y = {fmt(w)}"),
        ("y", 2.0 * w, f"the built-in hinge-right at y = {fmt(2.0 * w)}"),
    ]


def _check_named_curve(path: str, where: str, lined: bool, named: dict[str, int]) -> None:
    """A ``where`` that is no line ``x=c``/``y=c``: a gmsh physical curve's name, once
    (checked against the file later), on a mesh that has such curves."""
    if lined or re.match(r"^[xy]\s*=", where):
        raise err(
            path,
            'a hinge line "x=c" or "y=c" with c a number (like "y=0.5")'
            + ("" if lined else " or a physical curve name"),
            where,
        )
    if where in named:  # a gmsh physical curve, checked against the file later
        raise SceneError(
            f"{path}: two hinges on one line ({fmt(where)} and "
            f"hinge.{named[where]}.where = {fmt(where)})"
        )


def _check_inside(
    path: str, where: str, axis: str, c: float, size: float, on_boundary: str
) -> float:
    """The line ``axis = c`` strictly inside a body spanning ``[0, size]`` along ``axis``;
    the tolerance of that test, ``1e-9 size``."""
    tol = 1e-9 * size
    if c < -tol or c > size + tol:
        raise SceneError(
            f"{path}: {fmt(where)} is not a line of the mesh: the body "
            f"spans {axis} in [0, {fmt(size)}]"
        )
    if c <= tol or c >= size - tol:
        raise SceneError(on_boundary + f" (expected {axis}=c with 0 < c < {fmt(size)})")
    return tol


def _check_one_per_line(
    path: str, where: str, axis: str, c: float, tol: float, hinged: list[tuple[str, float, str]]
) -> None:
    """No earlier hinge (``hinged``) lies on the line ``axis = c`` (within ``tol``)."""
    for other_axis, other, text in hinged:
        if other_axis == axis and abs(c - other) <= tol:
            raise SceneError(
                f"{path}: two hinges on one line ({fmt(where)} and {text})"
                + (
                    _BUILT_IN_HINT
                    if text.startswith("the built-in")
                    else "; expected one [[hinge]] per line"
                )
            )
