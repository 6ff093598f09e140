"""Curved shells on gmsh meshes of second-order geometry, as quarters with planes
of symmetry, against exact and published values (tests/data/obstacle_course.md):
a cylinder under internal pressure (membrane), a pinched ring (bending) and the
Scordelis–Lo roof (both), the pinched cylinder and the pinched hemisphere with
its 18° hole, all in the linear range."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from conftest import fields_at, run_scene, write_scene


def _gmsh():
    import gmsh

    gmsh.initialize(readConfigFiles=False)
    gmsh.option.setNumber("General.Terminal", 0)
    return gmsh


def _name_mesh_write(gmsh, groups, path: Path) -> None:
    """Name the (dim, tag, name) groups, mesh with 9-node quadrilaterals, write."""
    for dim, tag, name in groups:
        gmsh.model.setPhysicalName(dim, gmsh.model.addPhysicalGroup(dim, [tag]), name)
    gmsh.model.mesh.generate(2)
    gmsh.model.mesh.setOrder(2)
    gmsh.write(str(path))


def quarter_cylinder(path: Path, radius: float, height: float, n: int) -> Path:
    """x² + z² = R², x, z ≥ 0, 0 ≤ y ≤ H, n × n 9-node quadrilaterals; curves named
    "sym_x" (in the plane x = 0), "sym_z" (z = 0), "bottom" (y = 0), "top"."""
    gmsh = _gmsh()
    try:
        geo = gmsh.model.geo
        centre = geo.addPoint(0, 0, 0)
        arc = geo.addCircleArc(geo.addPoint(radius, 0, 0), centre, geo.addPoint(0, 0, radius))
        out = geo.extrude([(1, arc)], 0, height, 0, numElements=[n], recombine=True)
        geo.synchronize()
        gmsh.model.mesh.setTransfiniteCurve(arc, n + 1)
        groups = (
            (2, out[1][1], "shell"),
            (1, abs(out[2][1]), "sym_x"),
            (1, abs(out[3][1]), "sym_z"),
            (1, arc, "bottom"),
            (1, out[0][1], "top"),
        )
        _name_mesh_write(gmsh, groups, path)
    finally:
        gmsh.finalize()
    return path


def quarter_hemisphere(
    path: Path, radius: float, hole_deg: float, n: int, points: dict | None = None
) -> Path:
    """A quarter of a hemisphere (x, y ≥ 0, z ≥ 0) with a hole of hole_deg about the
    pole; curves "sym_x" (x = 0), "sym_y" (y = 0), "equator", "hole", and the point
    "pin" where the hole meets y = 0 (to hold the rigid motion along z that the two
    planes leave free), and any further named ``points`` (name -> coordinates); n × n
    9-node quadrilaterals."""
    gmsh = _gmsh()
    try:
        geo = gmsh.model.geo
        h = math.radians(hole_deg)
        o = geo.addPoint(0, 0, 0)
        ex, ey = geo.addPoint(radius, 0, 0), geo.addPoint(0, radius, 0)
        hx = geo.addPoint(radius * math.sin(h), 0, radius * math.cos(h))
        hy = geo.addPoint(0, radius * math.sin(h), radius * math.cos(h))
        equator = geo.addCircleArc(ex, o, ey)
        sym_y, sym_x = geo.addCircleArc(ex, o, hx), geo.addCircleArc(ey, o, hy)
        hole = geo.addCircleArc(hx, geo.addPoint(0, 0, radius * math.cos(h)), hy)
        surface = geo.addSurfaceFilling(
            [geo.addCurveLoop([equator, sym_x, -hole, -sym_y])], sphereCenterTag=o
        )
        extra = tuple((0, geo.addPoint(*xyz), name) for name, xyz in (points or {}).items())
        geo.synchronize()
        for curve in (equator, sym_x, hole, sym_y):
            gmsh.model.mesh.setTransfiniteCurve(curve, n + 1)
        gmsh.model.mesh.setTransfiniteSurface(surface)
        gmsh.model.mesh.setRecombine(2, surface)
        groups = (
            (2, surface, "shell"),
            (1, sym_x, "sym_x"),
            (1, sym_y, "sym_y"),
            (1, equator, "equator"),
            (1, hole, "hole"),
            (0, hx, "pin"),
        )
        groups += extra
        _name_mesh_write(gmsh, groups, path)
    finally:
        gmsh.finalize()
    return path


def quarter_roof(path: Path, radius: float, half_length: float, angle_deg: float, n: int) -> Path:
    """The Scordelis–Lo roof's quarter: axis X, 0 ≤ x ≤ half_length, from the crown
    (y = 0, z = R) to the free edge at angle_deg; curves "sym_x" (x = 0), "crown"
    (y = 0), "diaphragm" (x = half_length), "free_edge"; n × n 9-node quads."""
    gmsh = _gmsh()
    try:
        geo = gmsh.model.geo
        a = math.radians(angle_deg)
        arcs, crowns, edges = [], [], []
        for x in (0.0, half_length):
            centre = geo.addPoint(x, 0, 0)
            crowns.append(geo.addPoint(x, 0, radius))
            edges.append(geo.addPoint(x, radius * math.sin(a), radius * math.cos(a)))
            arcs.append(geo.addCircleArc(crowns[-1], centre, edges[-1]))
        crown = geo.addLine(crowns[0], crowns[1])
        free = geo.addLine(edges[0], edges[1])
        surface = geo.addSurfaceFilling([geo.addCurveLoop([crown, arcs[1], -free, -arcs[0]])])
        geo.synchronize()
        for curve in (*arcs, crown, free):
            gmsh.model.mesh.setTransfiniteCurve(curve, n + 1)
        gmsh.model.mesh.setTransfiniteSurface(surface)
        gmsh.model.mesh.setRecombine(2, surface)
        groups = (
            (2, surface, "roof"),
            (1, arcs[0], "sym_x"),
            (1, arcs[1], "diaphragm"),
            (1, crown, "crown"),
            (1, free, "free_edge"),
        )
        _name_mesh_write(gmsh, groups, path)
    finally:
        gmsh.finalize()
    return path


CYLINDER = """
title = "{title}"
[mesh]
kind = "gmsh"
file = "cylinder.msh"
[shell]
thickness = {t}
E = {E}
nu = 0.0
axis = [0.0, 1.0, 0.0]
[time]
end = 1.0
dt = 1.0
[[boundary]]
where = "sym_x"
symmetry = [1.0, 0.0, 0.0]
[[boundary]]
where = "sym_z"
symmetry = [0.0, 0.0, 1.0]
[[boundary]]
where = "bottom"
fix = ["uy"]
{load}
[[output.probes]]
name = "crown"
at = [0.0, {half_height}, {R}]
[[output.probes]]
name = "side"
at = [{R}, {half_height}, 0.0]
"""
R, H, T, E = 2.0, 3.0, 0.02, 1.0e5


@pytest.fixture(scope="module")
def cylinder_mesh(tmp_path_factory):
    return quarter_cylinder(tmp_path_factory.mktemp("cyl") / "cylinder.msh", R, H, 8)


def _cylinder(tmp_path, mesh, title, load):
    scene = write_scene(
        tmp_path, CYLINDER.format(title=title, t=T, E=E, R=R, half_height=H / 2, load=load)
    )
    (tmp_path / "cylinder.msh").write_bytes(mesh.read_bytes())
    return run_scene(scene).history[-1][1]


def test_cylinder_under_internal_pressure(tmp_path, cylinder_mesh):
    """Radial displacement p R²/(E t) everywhere, within 1e-4 (the Green strain's
    quadratic part is 1e-6 of it; reached 1.5e-5)."""
    p = 1.0e-3
    u = _cylinder(
        tmp_path,
        cylinder_mesh,
        "cylinder under pressure",
        f'[[load]]\nkind = "pressure"\nvalue = {-p}',
    )
    exact = p * R**2 / (E * T)
    radial = np.array([u[0, 2], u[1, 0]])
    print(f"radial displacement {radial}, p R²/(E t) = {exact:.6e}")
    assert np.allclose(np.abs(radial), exact, rtol=1e-4, atol=0)


def test_pinched_ring(tmp_path, cylinder_mesh):
    """The cylinder as a ring of width H pinched by line loads P at the crown and its
    opposite: the crown moves (π/4 − 2/π) P R³/(2EI) in and the side (2/π − ½) P R³/(2EI)
    out, within 1 % (reached 0.17 % and 0.17 %)."""
    P = 1.0e-4
    u = _cylinder(
        tmp_path,
        cylinder_mesh,
        "pinched ring",
        f'[[load]]\nkind = "edge-force"\nwhere = "sym_x"\n'
        f'value = [0.0, 0.0, {-P / 2}]\nramp = "constant"',
    )
    EI = E * H * T**3 / 12
    crown = -(math.pi / 4 - 2 / math.pi) * P * R**3 / (2 * EI)
    side = (2 / math.pi - 0.5) * P * R**3 / (2 * EI)
    print(f"crown {u[0, 2]:.6e} (exact {crown:.6e}), side {u[1, 0]:.6e} (exact {side:.6e})")
    assert abs(u[0, 2] / crown - 1) < 0.01 and abs(u[1, 0] / side - 1) < 0.01


#: a roof or cylinder quarter from quarter_roof: rigid diaphragm, the planes x = 0, y = 0
ROOF_SUPPORTS = """[[boundary]]
where = "diaphragm"
fix = ["uy", "uz"]
[[boundary]]
where = "sym_x"
symmetry = [1.0, 0.0, 0.0]
[[boundary]]
where = "crown"
symmetry = [0.0, 1.0, 0.0]
"""


def test_scordelis_lo_roof(tmp_path):
    """Vertical displacement at the middle of the free edge, 0.3024 per unit of the
    self weight 90 (Belytschko et al. 1985; tests/data/obstacle_course.md), within
    2 % on 16 × 16 9-node quadrilaterals of the quarter, at 1/1000 of the weight (the
    linear range; reached −0.16 %)."""
    radius, half_length, angle, n = 25.0, 25.0, 40.0, 16
    quarter_roof(tmp_path / "roof.msh", radius, half_length, angle, n)
    a = math.radians(angle)
    scale = 1.0e-3
    thickness, weight = 0.25, 90.0
    scene = write_scene(
        tmp_path,
        f"""
