"""Structured strip ``[0, L] x [0, W]`` in the plane Z = 0, built with gmsh."""

from __future__ import annotations

import math
from numbers import Integral, Real

from rftfem.errors import SceneError

from .gmsh_file import _model_to_body

EDGE_TAGS = {"x=0": 1, "x=L": 2, "y=0": 3, "y=W": 4}
CELLS = ("quadrilateral", "triangle")

# gmsh options the strip depends on (global in gmsh: set and restored around the build)
_OPTIONS = {"Mesh.ElementOrder": 1, "Mesh.RecombineAll": 0,
            "Mesh.SubdivisionAlgorithm": 0, "Mesh.Smoothing": 0}


def share_divisions(lengths, nx: int) -> list[int]:
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


def _check_regions(regions, length: float):
    """Validated ``[(name, x0, x1)]`` clipped to ``[0, L]``; SceneError otherwise."""
    tol = 1e-9 * length
    out, seen = [], set()
    for i, item in enumerate(regions):
        key = f"mesh.regions.{i}"
        try:
            name, band = item
            x0, x1 = band
        except (TypeError, ValueError):
            raise SceneError(f"{key}: expected a name and an interval x = [x0, x1], "
                             f"found {item!r}") from None
        if not isinstance(name, str) or not name:
            raise SceneError(f"{key}.name: expected a non-empty string, found {name!r}")
        if name in seen:
            raise SceneError(f"{key}.name: region '{name}' is defined twice")
        if name in EDGE_TAGS:
            raise SceneError(f"{key}.name: '{name}' is the name of a strip edge; "
                             "choose another region name")
        seen.add(name)
        if not all(isinstance(v, Real) and not isinstance(v, bool) for v in (x0, x1)):
            raise SceneError(f"{key}.x: expected two numbers [x0, x1], found {list(band)!r}")
        x0, x1 = float(x0), float(x1)
        if not (math.isfinite(x0) and math.isfinite(x1)) or x1 - x0 <= tol:
            raise SceneError(f"{key}.x: expected an interval [x0, x1] with x1 − x0 > "
                             f"{tol:.3g} (1e-9 of the length), found [{x0:g}, {x1:g}]")
        if x0 < -tol or x1 > length + tol:
            raise SceneError(f"{key}.x: [{x0:g}, {x1:g}] is not inside the strip "
                             f"[0, {length:g}]")
        out.append((name, min(max(x0, 0.0), length), min(max(x1, 0.0), length)))
    return out


def _breakpoints(bands, length: float) -> list[float]:
    """0, L and every region limit, sorted; limits closer than 1e-9 L merged."""
    tol = 1e-9 * length
    xs = [0.0]
    for x in sorted(v for _, a, b in bands for v in (a, b)):
        if x - xs[-1] > tol and length - x > tol:
            xs.append(x)
    xs.append(length)
    return xs


def _prepare_strip(gmsh, length, width, xs, nseg, ny, quads, bands):
    geo = gmsh.model.geo
    m = len(nseg)
    bottom = [geo.addPoint(x, 0.0, 0.0) for x in xs]
    top = [geo.addPoint(x, width, 0.0) for x in xs]
    lb = [geo.addLine(bottom[i], bottom[i + 1]) for i in range(m)]
    lt = [geo.addLine(top[i], top[i + 1]) for i in range(m)]
    lv = [geo.addLine(bottom[i], top[i]) for i in range(m + 1)]
    surfaces = []
    for i in range(m):
        # counter-clockwise seen from +Z: the surface (and cell) normal is +Z
        loop = geo.addCurveLoop([lb[i], lv[i + 1], -lt[i], -lv[i]])
        surfaces.append(geo.addPlaneSurface([loop]))
    geo.synchronize()
    mesh = gmsh.model.mesh
    for i in range(m):
        mesh.setTransfiniteCurve(lb[i], nseg[i] + 1)
        mesh.setTransfiniteCurve(lt[i], nseg[i] + 1)
    for line in lv:
        mesh.setTransfiniteCurve(line, ny + 1)
    for i, s in enumerate(surfaces):
        mesh.setTransfiniteSurface(s, cornerTags=[bottom[i], bottom[i + 1], top[i + 1], top[i]])
        if quads:
            mesh.setRecombine(2, s)
    model = gmsh.model
    for i, s in enumerate(surfaces):
        model.addPhysicalGroup(2, [s], i + 1)
        model.setPhysicalName(2, i + 1, f"segment{i + 1}")
    for name, lines in (("x=0", [lv[0]]), ("x=L", [lv[m]]), ("y=0", lb), ("y=W", lt)):
        model.addPhysicalGroup(1, lines, EDGE_TAGS[name])
        model.setPhysicalName(1, EDGE_TAGS[name], name)
    mesh.generate(2)

    regions = {}
    for name, a, b in bands:
        regions[name] = [i + 1 for i in range(m) if a <= 0.5 * (xs[i] + xs[i + 1]) <= b]
    edges = {name: [tag] for name, tag in EDGE_TAGS.items()}
    return regions, edges


