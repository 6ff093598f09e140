"""``rftfem render``: pictures and films of finished runs, serial and under mpirun.

The roll-up (demos/rollup.toml, two full turns, 40 load steps, probe ``tip`` at
the free end) is run once on a coarse mesh; its pictures are then checked
against what the run itself wrote:

- a PNG is not blank: enough pixels differ from the white background;
- the body is where the probes say: the tip's final position (reference point
  plus the displacement in probes.csv, independent of the fields file) is
  projected with the picture's camera, and the pixel there is the body's, not
  the background (a render that forgot the displacement, or drew another
  frame, draws the tip elsewhere: the tip ends rolled up, far from x = L);
- a film has one frame per output time (or per ``--every`` output times);
- bad input exits 2 with one line.

Rendering runs in child processes: on dolfinx 0.5, VTK cannot be loaded in
a process that has imported dolfinx (see rftfem/outputs/compat_render.py).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
ROLLUP = ROOT / "demos" / "rollup.toml"
COARSE = ("mesh.divisions=[16,2]",)
N_FRAMES = 41  # t = 0 and 40 load steps


def _rftfem(*args, env=None, timeout=600):
    return subprocess.run(
        [sys.executable, "-m", "rftfem", *map(str, args)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=timeout,
        env=env or dict(os.environ),
    )


@pytest.fixture(scope="module")
def serial_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("render") / "rollup"
    done = _rftfem(
        "run", ROLLUP, "--out", out, "--quiet", *[a for s in COARSE for a in ("--set", s)]
    )
    assert done.returncode == 0, done.stderr
    return out


@pytest.fixture(scope="module")
def mpi_run(tmp_path_factory):
    import shutil

    here = Path(sys.executable).parent / "mpirun"
    exe = str(here) if here.exists() else shutil.which("mpirun")
    assert exe, "mpirun not found"
    out = tmp_path_factory.mktemp("render_mpi") / "rollup"
    env = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    cmd = [
        exe,
        "-n",
        "2",
        sys.executable,
        "-m",
        "rftfem",
        "run",
        str(ROLLUP),
        "--out",
        str(out),
        "--quiet",
        *[a for s in COARSE for a in ("--set", s)],
    ]
    done = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=900, env=env)
    assert done.returncode == 0, done.stderr[-2000:]
    return out


_RENDER = """
import json, sys
from rftfem.outputs.render import render
r = render(sys.argv[1], sys.argv[2], time=None if sys.argv[3] == "last" else float(sys.argv[3]),
           **json.loads(sys.argv[4]))
print(json.dumps({"pixels": r.probe_pixels, "reference_pixels": r.reference_pixels,
                  "times": r.times, "size": r.size}))