title = "Scordelis-Lo roof, a quarter"
[mesh]
kind = "gmsh"
file = "roof.msh"
[shell]
thickness = {thickness}
E = 4.32e8
nu = 0.0
density = {weight / thickness}
axis = [1.0, 0.0, 0.0]
[time]
scheme = "static"
end = 1.0
dt = 1.0
{ROOF_SUPPORTS}[[load]]
kind = "gravity"
value = [0.0, 0.0, {-scale}]
[[output.probes]]
name = "midside"
at = [0.0, {radius * math.sin(a)!r}, {radius * math.cos(a)!r}]
""",
    )
    w = -run_scene(scene).history[-1][1][0, 2] / scale
    print(
        f"Scordelis-Lo midside deflection {w:.5f} (reference 0.3024, "
        f"{100 * (w / 0.3024 - 1):+.2f} %)"
    )
    assert abs(w / 0.3024 - 1) < 0.02


def test_pinched_cylinder(tmp_path):
    """MacNeal & Harder's pinched cylinder (R = 300, L = 600 between rigid diaphragms,
    t = 3, E = 3e6, ν = 0.3, two opposite loads P = 1) as an octant with three planes
    of symmetry: the displacement under the load is 1.8248e-5 within 2 % on 8 × 8
    (reached −0.41 %). A point load is singular on a Reissner–Mindlin shell: the
    value creeps up with refinement (+1.2 % on 16 × 16)."""
    quarter_roof(tmp_path / "octant.msh", 300.0, 300.0, 90.0, 8)
    scene = write_scene(
        tmp_path,
        f"""