def build_strip(comm, length, width, divisions, cell="quadrilateral", regions=()):
    """A structured strip ``x in [0, L], y in [0, W]`` at Z = 0 as a Body.

    ``divisions = [nx, ny]``: elements along X and Y; ``cell`` is
    ``"quadrilateral"`` (recombined transfinite mesh, nx*ny cells) or
    ``"triangle"`` (each rectangle split in two, 2*nx*ny cells). Geometry
    degree 1. Every cell's normal ``G1 x G2`` (columns of the Jacobian) points
    to +Z.

    ``regions``: ``[(name, (x0, x1)), ...]`` bands across the strip, which may
    overlap. The strip is cut at every region limit into segments (limits
    closer than 1e-9 L count as one) and the ``nx`` divisions are shared among
    the segments in proportion to their lengths by largest-remainder rounding
    with at least one element each (:func:`share_divisions`): the total is
    exactly ``nx`` when ``nx`` is at least the number of segments, otherwise
    every segment has one element. Hence every region is a union of whole
    cells and its area is exact.

    Tags: segment ``k`` (1, 2, ... from x = 0 up) has cell tag ``k``, whether
    or not a region covers it; ``regions[name]`` lists the tags of the
    segments inside the band. Facet tags: ``"x=0"`` 1, ``"x=L"`` 2, ``"y=0"``
    3, ``"y=W"`` 4, in ``edges``.

    Bad arguments raise ``SceneError`` naming the ``mesh.*`` scene key.
    """
    for key, v in (("length", length), ("width", width)):
        if not isinstance(v, Real) or isinstance(v, bool) or not (math.isfinite(v) and v > 0):
            raise SceneError(f"mesh.{key}: expected a positive number, found {v!r}")
    length, width = float(length), float(width)
    try:
        nx, ny = divisions
        ok = all(isinstance(n, Integral) and not isinstance(n, bool) and n >= 1 for n in (nx, ny))
    except (TypeError, ValueError):
        ok = False
    if not ok:
        raise SceneError(f"mesh.divisions: expected two positive integers [nx, ny], "
                         f"found {divisions!r}")
    nx, ny = int(nx), int(ny)
    if cell not in CELLS:
        raise SceneError(f"mesh.cell: expected \"quadrilateral\" or \"triangle\", found {cell!r}")

    bands = _check_regions(regions, length)
    xs = _breakpoints(bands, length)
    nseg = share_divisions([b - a for a, b in zip(xs[:-1], xs[1:])], nx)

    mesh, cell_tags, facet_tags, names, edges = _model_to_body(
        comm,
        lambda gmsh: _prepare_strip(gmsh, length, width, xs, nseg, ny,
                                    cell == "quadrilateral", bands),
        options=_OPTIONS)
    from . import Body

    return Body(mesh=mesh, cell_tags=cell_tags, facet_tags=facet_tags,
                regions=names, edges=edges, length=length, width=width)
