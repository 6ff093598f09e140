"""Structured strips in the plane Z = 0, built with gmsh as a grid of rectangles.

:func:`build_strip` makes ``[0, L] x [0, W]``; :func:`grid_recipe` is the grid
builder it shares with :mod:`.three_link` (cuts in X and Y at region limits and
hinge lines, one transfinite surface and one cell tag per rectangle); their
arguments are checked in :mod:`.grid_arguments`.
"""

from __future__ import annotations

import bisect
import math
from typing import TYPE_CHECKING

from .gmsh_session import Recipe, realize
from .grid_arguments import (  # noqa: F401  (CELLS, EDGE_TAGS, MAX_SIZE: importable here too)
    CELLS,
    EDGE_TAGS,
    MAX_SIZE,
    check_cell,
    check_divisions,
    check_hinges,
    check_regions,
    check_size,
)

if TYPE_CHECKING:
    from collections.abc import Sequence

    from mpi4py import MPI

    from . import Body

    #: a band ``(a, b)`` of x or y
    Band = tuple[float, float]
    #: a region ``(name, xband, yband)`` (a band may be None), or the older ``(name, xband)``
    Region = tuple[str, Band | None, Band | None] | tuple[str, Band]


# gmsh options the strip depends on (global in gmsh: set and restored around the build)
_OPTIONS = {
    "Mesh.ElementOrder": 1,
    "Mesh.RecombineAll": 0,
    "Mesh.SubdivisionAlgorithm": 0,
    "Mesh.Smoothing": 0,
}


def share_divisions(lengths: Sequence[float], nx: int) -> list[int]:
    """Split ``nx`` elements among segments of the given lengths.

    Each segment gets its proportional share ``nx * l_i / sum(l)`` rounded by
    largest remainder (floors first, then one more to the largest fractional
    parts, ties to the leftmost), so the total is exactly ``nx``. A segment
    left with 0 gets 1, taken from the segment with at least 2 that is the most
    above its share. If ``nx`` is smaller than the number of segments, every
    segment gets 1 (total = number of segments).
    """
    m = len(lengths)
    if nx <= m:
        return [1] * m
    total = float(sum(lengths))
    quota = [nx * l / total for l in lengths]
    n = [int(math.floor(q)) for q in quota]
    order = sorted(range(m), key=lambda i: (-(quota[i] - n[i]), i))
    for i in order[: nx - sum(n)]:
        n[i] += 1
    for i in range(m):
        if n[i] == 0:
            donors = [j for j in range(m) if n[j] >= 2]
            j = max(donors, key=lambda j: (n[j] - quota[j], -j))
            n[j] -= 1
            n[i] = 1
    return n


# --- the grid --------------------------------------------------------------------


def _cuts(extent: float, fixed, limits) -> list[float]:
    """0, ``extent``, the ``fixed`` lines and the region ``limits``, sorted.

    A limit within 1e-9 of the extent of a cut already kept (0, the extent, a
    fixed line or a smaller limit) is merged into it.
    """
    tol = 1e-9 * extent
    cuts = sorted({0.0, extent, *fixed})
    for v in sorted(limits):
        k = bisect.bisect_left(cuts, v)
        if all(abs(v - cuts[j]) > tol for j in (k - 1, k) if 0 <= j < len(cuts)):
            cuts.insert(k, v)
    return cuts


def _share(cuts, groups) -> list[int]:
    """Divisions of the segments between ``cuts``: each group ``(a, b, n)``
    (``a``, ``b`` being cuts) shares ``n`` among its segments (:func:`share_divisions`)."""
    out = []
    for a, b, n in groups:
        i, j = cuts.index(a), cuts.index(b)
        out += share_divisions([q - p for p, q in zip(cuts[i:j], cuts[i + 1 : j + 1])], n)
    return out


def graded(v: float, cuts: Sequence[float], grading: float) -> float:
    """A coordinate ``v`` moved so that cells are graded towards both ends of its
    segment between ``cuts``: sizes ∝ 1 − g cos 2πs over the segment (s ∈ [0, 1]),
    g = (grading − 1)/(grading + 1), the ratio of the largest to the smallest;
    the cuts stay."""
    if grading == 1.0:
        return v
    g = (grading - 1.0) / (grading + 1.0)
    k = min(max(bisect.bisect_right(cuts, v) - 1, 0), len(cuts) - 2)
    a, b = cuts[k], cuts[k + 1]
    s = min(max((v - a) / (b - a), 0.0), 1.0)
    return a + (b - a) * (s - g * math.sin(2 * math.pi * s) / (2 * math.pi))