title = "pinched cylinder, an octant"
[mesh]
kind = "gmsh"
file = "octant.msh"
[shell]
thickness = 3.0
E = 3.0e6
nu = 0.3
axis = [1.0, 0.0, 0.0]
[time]
end = 1.0
dt = 1.0
{ROOF_SUPPORTS}[[boundary]]
where = "free_edge"
symmetry = [0.0, 0.0, 1.0]
[[load]]
kind = "point-force"
at = [0.0, 0.0, 300.0]
value = [0.0, 0.0, -0.25]
[[output.probes]]
name = "load"
at = [0.0, 0.0, 300.0]
""",
    )
    w = -run_scene(scene).history[-1][1][0, 2]
    print(
        f"pinched cylinder: {w:.5e} under the load (reference 1.8248e-5, "
        f"{100 * (w / 1.8248e-5 - 1):+.2f} %)"
    )
    assert abs(w / 1.8248e-5 - 1) < 0.02


#: the quarter hemisphere (quarter_hemisphere) under its two point loads, half a load
#: F / 2 at each load point; "out" is pulled outward along X, "in" pushed inward along Y
#: the quarter hemisphere's body, material and planes of symmetry
HEMISPHERE_QUARTER = """
title = "pinched hemisphere with an 18 degree hole, a quarter"
[mesh]
kind = "gmsh"
file = "hemisphere.msh"
[shell]
thickness = 0.04
E = 6.825e7
nu = 0.3
axis = [0.0, 0.0, 1.0]
{solver}[time]
scheme = "static"
end = 1.0
dt = {dt}
[[boundary]]
where = "sym_x"
symmetry = [1.0, 0.0, 0.0]
[[boundary]]
where = "sym_y"
symmetry = [0.0, 1.0, 0.0]
"""
HEMISPHERE = (
    HEMISPHERE_QUARTER
    + """[[boundary]]
