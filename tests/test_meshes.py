"""Meshes: strips, three-link bodies and gmsh files as Bodies (areas, tags, names, hinge
lines, orientation, errors, MPI)."""

from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
import sys
from pathlib import Path

import dolfinx.fem  # noqa: E402
import numpy as np
import pytest
import ufl  # noqa: E402
from mpi4py import MPI  # noqa: E402

from rftfem import compat  # noqa: F401  (imports dolfinx the right way first)
from rftfem.errors import SceneError  # noqa: E402
from rftfem.meshes import Body, build_body, build_strip, build_three_link, read_gmsh  # noqa: E402
from rftfem.meshes.strip import share_divisions  # noqa: E402

COMM = MPI.COMM_WORLD
DATA = Path(__file__).parent / "data"


# --- helpers -------------------------------------------------------------------


def _sum(value, comm=COMM):
    return comm.allreduce(value, op=MPI.SUM)


def cell_values(mesh, expr):
    """``∫_cell expr dx`` for every owned cell (one DG0 vector assembly)."""
    V = compat.function_space(mesh, "DG", 0)
    v = ufl.TestFunction(V)
    b = dolfinx.fem.assemble_vector(compat.form(expr * v * ufl.dx))
    return np.asarray(b.array)[: mesh.topology.index_map(mesh.topology.dim).size_local].copy()


def owned_tags(body: Body):
    """Cell tag of every owned cell (0 if untagged)."""
    n = body.mesh.topology.index_map(2).size_local
    tags = np.zeros(n, dtype=np.int64)
    keep = body.cell_tags.indices < n
    tags[body.cell_tags.indices[keep]] = body.cell_tags.values[keep]
    return tags


def areas(body: Body):
    """Global total area and area of each named region."""
    one = dolfinx.fem.Constant(body.mesh, 1.0)
    per_cell = cell_values(body.mesh, one)
    tags = owned_tags(body)
    comm = body.mesh.comm
    total = _sum(float(per_cell.sum()), comm)
    regions = {
        name: _sum(float(per_cell[np.isin(tags, ids)].sum()), comm)
        for name, ids in body.regions.items()
    }
    return total, regions


def edge_lengths(body: Body):
    ds = ufl.Measure("ds", domain=body.mesh, subdomain_data=body.facet_tags)
    one = dolfinx.fem.Constant(body.mesh, 1.0)
    return {
        name: _sum(dolfinx.fem.assemble_scalar(compat.form(one * ds(tuple(ids)))), body.mesh.comm)
        for name, ids in body.edges.items()
    }


def line_integrals(body: Body, names):
    """Per name ``name: (k, c)`` of a tagged line ``x_k = c``: its length as
    interior facets (dS), as exterior facets (ds), and ∫ (x_k − c)² over both
    (0 when every tagged facet lies on the line)."""
    mesh, ft = body.mesh, body.facet_tags
    dS = ufl.Measure("dS", domain=mesh, subdomain_data=ft)
    ds = ufl.Measure("ds", domain=mesh, subdomain_data=ft)
    one = dolfinx.fem.Constant(mesh, 1.0)
    x = ufl.SpatialCoordinate(mesh)

    def total(expr):
        return _sum(dolfinx.fem.assemble_scalar(compat.form(expr)), mesh.comm)

    out = {}
    for name, (k, c) in names.items():
        ids = tuple(body.edges[name])
        off = (x[k] - c) ** 2
        out[name] = [
            total(one("+") * dS(ids)),
            total(one * ds(ids)),
            total(off("+") * dS(ids) + off * ds(ids)),
        ]
    return out


def facet_cell_counts(body: Body, name):
    """Number of (local, ghosts included) cells of each owned facet tagged ``name``."""
    mesh, ft = body.mesh, body.facet_tags
    mesh.topology.create_connectivity(1, 2)
    f2c = mesh.topology.connectivity(1, 2)
    owned = ft.indices < mesh.topology.index_map(1).size_local
    facets = ft.indices[owned & np.isin(ft.values, body.edges[name])]
    return [len(f2c.links(f)) for f in facets]


def tag_counts(body: Body, ntags: int):
    """Global number of cells with each tag 1..ntags."""
    tags = owned_tags(body)
    return [_sum(int((tags == t).sum())) for t in range(1, ntags + 1)]


def normal_z(mesh):
    """Per owned cell: ∫ (G1×G2)_z/|G1×G2| dx and the cell area."""
    J = ufl.Jacobian(mesh)
    n = ufl.cross(J[:, 0], J[:, 1])
    nz = cell_values(mesh, n[2] / ufl.sqrt(ufl.dot(n, n)))
    area = cell_values(mesh, dolfinx.fem.Constant(mesh, 1.0))
    return nz, area


def num_cells(body: Body) -> int:
    return body.mesh.topology.index_map(2).size_global