"""


def render_png(run: Path, out: Path, time="last", **options) -> dict:
    done = subprocess.run(
        [sys.executable, "-c", _RENDER, str(run), str(out), str(time), json.dumps(options)],
        capture_output=True,
        text=True,
        timeout=600,
        cwd=ROOT,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def tip_position(run: Path, t: float) -> np.ndarray:
    rows = np.loadtxt(run / "probes.csv", delimiter=",", skiprows=1)
    row = rows[np.argmin(abs(rows[:, 0] - t))]
    import tomllib

    tip = tomllib.loads(ROLLUP.read_text())["output"]["probes"][0]["at"]
    return np.array(tip) + row[1:4]


def check_picture(png: Path, info: dict, run: Path):
    import imageio.v3 as iio

    img = iio.imread(png)[..., :3].astype(int)
    assert img.shape[:2] == (768, 1024)
    background = np.array([255, 255, 255])
    differs = np.abs(img - background).sum(axis=2) > 30
    assert differs.mean() > 0.02, f"picture nearly blank: {differs.mean():.4f} of pixels drawn"
    # colour pixels (the body), not the grey outline, text or axes
    rgb = img.astype(float)
    coloured = (rgb.max(axis=2) - rgb.min(axis=2)) > 40
    assert coloured.mean() > 0.01
    col, row = info["pixels"]["tip"]
    c, r = int(round(col)), int(round(row))
    assert 0 <= r < img.shape[0] and 0 <= c < img.shape[1], (col, row)
    window = coloured[max(r - 3, 0) : r + 4, max(c - 3, 0) : c + 4]
    assert window.any(), (
        f"no body at the tip's pixel ({col:.0f}, {row:.0f}); tip at "
        f"{tip_position(run, info['times'][-1])}"
    )
    # and no body where the tip would be undeformed (it has moved far from there)
    col0, row0 = info["reference_pixels"]["tip"]
    assert np.hypot(col - col0, row - row0) > 50
    c0, r0 = int(round(col0)), int(round(row0))
    if 0 <= r0 < img.shape[0] and 0 <= c0 < img.shape[1]:
        window = coloured[max(r0 - 3, 0) : r0 + 4, max(c0 - 3, 0) : c0 + 4]
        assert not window.any(), (
            f"body drawn at the tip's reference position ({col0:.0f}, {row0:.0f})"
        )
    return img


def test_png_of_last_frame_shows_the_body_where_the_tip_is(serial_run, tmp_path):
    info = render_png(serial_run, tmp_path / "last.png")
    assert info["times"] == [pytest.approx(2.0)]
    check_picture(tmp_path / "last.png", info, serial_run)


def test_png_at_a_time_draws_that_frame(serial_run, tmp_path):
    """At t = 0.5 the strip is a quarter-circle arc: the tip is up near z = L/(π/2)·…,
    a place the rolled-up last frame does not cover."""
    half = render_png(serial_run, tmp_path / "half.png", 0.52)
    assert half["times"] == [pytest.approx(0.5)]
    check_picture(tmp_path / "half.png", half, serial_run)


def test_cli_png_default_name(serial_run):
    done = _rftfem("render", serial_run)
    assert done.returncode == 0, done.stderr
    assert (serial_run / "render.png").stat().st_size > 10_000
    assert "render.png" in done.stdout


def _count_frames(path: Path) -> int:
    import imageio.v3 as iio

    return sum(1 for _ in iio.imiter(path))


def test_mp4_has_a_frame_per_output_time(serial_run, tmp_path):
    film = tmp_path / "film.mp4"
    done = _rftfem("render", serial_run, "--out", film, "--size", "640x480")
    assert done.returncode == 0, done.stderr
    assert _count_frames(film) == N_FRAMES


def test_gif_every_third_frame_ends_on_the_last(serial_run, tmp_path):
    film = tmp_path / "film.gif"
    done = _rftfem(
        "render", serial_run, "--out", film, "--every", "3", "--view", "follow", "--size", "320x240"
    )
    assert done.returncode == 0, done.stderr
    # output frames 0, 3, ..., 39, then the last (40)
    assert _count_frames(film) == len(range(0, N_FRAMES, 3)) + 1


@pytest.mark.mpi
def test_render_of_an_mpirun_run(mpi_run, serial_run, tmp_path):
    """Rank 0 writes the fields of both ranks: node for node (matched by position) the
    serial run's, to round-off (reached 2e-14)."""
    a, b = written_nodes(serial_run), written_nodes(mpi_run)
    assert a.shape == b.shape
    a, b = (v[np.lexsort(np.round(v[:, :3], 9).T[::-1])] for v in (a, b))
    assert np.abs(a[:, :3] - b[:, :3]).max() < 1e-12
    assert np.abs(a[:, 3:] - b[:, 3:]).max() < 1e-11 * np.abs(a[:, 3:]).max()
    info = render_png(mpi_run, tmp_path / "mpi.png")
    check_picture(tmp_path / "mpi.png", info, mpi_run)
    done = _rftfem("render", mpi_run, "--out", tmp_path / "mpi.mp4", "--size", "320x240")
    assert done.returncode == 0, done.stderr
    assert _count_frames(tmp_path / "mpi.mp4") == N_FRAMES


