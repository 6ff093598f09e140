"""Meshes checked as they are read (meshes/surface_checks.py): cells that face the
other way from their neighbours are turned, and cells of no area, cells turned
inside out, unmerged coincident nodes and a surface that cannot be oriented are
refused in one line; ``rftfem check`` reports cells, orientation, free edges and
pieces."""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest
from conftest import ROOT, run_command, write_scene
from stokes_bodies import write_disk, write_ellipsoid

from rftfem.meshes.surface_checks import REVERSED, check_surface

#: gradients of the bilinear quadrilateral's shape functions (gmsh's corner order,
#: reference square [-1, 1]²) at the 2 × 2 Gauss points
_G = 1 / math.sqrt(3)
_QUAD_POINTS = [(-_G, -_G), (_G, -_G), (_G, _G), (-_G, _G)]
QUAD_GRADS = np.array(
    [
        [
            [-(1 - e) / 4, -(1 - x) / 4],
            [(1 - e) / 4, -(1 + x) / 4],
            [(1 + e) / 4, (1 + x) / 4],
            [-(1 + e) / 4, (1 - x) / 4],
        ]
        for x, e in _QUAD_POINTS
    ]
)
TRI_GRADS = np.array([[[-1.0, -1.0], [1.0, 0.0], [0.0, 1.0]]])


def _grid(nx=4, ny=2):
    """A flat 2 × 1 grid of quadrilaterals facing +Z: nodes, cells."""
    x = np.array([(2 * i / nx, j / ny, 0.0) for j in range(ny + 1) for i in range(nx + 1)])
    cells = []
    for j in range(ny):
        for i in range(nx):
            a = j * (nx + 1) + i
            cells.append([a, a + 1, a + nx + 2, a + nx + 1])
    return x, np.array(cells)


def test_cells_facing_the_other_way_are_turned():
    """Three of eight cells given the other way round: the three are turned (the
    majority's side is kept), and with five of eight the other five are."""
    x, cells = _grid()
    flipped = cells.copy()
    flipped[[3, 7, 4]] = flipped[[3, 7, 4]][:, REVERSED[3]]
    turn, report = check_surface(3, flipped, x, QUAD_GRADS)
    assert sorted(np.flatnonzero(turn)) == [3, 4, 7] and report.turned == 3
    assert report.free_edges == 12 and report.pieces == [8]
    flipped[[0, 1]] = flipped[[0, 1]][:, REVERSED[3]]
    turn, _ = check_surface(3, flipped, x, QUAD_GRADS)
    assert sorted(np.flatnonzero(turn)) == [2, 5, 6]
    turn, report = check_surface(3, cells, x, QUAD_GRADS)
    assert not turn.any() and report.lines()[1] == "mesh: orientation consistent"


def test_moebius_band_is_refused():
    """A Möbius band of 24 quadrilaterals cannot face one side: refused, naming two cells."""
    n = 24
    u = 2 * np.pi * np.arange(n) / n
    x = np.array(
        [
            (
                (1 + s * np.cos(a / 2)) * np.cos(a),
                (1 + s * np.cos(a / 2)) * np.sin(a),
                s * np.sin(a / 2),
            )
            for a in u
            for s in (-0.3, 0.3)
        ]
    )
    cells = [[2 * i, 2 * i + 2, 2 * i + 3, 2 * i + 1] for i in range(n - 1)]
    cells.append([2 * n - 2, 1, 0, 2 * n - 1])  # the band joins itself turned over
    with pytest.raises(ValueError, match="cannot be oriented .* cells"):
        check_surface(3, np.array(cells), x, QUAD_GRADS)
    # the same band cut open (no joining cell) is a strip and is accepted
    check_surface(3, np.array(cells[:-1]), x, QUAD_GRADS)


