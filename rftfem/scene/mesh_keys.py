"""The ``[mesh]`` table of a scene: its keys and the checks that fill its
kind-dependent defaults (see :mod:`rftfem.scene.reading` for the rest of the file)."""

from __future__ import annotations

import math

from rftfem.errors import SceneError
from rftfem.scene.schema import (
    NONNEGATIVE,
    POSITIVE,
    Array,
    Divisions,
    Leaf,
    Num,
    Str,
    Table,
    Vec,
    check_unique,
    err,
    fmt,
)
from rftfem.scene.selectors import (
    BODY_NAME,
    LINED_KINDS,
    SPECIAL_SELECTORS,
    THREE_LINK_HINGES,
    THREE_LINK_REGIONS,
)

_INTERVAL = "an interval [a, b] of 2 numbers"
MOMENT_PER_LENGTH_RAD = "force·length/(length·rad)"

MESH = Table(
    {
        "kind": Leaf(
            Str(("strip", "gmsh", "three-link")),
            "strip",
            doc='How the body is made. "strip": the rectangle [0, length] × '
            '[0, width] in the plane Z = 0. "three-link": three strips side by '
            "side along Y, joined along X by two built-in hinges (regions left, "
            'middle, right; hinge lines hinge-left, hinge-right). "gmsh": the '
            "surface mesh in `mesh.file`, flat or curved.",
        ),
        "length": Leaf(
            POSITIVE,
            10.0,
            unit="length",
            doc="Extent of a strip or three-link body along X (the links' "
            "length). Not used with a gmsh mesh.",
        ),
        # 1.0, or 3 * link_width: filled by rftfem.scene.keys.cross_check
        "width": Leaf(
            POSITIVE,
            None,
            unit="length",
            default_doc='1.0; with kind = "three-link" it is 3 × link_width and may not be set',
            doc="Extent of a strip along Y. Not used with a gmsh mesh.",
        ),
        # 0.5 for three-link: filled by rftfem.scene.keys.cross_check
        "link_width": Leaf(
            POSITIVE,
            None,
            unit="length",
            default_doc='none: only with kind = "three-link", where it is 0.5',
            doc="Width of each link of a three-link body across Y; the body "
            "spans Y in [0, 3 link_width].",
        ),
        # 0.0 for three-link: filled likewise
        "hinge_stiffness": Leaf(
            NONNEGATIVE,
            None,
            unit=MOMENT_PER_LENGTH_RAD,
            default_doc='none: only with kind = "three-link", where it is 0.0',
            doc="Rotational spring of both built-in hinges of a "
            "three-link body, as `[[hinge]].stiffness`; 0 leaves "
            "them free.",
        ),
        "divisions": Leaf(
            Divisions(),
            [16, 1],
            doc="Number of cells along X and across Y (three-link: across "
            "each link), at most 1e7 cells in all. Region limits and hinge "
            "lines add cuts. Not used with a gmsh mesh.",
        ),
        "grading": Leaf(
            Num(1.0),
            1.0,
            doc="Cells graded towards both ends of the strip along X and across "
            "Y (its free edges), and of every segment between cuts (region "
            "limits, hinge lines): the ratio of the largest cell to the "
            "smallest in each segment, ≥ 1 (1: uniform). Sizes follow "
            "1 − g cos 2πs, g = (grading − 1)/(grading + 1). The Stokes layer "
            "needs none (its density carries the edge's singularity, "
            "docs/stokes.md); RFT and the shell may use it for edge "
            "effects. Not used with a gmsh mesh.",
        ),
        "cell": Leaf(
            Str(("quadrilateral", "triangle")),
            "quadrilateral",
            doc="Cell shape of a strip or three-link mesh; the unknowns are "
            "second order either way (Q2 or P2). A gmsh file brings its own "
            "cells.",
        ),
        "file": Leaf(
            Str(),
            None,
            default_doc='none: required only with kind = "gmsh"',
            doc="The gmsh .msh file, relative to the scene file's folder unless "
            "absolute. Its named physical surfaces are the regions, its named "
            "physical curves are edges for `where` and hinge lines, its named "
            "physical points are points a [[boundary]] or [[motion]] may hold. "
            "Checked as it is read: cells facing the other way from their "
            "neighbours are turned (the run's log says how many); cells of no "
            "area or turned inside out, coincident nodes not merged and a "
            "surface that cannot be oriented are refused; `rftfem check` "
            "lists cells, orientation, free edges and pieces.",
        ),
        "regions": Array(
            Table(
                {
                    "name": Leaf(
                        Str(name=True),
                        required=True,
                        doc="The region's name, unique; not a selector (all, x=0, x=L, "
                        "y=0, y=W) nor a built-in three-link name.",
                    ),
                    "x": Leaf(
                        Vec(2, expected=_INTERVAL),
                        unit="length",
                        default_doc="none: the region spans all of X (give x, y or both)",
                        doc="The band a ≤ X ≤ b of reference coordinates, inside [0, mesh.length].",
                    ),
                    "y": Leaf(
                        Vec(2, expected=_INTERVAL),
                        unit="length",
                        default_doc="none: the region spans all of Y (give x, y or both)",
                        doc="The band a ≤ Y ≤ b of reference coordinates, inside the body's width.",
                    ),
                }
            ),
            doc="Named parts of a strip or three-link body: the cells inside a band of X, of "
            "Y, or both. The mesh is cut along the band limits. A region can carry "
            "`[[shell.parts]]` and `[[magnetic.parts]]` values and serves as a `where` "
            "selector. Refused with a gmsh mesh, whose physical surfaces are the "
            "regions.",
        ),
    },
    required=True,
    doc="The body in its reference (unloaded) state: the shell's mid-surface, its mesh "
    "and its named regions and edges. A scene of several bodies gives `[[body]]` "
    "tables instead, each with a mesh table like this one.",
)