def _one_line_error(done, *words):
    assert done.returncode == 2, (done.returncode, done.stdout, done.stderr)
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1, done.stderr
    for w in words:
        assert w in lines[0], (w, lines[0])
    return lines[0]


def test_bad_input_exits_2_with_one_line(serial_run, tmp_path):
    empty = tmp_path / "empty"
    empty.mkdir()
    (empty / "summary.json").write_text("{}")
    _one_line_error(_rftfem("render", empty), "no fields.xdmf")
    _one_line_error(_rftfem("render", tmp_path / "nowhere"), "not found")
    _one_line_error(
        _rftfem("render", serial_run, "--color", "pressure"), "pressure", "displacement"
    )
    _one_line_error(_rftfem("render", serial_run, "--time", "7"), "--time", "outside")
    _one_line_error(_rftfem("render", serial_run, "--trail", "nose"), "nose", "tip")
    _one_line_error(_rftfem("render", serial_run, "--out", tmp_path / "x.jpg"), ".png")
    (tmp_path / "afile").write_text("")
    _one_line_error(_rftfem("render", serial_run, "--out", tmp_path / "afile" / "x.png"), "--out")
    _one_line_error(_rftfem("render", serial_run, "--out", "/proc/rftfem.png"), "--out")
    _one_line_error(_rftfem("render", serial_run, "--size", "big"), "--size")
    _one_line_error(
        _rftfem("render", serial_run, "--out", tmp_path / "f.mp4", "--time", "1"), "--time"
    )
    # a folder without its probe log still draws; a probe trail then says what is missing
    import shutil

    partial = tmp_path / "partial"
    shutil.copytree(serial_run, partial)
    (partial / "probes.csv").unlink()
    assert _rftfem("render", partial, "--out", tmp_path / "p.png").returncode == 0
    _one_line_error(_rftfem("render", partial, "--trail", "tip"), "probes.csv", "missing")


def test_scene_output_render_draws_at_the_end(tmp_path):
    out = tmp_path / "r"
    done = _rftfem(
        "run",
        ROLLUP,
        "--out",
        out,
        "--quiet",
        "--set",
        "mesh.divisions=[8,1]",
        "--set",
        'output.render="png"',
    )
    assert done.returncode == 0, done.stderr
    assert (out / "render.png").stat().st_size > 10_000
    assert done.stdout == ""  # quiet: nothing on success
    bad = _rftfem("check", ROLLUP, "--set", 'output.render="png"', "--set", "output.fields=false")
    _one_line_error(bad, "output.render", "output.fields")


def test_fields_file_has_the_xinclude_namespace_parsers_know(serial_run, tmp_path):
    """dolfinx 0.11 writes the XInclude namespace as https://...; ParaView and VTK
    then see no mesh in any time step. A finished run's file is repaired, and
    a file left unrepaired (a killed run) is read through a repaired copy."""
    import shutil

    text = (serial_run / "fields.xdmf").read_text()
    assert 'xmlns:xi="http://www.w3.org/2001/XInclude"' in text
    broken = tmp_path / "killed"
    shutil.copytree(serial_run, broken)
    (broken / "fields.xdmf").write_text(
        text.replace("http://www.w3.org/2001/XInclude", "https://www.w3.org/2001/XInclude")
    )
    info = render_png(broken, tmp_path / "killed.png")
    check_picture(tmp_path / "killed.png", info, broken)
    assert "https://" in (broken / "fields.xdmf").read_text()  # the user's file is not touched


# ---------------------------------------------------------------- drawn at degree 2
#
# The roll-up on 16 cells winds two turns of radius R = L/(4π): eight cells a turn.
# Drawn through the cells' corners, each turn is an octagon, whose outline's
# distance from the centre varies by 1 - cos(π/8) = 7.6 %; the solution (P2) is
# round to its discretisation error (0.13 % measured).  The outline is measured
# twice: from the written field file (the cells' nodes and their edges' own shape
# functions, not rftfem's drawing code) and from a side-view picture.