where = "pin"
fix = ["uz"]
[[load]]
kind = "point-force"
at = [10.0, 0.0, 0.0]
value = [{half}, 0.0, 0.0]
[[load]]
kind = "point-force"
at = [0.0, 10.0, 0.0]
value = [0.0, {minus_half}, 0.0]
[[output.probes]]
name = "out"
at = [10.0, 0.0, 0.0]
[[output.probes]]
name = "in"
at = [0.0, 10.0, 0.0]
"""
)


def _hemisphere(tmp_path, n, load, dt=1.0, atol=None, out_dir=None):
    """Displacements (outward at "out", inward at "in") at every output time; the
    scene's snes_atol is ``atol`` if given (the default otherwise)."""
    quarter_hemisphere(tmp_path / "hemisphere.msh", 10.0, 18.0, n)
    solver = f"[solver]\nsnes_atol = {atol}\n" if atol is not None else ""
    scene = write_scene(
        tmp_path, HEMISPHERE.format(half=load / 2, minus_half=-load / 2, dt=dt, solver=solver)
    )
    sim = run_scene(scene, out_dir=out_dir)
    return sim, {t: (u[0, 0], -u[1, 1]) for t, u in sim.history}


def test_pinched_hemisphere_with_a_hole(tmp_path):
    """MacNeal & Harder's hemisphere (R = 10, t = 0.04, E = 6.825e7, ν = 0.3, an 18°
    hole at the pole, alternating loads 2 out and in at 90° on the equator) as a
    quarter with two planes of symmetry (half a load, 1, at each load point) and u_z
    held at one point (the rigid motion the planes leave free): under the loads of 2
    a load point moves 0.094 along its load; within 2 % on 8 × 8, run at 1/1000 of
    the loads (reached −0.26 %, both points alike). The default Newton tolerance,
    1e-10 of the bending force, is below this stiff membrane's round-off floor
    (residuals stall at 5e-9), so the scene sets snes_atol to 1e-5 of the load."""
    scale = 1.0e-3
    _, rows = _hemisphere(tmp_path, 8, 2.0 * scale, atol=1.0e-5 * scale)
    along = np.array(rows[1.0]) / scale  # scaled back to the loads of 2
    print(
        f"pinched hemisphere: {along} under the loads of 2 (reference 0.094, "
        f"{100 * (along.mean() / 0.094 - 1):+.2f} %)"
    )
    assert np.all(np.abs(along / 0.094 - 1) < 0.02)