def _grade_nodes(gmsh, xs, ys, grading: float) -> None:
    """Move the generated mesh's nodes by :func:`graded` along X and Y."""
    if grading == 1.0:
        return
    tags, xyz, _ = gmsh.model.mesh.getNodes()
    for tag, (x, y, z) in zip(tags, xyz.reshape(-1, 3)):
        gmsh.model.mesh.setNode(int(tag), [graded(x, xs, grading), graded(y, ys, grading), z], [])


def _prepare_grid(gmsh, xs, nxs, ys, nys, quads, regions, lines, grading=1.0):
    """Rank 0: the grid of rectangles, its tags and names in the current model."""
    geo = gmsh.model.geo
    mx, my = len(nxs), len(nys)
    p = [[geo.addPoint(x, y, 0.0) for x in xs] for y in ys]  # p[j][i] at (x_i, y_j)
    h = [[geo.addLine(p[j][i], p[j][i + 1]) for i in range(mx)] for j in range(my + 1)]
    v = [[geo.addLine(p[j][i], p[j + 1][i]) for j in range(my)] for i in range(mx + 1)]
    surfaces = {}  # cell tag -> (surface, i, j); rectangle (i, j) has tag j * mx + i + 1
    for j in range(my):
        for i in range(mx):
            # counter-clockwise seen from +Z: the surface (and cell) normal is +Z
            loop = geo.addCurveLoop([h[j][i], v[i + 1][j], -h[j + 1][i], -v[i][j]])
            surfaces[j * mx + i + 1] = (geo.addPlaneSurface([loop]), i, j)
    geo.synchronize()
    mesh = gmsh.model.mesh
    for j in range(my + 1):
        for i in range(mx):
            mesh.setTransfiniteCurve(h[j][i], nxs[i] + 1)
    for i in range(mx + 1):
        for j in range(my):
            mesh.setTransfiniteCurve(v[i][j], nys[j] + 1)
    model = gmsh.model
    for tag, (s, i, j) in surfaces.items():
        mesh.setTransfiniteSurface(
            s, cornerTags=[p[j][i], p[j][i + 1], p[j + 1][i + 1], p[j + 1][i]]
        )
        if quads:
            mesh.setRecombine(2, s)
        model.addPhysicalGroup(2, [s], tag)
        model.setPhysicalName(2, tag, f"rectangle{i + 1}-{j + 1}")
    curves = {"x=0": v[0], "x=L": v[mx], "y=0": h[0], "y=W": h[my]}
    for axis, c, name in lines:
        curves[name] = v[xs.index(c)] if axis == "x" else h[ys.index(c)]
    edges = {}
    for tag, (name, group) in enumerate(curves.items(), start=1):
        model.addPhysicalGroup(1, group, tag)
        model.setPhysicalName(1, tag, name)
        edges[name] = [tag]
    mesh.generate(2)
    _grade_nodes(gmsh, xs, ys, grading)

    def inside(band, a, b):
        return band is None or band[0] <= 0.5 * (a + b) <= band[1]

    names = {
        name: [
            tag
            for tag, (_, i, j) in surfaces.items()
            if inside(xband, xs[i], xs[i + 1]) and inside(yband, ys[j], ys[j + 1])
        ]
        for name, xband, yband in regions
    }
    return names, edges