_WRITTEN = """
import json, sys
import numpy as np
from rftfem.outputs.render_view import RunFields
run = RunFields(sys.argv[1])
x = run.reference_points + run.frame(len(run.times) - 1)["displacement"]
grid = run.reference
cells = [list(map(int, grid.get_cell(c).point_ids)) for c in range(grid.n_cells)]
print(json.dumps({"reference": run.reference_points.tolist(), "x": x.tolist(),
                  "cells": cells, "types": np.asarray(grid.celltypes).tolist()}))
"""


def _written(run: Path) -> dict:
    done = subprocess.run(
        [sys.executable, "-c", _WRITTEN, str(run)],
        capture_output=True,
        text=True,
        timeout=600,
        cwd=ROOT,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def written_nodes(run: Path) -> np.ndarray:
    """[reference position, last displacement] of every written node."""
    data = _written(run)
    ref = np.array(data["reference"])
    return np.c_[ref, np.array(data["x"]) - ref]


def radial_variation(points_xz: np.ndarray) -> float:
    """(max - min) / mean of the distances of ``points_xz`` from their least-squares circle."""
    A = np.c_[2 * points_xz, np.ones(len(points_xz))]
    centre = np.linalg.lstsq(A, (points_xz**2).sum(axis=1), rcond=None)[0][:2]
    r = np.linalg.norm(points_xz - centre, axis=1)
    return float((r.max() - r.min()) / r.mean())


def written_outline(run: Path, curved: bool = True) -> np.ndarray:
    """Points along the written cells' edges on the strip's side y = 0 at the last
    frame (x, z), each edge drawn by its own Lagrange shape functions (``curved``)
    or as the chord between its corners."""
    data = _written(run)
    ref, x = np.array(data["reference"]), np.array(data["x"])
    # VTK's 9-node quadrilateral: corners 0-3, then the midside nodes of edges
    # 0-1, 1-2, 2-3, 3-0; the 4-node one has corners only
    assert set(data["types"]) == {28}, f"cells written: VTK types {set(data['types'])}"
    s = np.linspace(0.0, 1.0, 17)[:, None]
    points = []
    for cell in data["cells"]:
        for a, b, m in ((0, 1, 4), (1, 2, 5), (2, 3, 6), (3, 0, 7)):
            a, b, m = cell[a], cell[b], cell[m]
            if abs(ref[a, 1]) > 1e-9 or abs(ref[b, 1]) > 1e-9:
                continue
            if curved:
                xs = (1 - s) * (1 - 2 * s) * x[a] + s * (2 * s - 1) * x[b] + 4 * s * (1 - s) * x[m]
            else:
                xs = (1 - s) * x[a] + s * x[b]
            points.append(xs[:, [0, 2]])
    return np.concatenate(points)


def test_rolled_up_turns_are_round_in_the_written_fields(serial_run):
    curved = radial_variation(written_outline(serial_run))
    chords = radial_variation(written_outline(serial_run, curved=False))
    print(
        f"radius variation of the two turns, written cells: {100 * curved:.3f} % "
        f"(through the corners only: {100 * chords:.2f} %)"
    )
    assert curved < 0.02
    assert chords > 0.05  # the measure tells an octagon from a circle


def picture_outline_variation(png: Path) -> tuple[float, int]:
    """Radius variation of the dark outline in a side view (the title, axes and time
    stamp cut away): per 5° sector, the median distance of its dark pixels from their
    least-squares circle; (max - min) / mean over the sectors, and the radius in pixels."""
    import imageio.v3 as iio

    img = iio.imread(png)[..., :3].astype(int)
    dark = img.sum(axis=2) < 250
    h = img.shape[0]
    dark[: int(0.08 * h)] = False
    dark[int(0.8 * h) :] = False
    rows, cols = np.nonzero(dark)
    p = np.c_[cols, rows].astype(float)
    A = np.c_[2 * p, np.ones(len(p))]
    centre = np.linalg.lstsq(A, (p**2).sum(axis=1), rcond=None)[0][:2]
    d = p - centre
    r = np.linalg.norm(d, axis=1)
    sector = ((np.arctan2(d[:, 1], d[:, 0]) + np.pi) // np.radians(5)).astype(int)
    medians = np.array([np.median(r[sector == k]) for k in np.unique(sector)])
    assert len(medians) == 72, f"the outline covers {len(medians)} of 72 sectors"
    return float((medians.max() - medians.min()) / medians.mean()), int(medians.mean())


def test_rolled_up_turns_are_round_in_the_picture(serial_run, tmp_path):
    png = tmp_path / "side.png"
    done = _rftfem(
        "render", serial_run, "--out", png, "--view", "xz", "--color", "none", "--size", "2400x1000"
    )
    assert done.returncode == 0, done.stderr
    variation, radius = picture_outline_variation(png)
    print(
        f"radius variation of the two turns in the side view: {100 * variation:.2f} % "
        f"(radius {radius} px)"
    )
    assert radius > 100
    assert variation < 0.02


@pytest.mark.parametrize("what", ["wall", "contact"])
def test_a_wall_of_the_scene_is_drawn_under_the_body(serial_run, tmp_path, what):
    """A run whose scene has ``[fluid.wall]``, or a contact floor (``[[contact]]``
    kind "plane": a crawler floated in grey before), shows it: a plane under the body
    with an arrow to the body's side covers much of the picture, where the same run
    without it is white there.  (The roll-up run with the plane put into its stored
    scene: only the drawing is tested here.)"""
    import shutil

    import imageio.v3 as iio

    run = tmp_path / f"with_{what}"
    shutil.copytree(serial_run, run)
    summary = json.loads((run / "summary.json").read_text())
    plane = {"point": [0.0, 0.0, -5.0], "normal": [0.0, 0.0, 1.0]}
    if what == "wall":
        summary["scene"]["fluid"] = {"model": "stokes", "viscosity": 1.0, "wall": plane}
    else:
        summary["scene"]["contact"] = [{"kind": "plane", **plane, "friction": 0.3}]
    (run / "summary.json").write_text(json.dumps(summary))
    pictures = {}
    for name, folder in (("plain", serial_run), (what, run)):
        render_png(folder, tmp_path / f"{name}.png")
        img = iio.imread(tmp_path / f"{name}.png")[..., :3].astype(int)
        pictures[name] = (np.abs(img - 255).sum(axis=2) > 30).mean()
    print(f"drawn pixels: {pictures}")
    assert pictures[what] > pictures["plain"] + 0.2


def test_scale_draws_the_displacements_magnified(serial_run, tmp_path):
    """--scale 0.5 on the clamped roll-up (a body held in place: all of its
    displacement is shape) draws the tip at its reference position plus half its
    displacement (the body is there, projected with the picture's camera); that
    pixel is far from the unscaled tip's; and the picture says the factor."""
    import imageio.v3 as iio

    full = render_png(serial_run, tmp_path / "full.png", 0.5)
    half = render_png(serial_run, tmp_path / "half.png", 0.5, scale=0.5)
    check_picture(tmp_path / "half.png", half, serial_run)
    assert np.hypot(*np.subtract(half["pixels"]["tip"], full["pixels"]["tip"])) > 30
    # the factor is written in red at the bottom of the picture
    img = iio.imread(tmp_path / "half.png")[..., :3].astype(int)
    red = (img[..., 0] > 150) & (img[..., 1] < 90) & (img[..., 2] < 90)
    assert red[-60:].sum() > 50
    done = _rftfem("render", serial_run, "--out", tmp_path / "s.png", "--scale", "3")
    assert done.returncode == 0 and "displacements × 3" in done.stdout, done.stderr
    _one_line_error(_rftfem("render", serial_run, "--scale", "0"), "--scale", "> 0")
    _one_line_error(_rftfem("render", serial_run, "--scale", "nan"), "--scale")


def test_scale_keeps_the_rigid_motion_true():
    """A walker's feet went through its floor under --scale: the whole motion was
    magnified.  Now a body moved rigidly (turned and shifted) is drawn where it is at
    any scale, the drawn centroid is the true one, and a small deformation on top of
    a rigid motion is what is magnified (to the rigid fit's own small change)."""
    from rftfem.outputs.rigid_fit import magnified

    X = np.array(
        [
            [x, y, z]
            for x in np.linspace(-4, 4, 17)
            for y in np.linspace(-1, 1, 5)
            for z in (-0.05, 0.05)
        ]
    )  # a plate, symmetric about its centre
    a = 0.7
    R = np.array([[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0], [0, 0, 1.0]])
    rigid = X @ R.T + [30.0, -2.0, 0.5]
    drawn, _ = magnified(X, rigid - X, 20.0)
    assert np.abs(drawn - rigid).max() < 1e-12
    bend = np.zeros_like(X)
    bend[:, 2] = 1e-3 * X[:, 0] ** 2  # a small bending, in the body's own frame
    bend -= bend.mean(axis=0)
    x = rigid + bend @ R.T
    drawn, _ = magnified(X, x - X, 20.0)
    assert np.allclose(drawn.mean(axis=0), x.mean(axis=0), rtol=0, atol=1e-12)
    assert np.abs((drawn - rigid) - 20.0 * bend @ R.T).max() < 1e-9


def test_a_trail_is_drawn_over_the_body(serial_run, tmp_path):
    """A centroid's path runs inside or behind the body (a swimming sheet's centroid
    lies in the sheet): the trail is drawn on top, in its colour, with markers at
    its start and at the frame's time. Here the run's centroid is replaced by a path
    under the strip near its clamp, seen from above: without the overlay the strip
    hides all of it."""
    import shutil

    import imageio.v3 as iio

    run = tmp_path / "hidden_trail"
    shutil.copytree(serial_run, run)
    lines = (run / "body.csv").read_text().splitlines()
    header = lines[0].split(",")
    cols = [header.index(f"centroid_{c}") for c in "xyz"]
    rows = []
    for line in lines[1:]:
        values = line.split(",")
        t = float(values[0])
        for c, v in zip(cols, (1.0 + 4.0 * t, 0.5, -1.0)):
            values[c] = repr(v)
        rows.append(",".join(values))
    (run / "body.csv").write_text("\n".join([lines[0], *rows]) + "\n")
    render_png(run, tmp_path / "trail.png", 0.5, trail="centroid", view="xy")
    img = iio.imread(tmp_path / "trail.png")[..., :3].astype(int)
    trail = np.abs(img - np.array([214, 39, 40])).sum(axis=2) < 40
    print(f"trail pixels: {trail.sum()}")  # 484 drawn; 0 with the trail under the strip
    assert trail.sum() > 250


_ARROWS = """
import numpy as np
from rftfem.outputs.render import _arrows
points = np.array([[0.0, 0.0, 0.0], [0.0, 5.0, 0.0], [0.0, 9.0, 0.0]])
m = np.array([[1.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
glyphs = _arrows(points, m, np.linalg.norm(m, axis=1) > 0, 1.5)
near = glyphs.points[:, 1] < 2.5
print(np.ptp(glyphs.points[near, 0]), np.ptp(glyphs.points[~near, 0]))
"""


def test_magnetization_arrows_are_as_long_as_the_magnetization():
    done = subprocess.run(
        [sys.executable, "-c", _ARROWS], capture_output=True, text=True, timeout=300, cwd=ROOT
    )
    assert done.returncode == 0, done.stderr
    weak, strong = map(float, done.stdout.split())
    assert weak == pytest.approx(1.5, rel=1e-6) and strong == pytest.approx(3.0, rel=1e-6)