def check_mesh(mesh: dict) -> None:
    """Fill the kind-dependent keys of [mesh] and check its regions (the mesh of
    several bodies is made of [[body]] tables, each checked on its own)."""
    kind = mesh["kind"]
    if kind == "bodies":
        return
    three = kind == "three-link"
    if kind == "gmsh" and mesh["file"] is None:
        raise SceneError(
            "missing required key 'mesh.file' (expected the path of a gmsh "
            'mesh, relative to the scene file, when mesh.kind = "gmsh")'
        )
    if kind != "gmsh":
        mesh["file"] = None  # only read for gmsh meshes (lets --set mesh.kind=strip work)
    if three:
        _fill_three_link(mesh)
    else:
        if mesh["width"] is None:
            mesh["width"] = 1.0
        # only read for three-link meshes (lets --set mesh.kind=strip work)
        mesh["link_width"] = mesh["hinge_stiffness"] = None

    regions = mesh["regions"]
    check_unique(regions, "name", "mesh.regions", "region")
    extent = {
        "x": (mesh["length"], "mesh.length"),
        "y": (mesh["width"], "3 * mesh.link_width" if three else "mesh.width"),
    }
    for i, region in enumerate(regions):
        _check_region(region, i, kind, extent)


def _fill_three_link(mesh: dict) -> None:
    """A three-link mesh's defaults: its link width and hinge stiffness, and the
    width of its three links (which [mesh] may not set)."""
    if mesh["width"] is not None:
        raise SceneError(
            "mesh.width: expected no mesh.width with mesh.kind = "
            '"three-link" (set mesh.link_width: the body is 3 * link_width '
            f"wide), found mesh.width = {fmt(mesh['width'])}"
        )
    if mesh["link_width"] is None:
        mesh["link_width"] = 0.5
    if mesh["hinge_stiffness"] is None:
        mesh["hinge_stiffness"] = 0.0
    mesh["width"] = 3.0 * mesh["link_width"]
    if not math.isfinite(mesh["width"]):
        raise err(
            "mesh.link_width",
            "a number whose triple (the body's width) is finite",
            mesh["link_width"],
        )


def _check_region(region: dict, i: int, kind: str, extent: dict[str, tuple[float, str]]) -> None:
    """Region ``i`` of [mesh]: a name of its own and bands inside the body
    (``extent``: each axis's size and the key that sets it)."""
    name = region["name"]
    if kind == "three-link" and name in THREE_LINK_REGIONS + THREE_LINK_HINGES:
        raise SceneError(
            f"mesh.regions.{i}.name: expected a name other than the "
            "three-link mesh's built-in regions and hinge lines "
            f"{', '.join(THREE_LINK_REGIONS + THREE_LINK_HINGES)}, "
            f"found '{name}'"
        )
    if name in SPECIAL_SELECTORS:
        raise SceneError(
            f"mesh.regions.{i}.name: expected a name other than the "
            f"selectors {', '.join(SPECIAL_SELECTORS)}, found '{name}'"
        )
    if region["x"] is None and region["y"] is None:
        raise SceneError(
            f"mesh.regions.{i}: expected x = [a, b] and/or y = [a, b], "
            f"found neither in region '{name}'"
        )
    for axis in ("x", "y"):
        band = region[axis]
        if band is None:
            continue
        _check_band(band, f"mesh.regions.{i}.{axis}", kind, *extent[axis])


def _check_band(band: list[float], path: str, kind: str, size: float, size_key: str) -> None:
    """A region's band [a, b]: not empty, and inside the body's ``size`` along its
    axis on a strip or three-link mesh."""
    a, b = band
    if a >= b:
        raise SceneError(
            f"{path}: expected an interval [a, b] with a < b, found "
            f"{fmt(band)} (the region selects nothing)"
        )
    tol = 1e-9 * size
    if kind in LINED_KINDS and (a < -tol or b > size + tol):
        nothing = b <= 0.0 or a >= size
        raise SceneError(
            f"{path}: expected an interval [a, b] with 0 <= a < b <= "
            f"{size_key} = {fmt(size)}, found {fmt(band)}"
            + (
                " (the region selects nothing)"
                if nothing
                else f" (the region reaches outside the {BODY_NAME[kind]})"
            )
        )