def write_quarter_cylinder(
    path,
    radius=2.0,
    height=3.0,
    order=1,
    quads=True,
    physical=True,
    named=True,
    extra_surface=False,
):
    """A quarter of a cylinder of axis Y: x² + z² = R², x, z ≥ 0, 0 ≤ y ≤ H.

    Named groups: surface "shell" (tag 5), curves "bottom" (y = 0, tag 11) and
    "top" (y = H, tag 12). ``extra_surface`` adds a unit square at x ∈ [5, 6]
    that is in no physical group (saved with Mesh.SaveAll).
    """
    import gmsh

    gmsh.initialize(readConfigFiles=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("quarter-cylinder")
        geo = gmsh.model.geo
        centre = geo.addPoint(0, 0, 0)
        arc = geo.addCircleArc(geo.addPoint(radius, 0, 0), centre, geo.addPoint(0, 0, radius))
        out = geo.extrude([(1, arc)], 0, height, 0, numElements=[4], recombine=quads)
        top, surface = out[0][1], out[1][1]
        if extra_surface:
            p = [geo.addPoint(x, y, 0) for x, y in ((5, 0), (6, 0), (6, 1), (5, 1))]
            lines = [geo.addLine(p[i], p[(i + 1) % 4]) for i in range(4)]
            geo.addPlaneSurface([geo.addCurveLoop(lines)])
        geo.synchronize()
        gmsh.model.mesh.setTransfiniteCurve(arc, 9)
        if physical:
            gmsh.model.addPhysicalGroup(2, [surface], 5)
            gmsh.model.addPhysicalGroup(1, [arc], 11)
            gmsh.model.addPhysicalGroup(1, [top], 12)
            if named:
                gmsh.model.setPhysicalName(2, 5, "shell")
                gmsh.model.setPhysicalName(1, 11, "bottom")
                gmsh.model.setPhysicalName(1, 12, "top")
        gmsh.model.mesh.generate(2)
        if order > 1:
            gmsh.model.mesh.setOrder(order)
        gmsh.option.setNumber("Mesh.SaveAll", 1 if extra_surface else 0)
        gmsh.write(str(path))
    finally:
        gmsh.finalize()
    return path


@pytest.fixture(scope="module")
def msh_dir(tmp_path_factory):
    d = tmp_path_factory.mktemp("msh")
    write_quarter_cylinder(d / "qc_q1.msh")
    write_quarter_cylinder(d / "qc_q2.msh", order=2)
    write_quarter_cylinder(d / "qc_t2.msh", order=2, quads=False)
    write_quarter_cylinder(d / "qc_extra.msh", extra_surface=True)
    write_quarter_cylinder(d / "qc_unnamed.msh", named=False)
    write_quarter_cylinder(d / "qc_nogroups.msh", physical=False)
    (d / "garbage.msh").write_text("this is not\na mesh file\n")
    (d / "empty.msh").write_text("")
    (d / "plate.geo").write_text("Point(1) = {0, 0, 0};\n")
    return d


# --- division sharing ----------------------------------------------------------


def test_share_divisions():
    assert share_divisions([1.0, 9.0], 16) == [2, 14]  # 1.6 -> 2, 14.4 -> 14
    assert share_divisions([10.0], 7) == [7]
    assert share_divisions([1.0, 1.0, 1.0], 2) == [1, 1, 1]  # fewer than segments
    assert share_divisions([0.01, 10.0, 0.01], 10) == [1, 8, 1]  # at least one each
    for lengths, nx in (([1, 2, 3, 4], 13), ([0.3, 0.3, 9.4], 5), ([2.5, 2.5, 5], 3)):
        n = share_divisions(lengths, nx)
        assert sum(n) == nx and min(n) >= 1


# --- strips --------------------------------------------------------------------


@pytest.mark.parametrize("cell, per_rect", [("quadrilateral", 1), ("triangle", 2)])
def test_strip_area_cells_edges_orientation(cell, per_rect):
    L, W, nx, ny = 10.0, 2.0, 16, 2
    body = build_strip(COMM, L, W, [nx, ny], cell, regions=[("end1", (0.0, 1.0))])
    mesh = body.mesh
    assert (mesh.topology.dim, mesh.geometry.dim) == (2, 3)
    assert (body.length, body.width) == (L, W)
    assert num_cells(body) == per_rect * nx * ny

    total, regions = areas(body)
    assert total == pytest.approx(L * W, rel=1e-12)
    # rounding case: [0, 1] of 10 gets round(1.6) = 2 of the 16 divisions
    assert regions == {"end1": pytest.approx(1.0 * W, rel=1e-12)}
    tags = owned_tags(body)
    assert _sum(int(np.isin(tags, body.regions["end1"]).sum())) == per_rect * 2 * ny
    assert tags.min(initial=1) >= 1  # every cell tagged with a positive int

    assert set(body.edges) == {"x=0", "x=L", "y=0", "y=W"}
    lengths = edge_lengths(body)
    assert lengths["x=0"] == pytest.approx(W) and lengths["x=L"] == pytest.approx(W)
    assert lengths["y=0"] == pytest.approx(L) and lengths["y=W"] == pytest.approx(L)

    nz, area = normal_z(mesh)  # every cell: G1 × G2 along +Z
    assert np.allclose(nz, area, rtol=1e-12, atol=0.0)
    assert np.all(area > 0)
    assert np.allclose(mesh.geometry.x[:, 2], 0.0)


def test_strip_overlapping_regions_and_segment_tags():
    regions = [("a", (0.0, 6.0)), ("b", (4.0, 10.0)), ("tip", (9.5, 10.0))]
    body = build_strip(COMM, 10.0, 1.0, [20, 1], "quadrilateral", regions)
    # segments [0,4] [4,6] [6,9.5] [9.5,10] -> tags 1..4, 8/4/7/1 divisions
    assert body.regions == {"a": [1, 2], "b": [2, 3, 4], "tip": [4]}
    total, region_areas = areas(body)
    assert total == pytest.approx(10.0)
    assert region_areas == pytest.approx({"a": 6.0, "b": 6.0, "tip": 0.5})
    tags = owned_tags(body)
    counts = [_sum(int((tags == t).sum())) for t in (1, 2, 3, 4)]
    assert counts == [8, 4, 7, 1]


def test_strip_graded_towards_its_edges():
    """``mesh.grading = 4``: along each segment between cuts the cells shrink towards
    both ends (sizes ∝ 1 − g cos 2πs, g = 0.6: 10 cells from 0.439 to 1.561, a discrete
    ratio 3.56), symmetric, the cuts and the regions' areas exact; 1 is uniform; a
    gmsh mesh refuses it.  Broke: g with the other sign (cells largest at the edges)."""
    body = build_strip(COMM, 10.0, 1.0, [10, 4], "quadrilateral", grading=4.0)
    x = np.unique(np.round(np.concatenate(COMM.allgather(body.mesh.geometry.x[:, 0])), 9))
    sizes = np.diff(x)  # the vertices' columns (geometry of degree 1)
    assert len(sizes) == 10
    assert sizes[0] == pytest.approx(10 * (0.1 - 0.6 * math.sin(0.2 * math.pi) / (2 * math.pi)))
    assert sizes == pytest.approx(sizes[::-1]) and sizes.max() / sizes.min() > 3.5
    assert np.all(np.diff(sizes[:5]) > 0)
    regions = [("a", (0.0, 6.0))]
    graded = build_strip(COMM, 10.0, 1.0, [20, 2], "quadrilateral", regions, grading=3.0)
    total, region_areas = areas(graded)
    assert total == pytest.approx(10.0) and region_areas == pytest.approx({"a": 6.0})
    with pytest.raises(SceneError, match=r'^mesh.grading: for kind = "strip" or "three-link"'):
        build_body(COMM, {"kind": "gmsh", "file": "x.msh", "grading": 2.0}, None)


def test_strip_without_regions_and_coarse_division():
    body = build_strip(
        COMM, 3.0, 0.5, [1, 1], "triangle", regions=[("r", (1.0, 2.0))]
    )  # nx < segments: one each
    assert num_cells(body) == 2 * 3
    total, region_areas = areas(body)
    assert total == pytest.approx(1.5) and region_areas["r"] == pytest.approx(0.5)
    plain = build_strip(COMM, 3.0, 0.5, [3, 1])
    assert plain.regions == {} and num_cells(plain) == 3
    assert set(np.unique(owned_tags(plain))) <= {1}


@pytest.mark.parametrize("cell, per_rect", [("quadrilateral", 1), ("triangle", 2)])
def test_strip_grid_x_and_y_bands(cell, per_rect):
    regions = [
        ("end", (0.0, 1.0), None),
        ("side", None, (0.0, 0.5)),
        ("patch", (2.0, 4.0), (0.5, 1.5)),
    ]
    body = build_strip(COMM, 6.0, 2.0, [12, 4], cell, regions)
    # X cuts 0 1 2 4 6 -> 2/2/4/4 divisions; Y cuts 0 0.5 1.5 2 -> 1/2/1; tag j*4 + i + 1
    assert body.regions == {"end": [1, 5, 9], "side": [1, 2, 3, 4], "patch": [7]}
    assert body.hinges == [] and set(body.edges) == {"x=0", "x=L", "y=0", "y=W"}
    assert num_cells(body) == per_rect * 12 * 4
    nxs, nys = [2, 2, 4, 4], [1, 2, 1]
    assert tag_counts(body, 12) == [per_rect * n * m for m in nys for n in nxs]
    total, region_areas = areas(body)
    assert total == pytest.approx(12.0, rel=1e-12)
    assert region_areas == pytest.approx({"end": 2.0, "side": 3.0, "patch": 2.0}, rel=1e-12)
    lengths = edge_lengths(body)
    assert lengths == pytest.approx({"x=0": 2.0, "x=L": 2.0, "y=0": 6.0, "y=W": 6.0})
    nz, area = normal_z(body.mesh)
    assert np.allclose(nz, area, rtol=1e-12, atol=0.0)


@pytest.mark.parametrize("cell, per_rect", [("quadrilateral", 1), ("triangle", 2)])
def test_strip_hinge_lines_cut_and_named(cell, per_rect):
    L, W = 5.0, 1.0
    body = build_strip(
        COMM, L, W, [10, 3], cell, regions=[("tip", (4.0, 5.0))], hinges=["x=1.7", "y=0.5"]
    )
    assert body.edges == {
        "x=0": [1],
        "x=L": [2],
        "y=0": [3],
        "y=W": [4],
        "x=1.7": [5],
        "y=0.5": [6],
    }
    assert body.hinges == []
    # X cuts 0 1.7 4 5 -> 3/5/2 of 10; Y cuts 0 0.5 1 -> 2/1 of 3 (tie to the lower)
    assert num_cells(body) == per_rect * 10 * 3
    assert tag_counts(body, 6) == [per_rect * n * m for m in (2, 1) for n in (3, 5, 2)]
    assert body.regions == {"tip": [3, 6]}
    lines = line_integrals(body, {"x=1.7": (0, 1.7), "y=0.5": (1, 0.5)})
    assert lines["x=1.7"] == pytest.approx([W, 0.0, 0.0], abs=1e-12)
    assert lines["y=0.5"] == pytest.approx([L, 0.0, 0.0], abs=1e-12)
    for name in ("x=1.7", "y=0.5"):
        counts = facet_cell_counts(body, name)
        assert _sum(len(counts)) > 0 and set(counts) <= {2}  # interior: a cell on each side
    assert set(facet_cell_counts(body, "x=0")) <= {1}
    sides = line_integrals(body, {"x=0": (0, 0.0), "x=L": (0, L), "y=0": (1, 0.0), "y=W": (1, W)})
    assert sides == {
        "x=0": pytest.approx([0.0, W, 0.0], abs=1e-12),
        "x=L": pytest.approx([0.0, W, 0.0], abs=1e-12),
        "y=0": pytest.approx([0.0, L, 0.0], abs=1e-12),
        "y=W": pytest.approx([0.0, L, 0.0], abs=1e-12),
    }
    total, region_areas = areas(body)
    assert total == pytest.approx(L * W) and region_areas["tip"] == pytest.approx(1.0)


def test_strip_hinge_named_as_written_and_region_limit_merged():
    """The selector is the name; a region limit within 1e-9 L of the line is that line."""
    body = build_strip(
        COMM, 4.0, 1.0, [8, 2], regions=[("a", (0.0, 2.0 - 1e-12))], hinges=["x = 2.0"]
    )
    assert body.edges["x = 2.0"] == [5] and body.regions == {"a": [1]}
    assert tag_counts(body, 2) == [8, 8]
    lines = line_integrals(body, {"x = 2.0": (0, 2.0)})
    assert lines["x = 2.0"] == pytest.approx([1.0, 0.0, 0.0], abs=1e-12)


@pytest.mark.parametrize(
    "kwargs, key",
    [
        (dict(regions=[("r", (-1.0, 1.0))]), "mesh.regions.0.x"),
        (dict(regions=[("r", (2.0, 1.0))]), "mesh.regions.0.x"),
        (dict(regions=[("r", (0.0, 1.0)), ("r", (1.0, 2.0))]), "mesh.regions.1.name"),
        (dict(regions=[("x=0", (0.0, 1.0))]), "mesh.regions.0.name"),
        (dict(divisions=[0, 1]), "mesh.divisions"),
        (dict(divisions=[4.5, 1]), "mesh.divisions"),
        (dict(cell="hexahedron"), "mesh.cell"),
        (dict(length=-1.0), "mesh.length"),
        (dict(width=math.inf), "mesh.width"),
        (dict(regions=[("r", None, (-1.0, 0.5))]), "mesh.regions.0.y"),
        (dict(regions=[("r", None, (0.5, 0.5))]), "mesh.regions.0.y"),
        (dict(regions=[("r", (0.0, 1.0), (0.0, 2.0))]), "mesh.regions.0.y"),
        (dict(regions=[("r", None, ("a", 1.0))]), "mesh.regions.0.y"),
        (dict(regions=[("r", None, None)]), "mesh.regions.0"),
        (dict(regions=[("y=W", None, (0.0, 0.5))]), "mesh.regions.0.name"),
    ],
)
def test_strip_bad_arguments(kwargs, key):
    args = dict(length=10.0, width=1.0, divisions=[4, 1], cell="quadrilateral", regions=())
    args.update(kwargs)
    with pytest.raises(SceneError) as err:
        build_strip(COMM, **args)
    assert str(err.value).startswith(key + ":") and "\n" not in str(err.value)


BAD_HINGES = [  # on a strip [0, 5] x [0, 1]
    (["z=1"], "hinge.0.where", 'expected "x=c" or "y=c"'),
    (["x=abc"], "hinge.0.where", 'expected "x=c" or "y=c"'),
    (["x="], "hinge.0.where", 'expected "x=c" or "y=c"'),
    (["x=nan"], "hinge.0.where", 'expected "x=c" or "y=c"'),
    (["y=0.5", "x=inf"], "hinge.1.where", 'expected "x=c" or "y=c"'),
    ([2.5], "hinge.0.where", 'expected "x=c" or "y=c"'),
    ("x=1", "hinge", "expected a list"),
    (["x=7"], "hinge.0.where", "is not a line of the mesh: the body spans x in [0, 5]"),
    (["y=-0.5"], "hinge.0.where", "is not a line of the mesh: the body spans y in [0, 1]"),
    (["x=0"], "hinge.0.where", "lies on the body's boundary"),
    (["x=5"], "hinge.0.where", "lies on the body's boundary"),
    (["y=0.5", "y=1.0"], "hinge.1.where", "lies on the body's boundary"),
    (["y=1e-12"], "hinge.0.where", "lies on the body's boundary"),
    (
        ["x=1", "y=0.5", "x=1.0"],
        "hinge.2.where",
        "two hinges on one line: hinge.0.where and hinge.2.where",
    ),
    (
        ["y=0.5", "y=0.5000000000001"],
        "hinge.1.where",
        "two hinges on one line: hinge.0.where and hinge.1.where",
    ),
]


@pytest.mark.parametrize("hinges, key, words", BAD_HINGES)
def test_strip_bad_hinges(hinges, key, words):
    with pytest.raises(SceneError) as err:
        build_strip(COMM, 5.0, 1.0, [4, 2], hinges=hinges)
    message = str(err.value)
    assert message.startswith(key + ": ") and words in message and "\n" not in message


# --- three-link bodies ------------------------------------------------------------


@pytest.mark.parametrize("cell, per_rect", [("quadrilateral", 1), ("triangle", 2)])
def test_three_link_links_hinges_edges(cell, per_rect):
    L, w = 4.0, 0.5
    body = build_three_link(COMM, L, w, [8, 2], cell)
    assert (body.length, body.width) == (L, 3 * w)
    assert body.hinges == ["hinge-left", "hinge-right"]
    assert body.edges == {
        "x=0": [1],
        "x=L": [2],
        "y=0": [3],
        "y=W": [4],
        "hinge-left": [5],
        "hinge-right": [6],
    }
    assert body.regions == {"left": [1], "middle": [2], "right": [3]}
    assert num_cells(body) == per_rect * 8 * 3 * 2
    assert tag_counts(body, 3) == [per_rect * 8 * 2] * 3
    total, region_areas = areas(body)
    assert total == pytest.approx(3 * L * w, rel=1e-12)
    assert region_areas == pytest.approx(
        {"left": L * w, "middle": L * w, "right": L * w}, rel=1e-12
    )
    lengths = edge_lengths(body)
    assert lengths == pytest.approx(
        {"x=0": 3 * w, "x=L": 3 * w, "y=0": L, "y=W": L, "hinge-left": 0.0, "hinge-right": 0.0},
        abs=1e-12,
    )
    lines = line_integrals(
        body,
        {
            "hinge-left": (1, w),
            "hinge-right": (1, 2 * w),
            "y=0": (1, 0.0),
            "y=W": (1, 3 * w),
            "x=L": (0, L),
        },
    )
    assert lines == {
        "hinge-left": pytest.approx([L, 0.0, 0.0], abs=1e-12),
        "hinge-right": pytest.approx([L, 0.0, 0.0], abs=1e-12),
        "y=0": pytest.approx([0.0, L, 0.0], abs=1e-12),
        "y=W": pytest.approx([0.0, L, 0.0], abs=1e-12),
        "x=L": pytest.approx([0.0, 3 * w, 0.0], abs=1e-12),
    }
    for name in body.hinges:
        counts = facet_cell_counts(body, name)
        assert _sum(len(counts)) > 0 and set(counts) <= {2}
    nz, area = normal_z(body.mesh)
    assert np.allclose(nz, area, rtol=1e-12, atol=0.0)


def test_three_link_user_regions_and_hinges_share_link_divisions():
    L, w = 4.0, 0.5
    body = build_three_link(
        COMM,
        L,
        w,
        [8, 4],
        regions=[
            ("tip", (3.0, 4.0), None),
            ("stripe", None, (0.1, 0.4)),
            ("dot", (0.0, 1.0), (1.0, 1.2)),
        ],
        hinges=["y=1.2", "x=2"],
    )
    assert body.hinges == ["hinge-left", "hinge-right"]
    assert body.edges == {
        "x=0": [1],
        "x=L": [2],
        "y=0": [3],
        "y=W": [4],
        "hinge-left": [5],
        "hinge-right": [6],
        "y=1.2": [7],
        "x=2": [8],
    }
    # X cuts 0 1 2 3 4 -> 2 each; Y cuts 0 .1 .4 .5 | 1 | 1.2 1.5: per link 1/2/1, 4, 2/2
    assert num_cells(body) == 8 * 12
    nxs, nys = [2, 2, 2, 2], [1, 2, 1, 4, 2, 2]
    assert tag_counts(body, 24) == [n * m for m in nys for n in nxs]
    assert body.regions == {
        "left": list(range(1, 13)),
        "middle": [13, 14, 15, 16],
        "right": list(range(17, 25)),
        "tip": [4, 8, 12, 16, 20, 24],
        "stripe": [5, 6, 7, 8],
        "dot": [17],
    }
    total, region_areas = areas(body)
    assert region_areas == pytest.approx(
        {"left": 2.0, "middle": 2.0, "right": 2.0, "tip": 1.5, "stripe": 1.2, "dot": 0.2}, rel=1e-12
    )
    lines = line_integrals(body, {"y=1.2": (1, 1.2), "x=2": (0, 2.0)})
    assert lines["y=1.2"] == pytest.approx([L, 0.0, 0.0], abs=1e-12)
    assert lines["x=2"] == pytest.approx([3 * w, 0.0, 0.0], abs=1e-12)


def test_three_link_extra_cuts_share_their_links_divisions():
    """Cuts at y = 0.25 and 0.75 split the left and middle links: 3 divisions each
    shared 2/1 in the link; the right link keeps 3 (shared over the whole width it
    would be 2/2, 1/1, 3)."""
    body = build_three_link(COMM, 1.0, 0.5, [2, 3], hinges=["y=0.25", "y=0.75"])
    assert num_cells(body) == 2 * 9
    assert tag_counts(body, 5) == [2 * m for m in (2, 1, 2, 1, 3)]
    assert body.regions == {"left": [1, 2], "middle": [3, 4], "right": [5]}


@pytest.mark.parametrize(
    "kwargs, key, words",
    [
        (dict(length=-1.0), "mesh.length", "positive number"),
        (dict(length=math.nan), "mesh.length", "positive number"),
        (dict(link_width=0.0), "mesh.link_width", "positive number"),
        (dict(link_width=math.inf), "mesh.link_width", "positive number"),
        (dict(link_width="1"), "mesh.link_width", "positive number"),
        (dict(divisions=[3]), "mesh.divisions", "[nx, n_per_link]"),
        (dict(divisions=[3, 0]), "mesh.divisions", "two positive integers"),
        (dict(divisions=[3.0, 1]), "mesh.divisions", "two positive integers"),
        (dict(cell="hexahedron"), "mesh.cell", "quadrilateral"),
        (dict(regions=[("left", (0.0, 1.0))]), "mesh.regions.0.name", "'left'"),
        (
            dict(regions=[("r", None, (1.0, 1.2)), ("middle", None, (0.0, 0.1))]),
            "mesh.regions.1.name",
            "'middle'",
        ),
        (dict(regions=[("r", None, (0.0, 2.0))]), "mesh.regions.0.y", "[0, 1.5]"),
        (
            dict(hinges=["y=0.5"]),
            "hinge.0.where",
            "two hinges on one line: hinge-left and hinge.0.where",
        ),
        (
            dict(hinges=["x=1", "y=1.0"]),
            "hinge.1.where",
            "two hinges on one line: hinge-right and hinge.1.where",
        ),
        (dict(hinges=["y=1.5"]), "hinge.0.where", "lies on the body's boundary"),
        (dict(hinges=["y=2"]), "hinge.0.where", "the body spans y in [0, 1.5]"),
        (dict(hinges=["w=1"]), "hinge.0.where", 'expected "x=c" or "y=c"'),
    ],
)
def test_three_link_bad_arguments(kwargs, key, words):
    args = dict(length=4.0, link_width=0.5, divisions=[4, 1])
    args.update(kwargs)
    with pytest.raises(SceneError) as err:
        build_three_link(COMM, **args)
    message = str(err.value)
    assert message.startswith(key + ": ") and words in message and "\n" not in message


def test_gmsh_left_as_found():
    """A gmsh someone else initialized stays initialized, with its model and options."""
    import gmsh

    gmsh.initialize(readConfigFiles=False)
    try:
        gmsh.model.add("users-model")
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.option.setNumber("Mesh.ElementOrder", 2)
        body = build_strip(COMM, 2.0, 1.0, [2, 1])
        assert _sum(body.mesh.geometry.index_map().size_local) == 6  # degree 1 regardless
        assert gmsh.model.getCurrent() == "users-model"
        assert gmsh.option.getNumber("Mesh.ElementOrder") == 2
        assert gmsh.model.list().count("users-model") == 1 and len(gmsh.model.list()) == 2
    finally:
        gmsh.finalize()


# --- gmsh files ----------------------------------------------------------------


@pytest.mark.parametrize(
    "name, cells, rel",
    [
        ("qc_q1.msh", 32, 2e-3),
        ("qc_q2.msh", 32, 1e-5),
        ("qc_t2.msh", 64, 1e-5),
    ],
)
def test_read_curved_surface(msh_dir, name, cells, rel):
    body = read_gmsh(COMM, msh_dir / name)
    R, H = 2.0, 3.0
    assert (body.mesh.topology.dim, body.mesh.geometry.dim) == (2, 3)
    assert num_cells(body) == cells
    # geometry nodes: 9 x 5 grid (P1), 17 x 9 grid (P2; diagonal midpoints are grid points)
    nodes = _sum(body.mesh.geometry.index_map().size_local)
    assert nodes == {"qc_q1.msh": 9 * 5, "qc_q2.msh": 17 * 9, "qc_t2.msh": 17 * 9}[name]
    assert body.regions == {"shell": [5]} and body.edges == {"bottom": [11], "top": [12]}
    assert (body.length, body.width) == (pytest.approx(R), pytest.approx(H))
    total, regions = areas(body)
    exact = 0.5 * math.pi * R * H
    assert total == pytest.approx(exact, rel=rel)
    assert regions["shell"] == pytest.approx(total, rel=1e-12)
    lengths = edge_lengths(body)
    assert lengths["bottom"] == pytest.approx(0.5 * math.pi * R, rel=rel)
    assert lengths["top"] == pytest.approx(0.5 * math.pi * R, rel=rel)


def test_read_drops_cells_in_no_physical_surface(msh_dir):
    body = read_gmsh(COMM, msh_dir / "qc_extra.msh")
    assert num_cells(body) == 32
    assert (body.length, body.width) == (pytest.approx(2.0), pytest.approx(3.0))


def test_read_hand_written_msh22():
    body = read_gmsh(COMM, DATA / "two_quads_v22.msh")
    assert body.regions == {"left": [1], "right": [2]} and body.edges == {"clamp": [3]}
    total, regions = areas(body)
    assert total == pytest.approx(2.0) and regions == pytest.approx({"left": 1.0, "right": 1.0})
    assert edge_lengths(body) == {"clamp": pytest.approx(1.0)}
    nz, area = normal_z(body.mesh)
    assert np.allclose(nz, area)


@pytest.mark.parametrize(
    "name, words",
    [
        ("garbage.msh", "cannot read"),
        ("empty.msh", "cannot read"),
        ("missing.msh", "no such file"),
        ("qc_nogroups.msh", "no physical surface"),
        ("qc_unnamed.msh", "no named physical surface"),
        ("plate.geo", ".msh"),
    ],
)
def test_read_bad_files(msh_dir, name, words):
    with pytest.raises(SceneError) as err:
        read_gmsh(COMM, msh_dir / name)
    message = str(err.value)
    assert message.startswith("mesh.file: ") and words in message
    assert "\n" not in message and name in message


# --- scenes' [mesh] tables ------------------------------------------------------


def test_build_body_dispatch(msh_dir):
    strip = build_body(
        COMM,
        {
            "kind": "strip",
            "length": 4.0,
            "width": 1.0,
            "divisions": [8, 1],
            "cell": "triangle",
            "regions": [{"name": "end1", "x": [0.0, 1.0]}],
        },
    )
    assert strip.regions == {"end1": [1]} and num_cells(strip) == 16
    grid = build_body(
        COMM,
        {
            "length": 4.0,
            "divisions": [4, 2],
            "regions": [{"name": "s", "y": [0.0, 0.5]}, {"name": "e", "x": [3.0, 4.0], "y": None}],
        },
        hinges=["x=2"],
    )
    assert grid.regions == {"s": [1, 2, 3], "e": [3, 6]} and grid.edges["x=2"] == [5]
    links = build_body(
        COMM,
        {"kind": "three-link", "length": 2.0, "regions": [{"name": "end", "x": [1.5, 2.0]}]},
        hinges=["x=1"],
    )
    assert num_cells(links) == 10 * 3 * 2  # default divisions [10, 2]
    assert (links.length, links.width) == (2.0, 1.5)  # default link_width 0.5
    assert links.hinges == ["hinge-left", "hinge-right"] and links.edges["x=1"] == [7]
    assert links.regions["end"] == [3, 6, 9]
    curved = build_body(
        COMM, {"kind": "gmsh", "file": "qc_q1.msh"}, scene_dir=msh_dir, hinges=["x=1", "nonsense"]
    )  # gmsh: hinges resolved later
    assert curved.regions == {"shell": [5]} and curved.hinges == []
    for section, key in (
        ({"kind": "three-links"}, "mesh.kind"),
        ({"regions": [{"name": "r"}]}, "mesh.regions.0"),
        ({"regions": [{"name": "r", "x": None, "y": None}]}, "mesh.regions.0"),
        ({"regions": [{"name": "r", "y": [1.0]}]}, "mesh.regions.0.y"),
        ({"kind": "three-link", "link_width": -0.5}, "mesh.link_width"),
        (
            {"kind": "three-link", "regions": [{"name": "right", "x": [0, 1]}]},
            "mesh.regions.0.name",
        ),
        (
            {"kind": "gmsh", "file": "qc_q1.msh", "regions": [{"name": "r", "y": [0, 1]}]},
            "mesh.regions",
        ),
        ({"kind": "gmsh"}, "mesh.file"),
        ({"kind": "gmsh", "file": "nope.msh"}, "mesh.file"),
        ({"kind": "strip", "length": 1.0, "regions": [{"x": [0, 1]}]}, "mesh.regions.0.name"),
        ({"kind": "strip", "length": 1.0, "divisions": [1]}, "mesh.divisions"),
    ):
        with pytest.raises(SceneError) as err:
            build_body(COMM, section, scene_dir=msh_dir)
        assert str(err.value).startswith(key + ":")
    with pytest.raises(SceneError) as err:
        build_body(COMM, {"kind": "three-link"}, hinges=["x=0.5", "y=1"])
    assert str(err.value).startswith("hinge.1.where: two hinges on one line: hinge-right")


# --- MPI -------------------------------------------------------------------------

MPI_SCRIPT = """
import json, sys
from mpi4py import MPI
sys.path.insert(0, {tests!r})
import test_meshes as t

comm = MPI.COMM_WORLD
out = dict(t.{call}, size=comm.size)
if comm.rank == 0:
    print("RESULT " + json.dumps(out))
"""


def _mpirun():
    """An mpirun of the MPI that mpi4py uses, or None."""
    if os.environ.get("RFTFEM_MPIRUN"):
        return os.environ["RFTFEM_MPIRUN"]
    vendor = MPI.get_vendor()[0]
    marks = ("Open MPI", "OpenRTE") if "Open MPI" in vendor else ("HYDRA", "MPICH")
    here = Path(sys.executable).parent
    candidates = [
        here / "mpirun",
        here / "mpiexec",
        shutil.which("mpirun"),
        shutil.which("mpiexec"),
    ]
    for c in candidates:
        if c and os.path.isfile(c) and os.access(c, os.X_OK):
            try:
                text = subprocess.run(
                    [str(c), "--version"], capture_output=True, text=True, timeout=30
                ).stdout
            except (OSError, subprocess.SubprocessError):
                continue
            if any(m in text for m in marks):
                return str(c)
    return None


def measure(comm, msh, bad):
    """Areas, edge lengths, cell counts and region tags of two strips, a three-link
    body and a gmsh file built on ``comm``, and the message for an unreadable file."""
    out = {}
    for cell in ("quadrilateral", "triangle"):
        body = build_strip(
            comm, 10.0, 2.0, [16, 2], cell, regions=[("end1", (0.0, 1.0)), ("mid", (3.0, 7.5))]
        )
        out[cell] = [areas(body), edge_lengths(body), num_cells(body), body.regions]
    body = build_three_link(
        comm,
        6.0,
        0.5,
        [12, 2],
        "quadrilateral",
        regions=[("tip", (5.0, 6.0), None)],
        hinges=["x=3"],
    )
    out["three-link"] = [areas(body), edge_lengths(body), num_cells(body), body.regions]
    body = read_gmsh(comm, msh)
    out["gmsh"] = [
        areas(body),
        edge_lengths(body),
        num_cells(body),
        body.regions,
        [body.length, body.width],
    ]
    try:
        read_gmsh(comm, bad)
    except SceneError as err:
        out["bad"] = str(err)
    return json.loads(json.dumps(out))  # tuples -> lists, as from the subprocess


def measure_hinges(comm):
    """dS length, ds length and distance to its line of each hinge line of a
    three-link body built on ``comm``."""
    body = build_three_link(comm, 6.0, 0.5, [12, 2], "quadrilateral", hinges=["x=3"])
    lines = {"hinge-left": (1, 0.5), "hinge-right": (1, 1.0), "x=3": (0, 3.0)}
    return json.loads(json.dumps(line_integrals(body, lines)))


def _on_two_ranks(tmp_path, call: str) -> dict:
    """``t.<call>`` (``comm`` the world) run on 2 ranks, as rank 0 returned it.

    From a serial pytest, the 2-rank run is ``mpirun -n 2`` of a small script.
    When pytest itself runs under mpirun, it is the call on the world
    communicator of this process.
    """
    if COMM.size > 1:
        out = dict(eval("t." + call, {"t": sys.modules[__name__], "comm": COMM}), size=COMM.size)
    else:
        mpirun = _mpirun()
        if mpirun is None:
            pytest.fail(f"no mpirun found for {MPI.get_vendor()[0]}")
        script = tmp_path / "mpi_meshes.py"
        script.write_text(MPI_SCRIPT.format(tests=str(Path(__file__).parent), call=call))
        env = {
            k: v
            for k, v in os.environ.items()
            if not k.startswith(("OMPI_", "PMIX_", "PMI_", "HYDRA_", "MPIR_"))
        }
        env.update(
            OMPI_ALLOW_RUN_AS_ROOT="1",
            OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
            OMPI_MCA_rmaps_base_oversubscribe="1",
        )
        proc = subprocess.run(
            [mpirun, "-n", "2", sys.executable, str(script)],
            env=env,
            capture_output=True,
            text=True,
            timeout=120,
        )
        lines = [ln for ln in proc.stdout.splitlines() if ln.startswith("RESULT ")]
        assert proc.returncode == 0 and lines, proc.stdout[-2000:] + proc.stderr[-2000:]
        out = json.loads(lines[0][len("RESULT ") :])
    assert out.pop("size") == (COMM.size if COMM.size > 1 else 2)
    return out


@pytest.mark.mpi
def test_mpirun_two_ranks_match_serial(msh_dir, tmp_path):
    """Meshes built on 2 ranks give the serial areas, lengths, counts and tags."""
    msh, bad = str(msh_dir / "qc_q2.msh"), str(msh_dir / "garbage.msh")
    parallel = _on_two_ranks(tmp_path, f"measure(comm, {msh!r}, {bad!r})")
    assert parallel.pop("bad").startswith("mesh.file: ")
    serial = measure(MPI.COMM_SELF, msh, bad)
    assert serial.pop("bad").startswith("mesh.file: ")
    assert set(parallel) == set(serial)
    for key in serial:
        (p_total, p_regions), p_edges, p_cells, p_names = parallel[key][:4]
        (s_total, s_regions), s_edges, s_cells, s_names = serial[key][:4]
        assert p_cells == s_cells and p_names == s_names
        assert p_total == pytest.approx(s_total, rel=1e-12)
        assert p_regions == pytest.approx(s_regions, rel=1e-12)
        assert p_edges == pytest.approx(s_edges, rel=1e-12)
    assert parallel["gmsh"][4] == pytest.approx(serial["gmsh"][4], rel=1e-12)


@pytest.mark.mpi
def test_mpirun_hinge_lines_are_interior_on_two_ranks(tmp_path):
    """Interior-facet (dS) integrals over hinge lines cut by the partition work
    and give the serial lengths: the mesh ghosts the cells across shared facets."""
    parallel = _on_two_ranks(tmp_path, "measure_hinges(comm)")
    serial = measure_hinges(MPI.COMM_SELF)
    for name, exact in (("hinge-left", 6.0), ("hinge-right", 6.0), ("x=3", 1.5)):
        assert serial[name] == pytest.approx([exact, 0.0, 0.0], abs=1e-12)
        assert parallel[name] == pytest.approx([exact, 0.0, 0.0], abs=1e-12)