def test_bad_cells_and_unmerged_nodes_are_named():
    x, cells = _grid()
    bowtie = cells.copy()
    bowtie[5] = bowtie[5][[0, 1, 3, 2]]
    with pytest.raises(ValueError, match=r"cell 6 is turned inside out near \(0.75, 0.75, 0\)"):
        check_surface(3, bowtie, x, QUAD_GRADS)
    apart = np.vstack([x, x[cells[1, 1]]])  # cell 2's corner, not merged with cell 3's
    unmerged = cells.copy()
    unmerged[1, 1] = len(x)
    with pytest.raises(ValueError, match=r"1 pair\(s\) of nodes coincide .* at \(1, 0, 0\)"):
        check_surface(3, unmerged, apart, QUAD_GRADS)
    line = np.array([[0.0, 0, 0], [1, 0, 0], [2, 0, 0], [1, 1, 0]])
    with pytest.raises(ValueError, match=r"cell 1 has \(nearly\) zero area"):
        check_surface(2, np.array([[0, 1, 2], [0, 2, 3]]), line, TRI_GRADS)


def _reverse_outer_ring(path, radius):
    """Rewrite the gmsh file with the cells whose centre lies beyond ``radius`` given
    the other way round (as hand-assembled patches can come)."""
    import gmsh

    gmsh.initialize(readConfigFiles=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.merge(str(path))
        tags, xyz, _ = gmsh.model.mesh.getNodes()
        where = dict(zip(tags.tolist(), xyz.reshape(-1, 3)))
        turned = 0
        for _, e in gmsh.model.getEntities(2):
            types, elements, nodes = gmsh.model.mesh.getElements(2, e)
            cells = nodes[0].reshape(len(elements[0]), -1)
            centres = np.array([where[int(c[0])] + where[int(c[2])] for c in cells]) / 2
            outer = np.linalg.norm(centres[:, :2], axis=1) > radius
            cells[outer] = cells[outer][:, REVERSED[int(types[0])]]
            turned += int(outer.sum())
            inside, coords, _ = gmsh.model.mesh.getNodes(2, e, includeBoundary=False)
            gmsh.model.mesh.clear([(2, e)])
            gmsh.model.mesh.addNodes(2, e, inside, coords)
            gmsh.model.mesh.addElements(2, e, [int(types[0])], elements, [cells.ravel()])
        gmsh.write(str(path))
        return turned
    finally:
        gmsh.finalize()


DISK = """
title = "a free disk pushed by a pressure through a liquid"
[mesh]
kind = "gmsh"
file = "{file}"
[shell]
thickness = 0.05
E = 1.0e4
nu = 0.3
[fluid]
drag = [2.0e-3, 2.0e-3, 2.0e-3]
[time]
end = 0.3
dt = 0.1
[[load]]
kind = "pressure"
where = "all"
value = 1.0e-3
ramp = "constant"
"""


def test_disk_with_a_reversed_ring_runs_as_the_consistent_disk(tmp_path):
    """A disk of second-order quadrilaterals whose outer ring was given facing −Z:
    `rftfem check` says how many cells it turned, and under a uniform pressure in
    isotropic drag it moves as the consistent disk does, at p / c along its normal
    (the same centroids to 1e-12 of the travel; reached 0 under the machine's,
    Haswell and Sandybridge kernels: the turned cells make the same mesh). Without
    the turning the run failed at its first step ("a director turned 0.369 rad")."""
    write_disk(tmp_path / "good.msh", size=0.35)
    write_disk(tmp_path / "mixed.msh", size=0.35)
    turned = _reverse_outer_ring(tmp_path / "mixed.msh", 0.8)
    assert 5 < turned < 30  # of 61: the majority faces +Z and is kept
    rows = {}
    for name in ("good", "mixed"):
        scene = write_scene(tmp_path, DISK.format(file=f"{name}.msh"), name=f"{name}.toml")
        done = run_command([sys.executable, "-m", "rftfem", "check", str(scene)], cwd=ROOT)
        assert done.returncode == 0, done.stderr
        expected = (
            "consistent"
            if name == "good"
            else f"{turned} cell(s) turned to face as their neighbours"
        )
        assert f"mesh: orientation {expected}" in done.stdout, done.stdout
        assert "mesh: open (" in done.stdout and ", 1 piece" in done.stdout
        out = tmp_path / f"out-{name}"
        done = run_command(
            [
                sys.executable,
                "-m",
                "rftfem",
                "run",
                str(scene),
                "--out",
                str(out),
                "--set",
                "output.fields=false",
            ],
            cwd=ROOT,
        )
        assert done.returncode == 0, done.stderr[-2000:]
        if name == "mixed":
            assert f"mesh: turned {turned} cell(s) of " in done.stdout
            assert "mixed.msh to face as their neighbours" in done.stdout
        rows[name] = np.genfromtxt(out / "body.csv", delimiter=",", names=True)
    good, mixed = rows["good"], rows["mixed"]
    travel = 1.0e-3 / 2.0e-3 * good["time"][-1]
    apart = max(np.abs(good[f"centroid_{a}"] - mixed[f"centroid_{a}"]).max() for a in "xyz")
    print(
        f"z: {good['centroid_z']} / {mixed['centroid_z']}; exact {travel} at the end; "
        f"largest difference {apart / travel:.1e} of the travel"
    )
    assert good["centroid_z"][-1] == pytest.approx(travel, rel=1e-9)
    for axis in "xyz":
        assert np.abs(good[f"centroid_{axis}"] - mixed[f"centroid_{axis}"]).max() <= 1e-12 * travel


def _write_msh(path, x, cells, cell_type=3):
    """A gmsh 2.2 file of one physical surface "body" from nodes and cells (0-based)."""
    lines = [
        "$MeshFormat",
        "2.2 0 8",
        "$EndMeshFormat",
        "$PhysicalNames",
        "1",
        '2 1 "body"',
        "$EndPhysicalNames",
        "$Nodes",
        str(len(x)),
    ]
    lines += [f"{i + 1} {a!r} {b!r} {c!r}" for i, (a, b, c) in enumerate(np.asarray(x).tolist())]
    lines += ["$EndNodes", "$Elements", str(len(cells))]
    lines += [
        f"{k + 1} {cell_type} 2 1 1 " + " ".join(str(n + 1) for n in c)
        for k, c in enumerate(np.asarray(cells).tolist())
    ]
    path.write_text("\n".join(lines + ["$EndElements", ""]), encoding="utf-8")


def _sphere_cells(path):
    """Nodes and 9-node cells of a gmsh sphere file."""
    import gmsh

    gmsh.initialize(readConfigFiles=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.merge(str(path))
        tags, xyz, _ = gmsh.model.mesh.getNodes()
        index = {int(t): i for i, t in enumerate(tags)}
        _, nodes = gmsh.model.mesh.getElementsByType(10)
        return xyz.reshape(-1, 3), np.vectorize(index.get)(nodes.reshape(-1, 9))
    finally:
        gmsh.finalize()


def test_closed_surfaces_and_pieces_are_reported(tmp_path):
    """A sphere is closed (no free edge); two spheres in one file are two pieces, a
    legal body that `rftfem check` lists."""
    write_ellipsoid(tmp_path / "one.msh", size=0.5)
    x, cells = _sphere_cells(tmp_path / "one.msh")
    _write_msh(
        tmp_path / "two.msh",
        np.vstack([x, x + [3.0, 0, 0]]),
        np.vstack([cells, cells + len(x)]),
        cell_type=10,
    )
    for name, pieces in (("one", "1 piece"), ("two", f"2 pieces of {len(cells)}, ")):
        scene = write_scene(tmp_path, DISK.format(file=f"{name}.msh"), name=f"{name}.toml")
        done = run_command([sys.executable, "-m", "rftfem", "check", str(scene)], cwd=ROOT)
        assert done.returncode == 0, done.stderr
        assert f"mesh: closed (no free edge), {pieces}" in done.stdout, done.stdout


def test_refusals_through_the_command_line(tmp_path):
    """A file with a cell turned inside out is refused with exit 2 and one line."""
    x, cells = _grid()
    cells[5] = cells[5][[0, 1, 3, 2]]
    _write_msh(tmp_path / "bad.msh", x, cells)
    scene = write_scene(tmp_path, DISK.format(file="bad.msh"))
    done = subprocess.run(
        [sys.executable, "-m", "rftfem", "check", str(scene)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 2
    err = done.stderr.strip().splitlines()
    assert len(err) == 1 and "mesh.file: cell 6 is turned inside out" in err[0], err