def grid_recipe(
    length: float,
    width: float,
    nx: int,
    ygroups: Sequence[tuple[float, float, int]],
    cell: str,
    regions: Sequence[Region],
    hinges: Sequence[str],
    grading: float = 1.0,
    builtin_lines: Sequence[tuple[str, float, str]] = (),
    builtin_regions: Sequence[Region] = (),
) -> Recipe:
    """The body ``[0, length] x [0, width]`` at Z = 0 as a grid of rectangles (its
    :class:`~.gmsh_session.Recipe`).

    Checked arguments except ``regions`` and ``hinges`` (user input, checked
    here). The X cuts (0, L, x hinge lines, region x limits) share ``nx``; the
    Y cuts share divisions by ``ygroups`` ``[(y0, y1, n)]`` (consecutive, from
    0 to ``width``; inner limits must be built-in lines). ``builtin_lines``
    ``[(axis, c, name)]`` are named hinge lines that come first (facet tags 5,
    6, ...), ``builtin_regions`` ``[(name, xband, yband)]`` regions that come
    first and whose names users may not take. The Body's ``hinges`` are the
    built-in line names.
    """
    bands = check_regions(regions, length, width, [name for name, _, _ in builtin_regions])
    lines = check_hinges(hinges, length, width, builtin_lines)
    all_regions = list(builtin_regions) + bands

    def limits(k):
        return [v for r in all_regions if r[k] is not None for v in r[k]]

    xs = _cuts(length, [c for axis, c, _ in lines if axis == "x"], limits(1))
    ys = _cuts(width, [c for axis, c, _ in lines if axis == "y"], limits(2))
    nxs = _share(xs, [(0.0, length, nx)])
    nys = _share(ys, ygroups)

    def prepare(gmsh):
        names, edges = _prepare_grid(
            gmsh, xs, nxs, ys, nys, cell == "quadrilateral", all_regions, lines, grading
        )
        return names, edges, {}, None

    return Recipe(
        prepare,
        options=_OPTIONS,
        extents=(length, width),
        hinges=[name for _, _, name in builtin_lines],
    )


def strip_recipe(
    length: float,
    width: float,
    divisions: Sequence[int],
    cell: str = "quadrilateral",
    regions: Sequence[Region] = (),
    hinges: Sequence[str] = (),
    grading: float = 1.0,
) -> Recipe:
    """The :class:`~.gmsh_session.Recipe` of :func:`build_strip` (same arguments but ``comm``)."""
    length, width = check_size("length", length), check_size("width", width)
    nx, ny = check_divisions(divisions, "[nx, ny]")
    check_cell(cell)
    return grid_recipe(
        length, width, nx, [(0.0, width, ny)], cell, regions, hinges, grading=grading
    )


def build_strip(
    comm: MPI.Comm,
    length: float,
    width: float,
    divisions: Sequence[int],
    cell: str = "quadrilateral",
    regions: Sequence[Region] = (),
    hinges: Sequence[str] = (),
    grading: float = 1.0,
) -> Body:
    """A structured strip ``x in [0, L], y in [0, W]`` at Z = 0 as a Body.

    ``divisions = [nx, ny]``: elements along X and Y; ``cell`` is
    ``"quadrilateral"`` (recombined transfinite mesh, nx*ny cells) or
    ``"triangle"`` (each rectangle split in two, 2*nx*ny cells). Geometry
    degree 1. Every cell's normal ``G1 x G2`` (columns of the Jacobian) points
    to +Z.

    ``regions``: ``[(name, xband, yband), ...]`` with ``xband = (x0, x1)`` a
    band across the strip, ``yband = (y0, y1)`` a band along it, either one
    ``None`` (not both); both given is a rectangle. ``(name, xband)`` is an x
    band. Regions may overlap. ``hinges``: selectors ``"x=c"`` / ``"y=c"``,
    inner lines of the strip.

    The strip is cut in X at every region x limit and x hinge line, and in Y
    at every y limit and y hinge line (limits closer than 1e-9 of the extent
    count as one; a hinge line wins) into a grid of rectangles. The ``nx``
    divisions are shared among the X segments and ``ny`` among the Y segments
    in proportion to their lengths (:func:`share_divisions`): the totals are
    exactly ``nx`` and ``ny`` unless there are more segments than divisions
    (then one element each). Every region is a union of whole cells, its area
    exact.

    Tags: rectangle ``(i, j)`` (``i``-th X segment, ``j``-th Y segment, from
    0) has cell tag ``j * mx + i + 1`` (``mx`` X segments);
    ``regions[name]`` lists the tags of the rectangles whose centre is in all
    the given bands. Facet tags (``edges``): ``"x=0"`` 1, ``"x=L"`` 2,
    ``"y=0"`` 3, ``"y=W"`` 4, then each hinge selector, named as written, 5,
    6, ... in order (every grid line at that coordinate, from side to side;
    interior facets).

    Bad arguments raise ``SceneError`` naming the ``mesh.*`` scene key, or
    ``hinge.N.where`` (``N`` the index in ``hinges``).
    """
    return realize(comm, strip_recipe(length, width, divisions, cell, regions, hinges, grading))
