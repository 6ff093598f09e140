"""gmsh meshes of the rigid bodies of the Stokes-flow tests: a flat disk and an
ellipsoid (a sphere when its semi-axes are equal), second-order quadrilaterals."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np


def _session():
    import gmsh

    gmsh.initialize(readConfigFiles=False)
    gmsh.option.setNumber("General.Terminal", 0)
    return gmsh


def _group(gmsh, dim, tags, name):
    gmsh.model.setPhysicalName(dim, gmsh.model.addPhysicalGroup(dim, tags), name)


def write_disk(
    path, radius: float = 1.0, size: float = 0.2, edge_size: float | None = None, tilt: float = 0.0
):
    """A flat disk in the XY plane, centre at the origin: surface group "disk", its rim
    the curve group "rim"; ``edge_size`` grades the cells towards the rim; ``tilt``
    (rad) turns it about Y (its normal then leans towards +X)."""
    gmsh = _session()
    try:
        gmsh.model.add("disk")
        g = gmsh.model.geo
        c = g.addPoint(0, 0, 0)
        p = [
            g.addPoint(radius * math.cos(a), radius * math.sin(a), 0)
            for a in np.arange(4) * math.pi / 2
        ]
        arcs = [g.addCircleArc(p[i], c, p[(i + 1) % 4]) for i in range(4)]
        surface = g.addPlaneSurface([g.addCurveLoop(arcs)])
        g.synchronize()
        _group(gmsh, 2, [surface], "disk")
        _group(gmsh, 1, arcs, "rim")
        gmsh.option.setNumber("Mesh.MeshSizeMax", size)
        gmsh.option.setNumber("Mesh.MeshSizeMin", min(size, edge_size or size))
        if edge_size is not None:
            f = gmsh.model.mesh.field
            dist = f.add("Distance")
            f.setNumbers(dist, "CurvesList", arcs)
            f.setNumber(dist, "NumPointsPerCurve", 400)
            grade = f.add("Threshold")
            f.setNumber(grade, "InField", dist)
            f.setNumber(grade, "SizeMin", edge_size)
            f.setNumber(grade, "SizeMax", size)
            f.setNumber(grade, "DistMin", 0.0)
            f.setNumber(grade, "DistMax", 0.5 * radius)
            f.setAsBackgroundMesh(grade)
            gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
        gmsh.option.setNumber("Mesh.RecombineAll", 1)
        gmsh.model.mesh.generate(2)
        gmsh.model.mesh.setOrder(2)
        if tilt:
            c, s = math.cos(tilt), math.sin(tilt)
            turn = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])
            tags, xyz, _ = gmsh.model.mesh.getNodes()
            for tag, x in zip(tags, xyz.reshape(-1, 3) @ turn.T):
                gmsh.model.mesh.setNode(int(tag), list(x), [])
        gmsh.write(str(path))
    finally:
        gmsh.finalize()


def write_disk_ogrid(
    path, radius: float = 1.0, around: int = 6, radial: int = 4, inner: float = 0.45
):
    """A flat disk meshed as an O-grid (a structured square of side ``inner``·√2·radius
    inside four structured blocks out to the rim): ``around`` cells along each quarter
    of the rim and across the square, ``radial`` cells from the square to the rim;
    surface group "disk", rim "rim"."""
    gmsh = _session()
    try:
        gmsh.model.add("ogrid")
        g = gmsh.model.geo
        c = g.addPoint(0, 0, 0)
        angles = np.pi / 4 + np.arange(4) * np.pi / 2
        sq = [
            g.addPoint(inner * radius * math.cos(a), inner * radius * math.sin(a), 0)
            for a in angles
        ]
        rim = [g.addPoint(radius * math.cos(a), radius * math.sin(a), 0) for a in angles]
        inside = [g.addLine(sq[i], sq[(i + 1) % 4]) for i in range(4)]
        arcs = [g.addCircleArc(rim[i], c, rim[(i + 1) % 4]) for i in range(4)]
        spokes = [g.addLine(sq[i], rim[i]) for i in range(4)]
        surfaces = [g.addPlaneSurface([g.addCurveLoop(inside)])]
        for i in range(4):
            loop = g.addCurveLoop([spokes[i], arcs[i], -spokes[(i + 1) % 4], -inside[i]])
            surfaces.append(g.addPlaneSurface([loop]))
        for line in inside + arcs:
            g.mesh.setTransfiniteCurve(line, around + 1)
        for line in spokes:
            g.mesh.setTransfiniteCurve(line, radial + 1)
        for s_ in surfaces:
            g.mesh.setTransfiniteSurface(s_)
            g.mesh.setRecombine(2, s_)
        g.synchronize()
        _group(gmsh, 2, surfaces, "disk")
        _group(gmsh, 1, arcs, "rim")
        gmsh.model.mesh.generate(2)
        gmsh.model.mesh.setOrder(2)
        gmsh.write(str(path))
    finally:
        gmsh.finalize()


def write_ellipsoid(path, semi_axes=(1.0, 1.0, 1.0), size: float = 0.3):
    """A closed ellipsoid surface centred at the origin (group "body")."""
    gmsh = _session()
    try:
        gmsh.model.add("ellipsoid")
        occ = gmsh.model.occ
        occ.addSphere(0, 0, 0, 1.0)
        occ.synchronize()
        surfaces = [tag for _, tag in gmsh.model.getEntities(2)]
        _group(gmsh, 2, surfaces, "body")
        scale = np.asarray(semi_axes, dtype=float)
        # mesh the unit sphere with cells of the ellipsoid's mean size, then stretch it
        h = 2.0 * size / float(np.cbrt(np.prod(scale)))  # (halved by the subdivision)
        gmsh.option.setNumber("Mesh.MeshSizeMax", h)
        gmsh.option.setNumber("Mesh.MeshSizeMin", h)
        gmsh.option.setNumber("Mesh.RecombineAll", 1)
        gmsh.option.setNumber("Mesh.SubdivisionAlgorithm", 1)  # all quadrilaterals
        gmsh.model.mesh.generate(2)
        gmsh.model.mesh.setOrder(2)
        tags, xyz, _ = gmsh.model.mesh.getNodes()
        for tag, x in zip(tags, xyz.reshape(-1, 3) * scale):
            gmsh.model.mesh.setNode(int(tag), list(x), [])
        gmsh.write(str(path))
    finally:
        gmsh.finalize()


def write_sphere_pair(path, distance: float, size: float = 0.5):
    """Two unit spheres whose centres are ``distance`` apart on X, at ±distance/2
    (one group "body": two pieces of one mesh)."""
    gmsh = _session()
    try:
        gmsh.model.add("pair")
        occ = gmsh.model.occ
        for x in (-0.5 * distance, 0.5 * distance):
            occ.addSphere(x, 0, 0, 1.0)
        occ.synchronize()
        _group(gmsh, 2, [tag for _, tag in gmsh.model.getEntities(2)], "body")
        gmsh.option.setNumber("Mesh.MeshSizeMax", 2.0 * size)  # (halved by the subdivision)
        gmsh.option.setNumber("Mesh.MeshSizeMin", 2.0 * size)
        gmsh.option.setNumber("Mesh.RecombineAll", 1)
        gmsh.option.setNumber("Mesh.SubdivisionAlgorithm", 1)  # all quadrilaterals
        gmsh.model.mesh.generate(2)
        gmsh.model.mesh.setOrder(2)
        gmsh.write(str(path))
    finally:
        gmsh.finalize()


SWIMMING_SHEET = """title = "a short swimming sheet in Stokes flow"
[mesh]
kind = "strip"
length = 10.0
width = 2.0
divisions = [10, 2]
[shell]
thickness = 0.1
E = 100.0
nu = 0.3
density = 1.0e-8
axis = [1.0, 0.0, 0.0]
[fluid]
model = "stokes"
viscosity = 1.0e-9
[time]
scheme = "generalized-alpha"
rho_inf = 0.9
end = 0.15707963267948966
dt = 0.003926990816987242
[[motion]]
where = "all"
component = "uz"
kind = "travelling-wave"
amplitude = 0.15
wavenumber = 0.6283185307179586
angular_frequency = 100.0
ramp_time = 0.031415926535897934
[[output.probes]]
name = "front"
at = [10.0, 0.0, 0.0]
"""


def swimming_sheet_scene(folder) -> "Path":
    """A 10 × 2 sheet (one wavelength) swimming by a travelling wave in Stokes flow,
    generalized-α with inertia: 40 steps of a sixteenth of the period (2.5 periods)."""
    from pathlib import Path

    path = Path(folder) / "stokes_sheet.toml"
    path.write_text(SWIMMING_SHEET, encoding="utf-8")
    return path