#: Sze, Liu & Lo (2004), problem 3.4, at P/Pmax: (outward, inward) displacement of the
#: load points, Pmax = 400 (tests/data/obstacle_course.md)
SZE_HEMISPHERE = {0.5: (3.406, 5.902), 1.0: (4.067, 8.178)}


def test_hemisphere_large_deflection_matches_sze(tmp_path):
    """Sze 3.4: the same hemisphere under loads up to Pmax = 400, where the inward
    point moves 8.2, 0.8 of the radius (the linear answer would be 18.8). Within 2 %
    at P/Pmax = 0.5 and 1 on 16 × 16 9-node quadrilaterals of the quarter, in eight
    static load steps at the default tolerances (reached +0.01 % and −0.67 % at 0.5,
    +0.04 % and −0.57 % at 1; 8 × 8 gives −1.6 % and −1.9 % inward)."""
    sim, rows = _hemisphere(tmp_path, 16, 400.0, dt=0.125, out_dir=tmp_path / "out")
    assert sim.summary["status"] == "ok"
    for p, ref in SZE_HEMISPHERE.items():
        got = np.array(rows[p])
        err = got / np.array(ref) - 1
        print(
            f"P/Pmax = {p}: outward {got[0]:.4f} ({ref[0]}), inward {got[1]:.4f} "
            f"({ref[1]}); errors {100 * err[0]:+.2f} %, {100 * err[1]:+.2f} %"
        )
        assert np.all(np.abs(err) < 0.02), f"P/Pmax = {p}: {got}, reference {ref}"
    # a curved mesh's fields are written on its nine nodes per cell, as the probes saw
    distance, written = fields_at(tmp_path / "out", [0.0, 10.0, 0.0])
    assert distance < 1e-12 and len(written) == len(sim.history)
    assert np.allclose(-written[:, 2], [rows[t][1] for t in sorted(rows)], rtol=1e-6, atol=1e-6)


@pytest.mark.parametrize(
    "entry, words",
    [
        (
            '[[boundary]]\nwhere = "pin"\nsymmetry = [0.0, 1.0, 0.0]',
            "boundary.2.where: 'pin' is a point; a plane of symmetry is an edge",
        ),
        (
            '[[load]]\nkind = "pressure"\nwhere = "pin"\nvalue = 1.0',
            "load.0.where: 'pin' is a point; a pressure acts on a surface",
        ),
        (
            '[[load]]\nkind = "edge-force"\nwhere = "pin"\nvalue = [1.0, 0.0, 0.0]',
            "load.0.where: 'pin' is a point; this needs an edge",
        ),
        ("", "mesh.file: physical point 'stray' is not on the body's surface"),
    ],
)
def test_a_point_selector_only_where_a_point_fits(tmp_path, entry, words):
    """A named gmsh point holds degrees of freedom at vertices; where an edge or a
    surface is needed, or off the body (a free node in the file, which would crash
    dolfinx's reader), the run refuses in one line."""
    from rftfem.errors import SceneError

    points = {"stray": (20.0, 0.0, 0.0)} if not entry else {}
    quarter_hemisphere(tmp_path / "hemisphere.msh", 10.0, 18.0, 2, points=points)
    scene = write_scene(tmp_path, HEMISPHERE_QUARTER.format(solver="", dt=1.0) + entry + "\n")
    with pytest.raises(SceneError, match=words.replace("[", r"\[")):
        run_scene(scene)
