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
a process that has imported dolfinx (see rftfem/compat_render.py).
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
    return subprocess.run([sys.executable, "-m", "rftfem", *map(str, args)], cwd=ROOT,
                          capture_output=True, text=True, timeout=timeout,
                          env=env or dict(os.environ))


@pytest.fixture(scope="module")
def serial_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("render") / "rollup"
    done = _rftfem("run", ROLLUP, "--out", out, "--quiet", *[a for s in COARSE for a in ("--set", s)])
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
    cmd = [exe, "-n", "2", sys.executable, "-m", "rftfem", "run", str(ROLLUP), "--out", str(out),
           "--quiet", *[a for s in COARSE for a in ("--set", s)]]
    done = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=900, env=env)
    assert done.returncode == 0, done.stderr[-2000:]
    return out


_RENDER = """
import json, sys
from rftfem.render import render
r = render(sys.argv[1], sys.argv[2], time=None if sys.argv[3] == "last" else float(sys.argv[3]))
print(json.dumps({"pixels": r.probe_pixels, "reference_pixels": r.reference_pixels,
                  "times": r.times, "size": r.size}))
"""


def render_png(run: Path, out: Path, time="last") -> dict:
    done = subprocess.run([sys.executable, "-c", _RENDER, str(run), str(out), str(time)],
                          capture_output=True, text=True, timeout=600, cwd=ROOT)
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
    window = coloured[max(r - 3, 0):r + 4, max(c - 3, 0):c + 4]
    assert window.any(), (f"no body at the tip's pixel ({col:.0f}, {row:.0f}); tip at "
                          f"{tip_position(run, info['times'][-1])}")
    # and no body where the tip would be undeformed (it has moved far from there)
    col0, row0 = info["reference_pixels"]["tip"]
    assert np.hypot(col - col0, row - row0) > 50
    c0, r0 = int(round(col0)), int(round(row0))
    if 0 <= r0 < img.shape[0] and 0 <= c0 < img.shape[1]:
        window = coloured[max(r0 - 3, 0):r0 + 4, max(c0 - 3, 0):c0 + 4]
        assert not window.any(), f"body drawn at the tip's reference position ({col0:.0f}, {row0:.0f})"
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
    done = _rftfem("render", serial_run, "--out", film, "--every", "3", "--view", "follow",
                   "--size", "320x240")
    assert done.returncode == 0, done.stderr
    # output frames 0, 3, ..., 39, then the last (40)
    assert _count_frames(film) == len(range(0, N_FRAMES, 3)) + 1


@pytest.mark.mpi
def test_render_of_an_mpirun_run(mpi_run, tmp_path):
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
    _one_line_error(_rftfem("render", serial_run, "--color", "pressure"), "pressure",
                    "displacement")
    _one_line_error(_rftfem("render", serial_run, "--time", "7"), "--time", "outside")
    _one_line_error(_rftfem("render", serial_run, "--trail", "nose"), "nose", "tip")
    _one_line_error(_rftfem("render", serial_run, "--out", tmp_path / "x.jpg"), ".png")
    (tmp_path / "afile").write_text("")
    _one_line_error(_rftfem("render", serial_run, "--out", tmp_path / "afile" / "x.png"),
                    "--out")
    _one_line_error(_rftfem("render", serial_run, "--out", "/proc/rftfem.png"), "--out")
    _one_line_error(_rftfem("render", serial_run, "--size", "big"), "--size")
    _one_line_error(_rftfem("render", serial_run, "--out", tmp_path / "f.mp4", "--time", "1"),
                    "--time")
    # a folder without its probe log still draws; a probe trail then says what is missing
    import shutil

    partial = tmp_path / "partial"
    shutil.copytree(serial_run, partial)
    (partial / "probes.csv").unlink()
    assert _rftfem("render", partial, "--out", tmp_path / "p.png").returncode == 0
    _one_line_error(_rftfem("render", partial, "--trail", "tip"), "probes.csv", "missing")


def test_scene_output_render_draws_at_the_end(tmp_path):
    out = tmp_path / "r"
    done = _rftfem("run", ROLLUP, "--out", out, "--quiet", "--set", "mesh.divisions=[8,1]",
                   "--set", 'output.render="png"')
    assert done.returncode == 0, done.stderr
    assert (out / "render.png").stat().st_size > 10_000
    assert done.stdout.strip().splitlines() == [done.stdout.strip()]  # quiet: one line
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
    (broken / "fields.xdmf").write_text(text.replace("http://www.w3.org/2001/XInclude",
                                                     "https://www.w3.org/2001/XInclude"))
    info = render_png(broken, tmp_path / "killed.png")
    check_picture(tmp_path / "killed.png", info, broken)
    assert "https://" in (broken / "fields.xdmf").read_text()  # the user's file is not touched
