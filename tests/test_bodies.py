"""Several bodies in one scene (``[[body]]``): placed meshes of their own, entries
that address a body by name, a block of body.csv columns per body, and the
refusals of what cannot be."""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest
from conftest import ROOT, write_scene
from stokes_bodies import write_ellipsoid
from test_stokes import _stimson_jeffery

from rftfem.errors import SceneError
from rftfem.integration.simulation import Simulation
from rftfem.scene.reading import load_scene

#: the swimming sheet of demos/swimming_sheet.toml, short and coarse in time (a quarter
#: of its length, two wave periods at T/16); {mesh} is its body
SHEET = """
title = "swimming sheets"
{mesh}
[shell]
thickness = 0.1
E = 100.0
nu = 0.3
density = 1.0e-8
axis = [1.0, 0.0, 0.0]
[fluid]
drag = [3.0e-9, 3.0e-9, 5.67e-9]
[time]
scheme = "generalized-alpha"
rho_inf = 0.9
end = 0.12566370614359174
dt = 0.007853981633974483
[[motion]]
where = "all"
component = "uz"
kind = "travelling-wave"
amplitude = 0.15
wavenumber = 0.5
angular_frequency = 100.0
origin = 0.0
"""
STRIP = 'kind = "strip"\nlength = 10.0\nwidth = 2.0\ndivisions = [10, 2]'


def _run(tmp_path, text, name="scene.toml"):
    sim = Simulation(load_scene(write_scene(tmp_path, text, name)), out_dir=None, quiet=True)
    sim.run()
    return sim


def _column(sim, name):
    return sim.body.values(sim.t)[sim.body.header().index(name)]


def test_sheets_side_by_side_swim_each_as_one_alone(tmp_path):
    """Resistive force theory is local: two sheets 6 apart (the second moved along Y),
    each driven by the same travelling wave, each move as the sheet alone: their
    centroids' X (the swimming) within 5e-9 of the distance swum (reached 8e-14 and
    4e-10: the round-off of a centroid near 5), the liquid's force on each within
    1e-8 of the lone sheet's (reached 2e-16, 6e-12), equal velocities, and the two
    blocks add up to the scene's resultant.  Broke: the drag's resultant not
    restricted to the body (``restricted(f, chi)`` → ``f``): each body's force twice
    the lone sheet's."""
    alone = _run(tmp_path, SHEET.format(mesh=f"[mesh]\n{STRIP}"), "alone.toml")
    pair = SHEET.format(
        mesh=f'[[body]]\nname = "a"\nmesh = {{ {STRIP.replace(chr(10), ", ")} }}\n'
        f'[[body]]\nname = "b"\nmesh = {{ {STRIP.replace(chr(10), ", ")} }}\n'
        "at = [0.0, 6.0, 0.0]\n"
    )
    both = _run(tmp_path, pair, "pair.toml")
    x0 = _column(alone, "centroid_x")
    swum = abs(x0 - 5.0)
    assert swum > 1e-3  # the sheet swam
    for name, dy in (("a", 0.0), ("b", 6.0)):
        off = abs(_column(both, f"{name}_centroid_x") - x0)
        print(f"{name}: centroid x off by {off / swum:.1e} of the distance swum")
        assert off < 5e-9 * swum
        assert abs(_column(both, f"{name}_centroid_y") - _column(alone, "centroid_y") - dy) < 1e-9
        F = np.array([_column(both, f"{name}_fluid_F{c}") for c in "xyz"])
        F0 = np.array([_column(alone, f"fluid_F{c}") for c in "xyz"])
        print(f"{name}: its liquid's force off by {np.abs(F - F0).max() / np.abs(F0).max():.1e}")
        assert np.abs(F - F0).max() < 1e-8 * np.abs(F0).max()
    va, vb = ([_column(both, f"{n}_velocity_{c}") for c in "xyz"] for n in "ab")
    off = np.abs(np.subtract(va, vb)).max() / np.abs(va).max()
    print(f"velocities {va} and {vb}: {off:.1e} apart")  # (reached 1e-11, 2e-12)
    assert abs(va[2]) > 1e-3 and off < 1e-9
    total = np.array(
        [_column(both, f"a_fluid_F{c}") + _column(both, f"b_fluid_F{c}") for c in "xyz"]
    )
    whole = np.array([_column(both, f"fluid_F{c}") for c in "xyz"])
    assert np.abs(total - whole).max() < 1e-13 * np.abs(whole).max()


#: a stiff closed body in Stokes flow, as in tests/test_stokes.py
SPHERES = """
title = "two spheres"
[[body]]
name = "left"
mesh = {{ kind = "gmsh", file = "{mesh}" }}
at = [{left}, 0.0, 0.0]
[[body]]
name = "right"
mesh = {{ kind = "gmsh", file = "{mesh}" }}
at = [{right}, 0.0, 0.0]
turn = [0.0, 90.0, 0.0]
[shell]
thickness = 0.05
E = 1.0e8
nu = 0.3
density = 0.0
axis = [1.0, 0.0, 0.0]
[time]
end = 0.1
dt = 0.1
scheme = "backward-euler"
[fluid]
model = "stokes"
viscosity = 1.0
[[motion]]
component = "ux"
kind = "table"
values = [[0.0, 0.0], [1.0, 1.0]]
"""


def test_two_spheres_as_two_bodies_in_one_liquid(tmp_path):
    """Two unit spheres (0.5 a cells, the second turned 90° about Y: its own mesh
    seen from another side) placed 3 a apart on X and translated along their line of
    centres in Stokes flow: each feels Stimson & Jeffery's drag 6πμaU λ(s = 3)
    (the series of tests/test_stokes.py), within 3e-4 (reached
    −2.5e-5), their blocks add to the scene's resultant to round-off, and by symmetry
    their forces agree to the meshes' difference (1e-4; reached 1e-5).  Broke: the
    Stokes resultant of a body taken over every node (``mine`` all True): 2× each."""
    write_ellipsoid(tmp_path / "sphere.msh", (1.0, 1.0, 1.0), size=0.5)
    text = SPHERES.format(mesh=tmp_path / "sphere.msh", left=-1.5, right=1.5)
    sim = _run(tmp_path, text)
    each = 6 * math.pi * _stimson_jeffery(3.0)
    forces = {n: -_column(sim, f"{n}_fluid_Fx") for n in ("left", "right")}
    print({n: f / each - 1 for n, f in forces.items()})
    for force in forces.values():
        assert abs(force / each - 1) < 3e-4
    assert abs(forces["left"] / forces["right"] - 1) < 1e-4
    total = _column(sim, "left_fluid_Fx") + _column(sim, "right_fluid_Fx")
    assert abs(total - _column(sim, "fluid_Fx")) < 1e-12 * abs(total)


#: two strips in RFT; {extra} is added to the scene
TWO = """
title = "two strips"
[[body]]
name = "a"
mesh = { kind = "strip", length = 4.0, width = 1.0, divisions = [4, 1] }
[[body]]
name = "b"
mesh = { kind = "strip", length = 4.0, width = 1.0, divisions = [4, 1] }
at = [0.0, 3.0, 0.0]
[shell]
thickness = 0.1
E = 100.0
[fluid]
drag = [1.0, 1.0, 2.0]
[time]
end = 0.1
dt = 0.1
"""


@pytest.mark.parametrize(
    "extra,message",
    [
        (
            TWO.replace('name = "b"', 'name = "a"'),
            r"^body\.1\.name: expected a unique body name, found 'a' a second time$",
        ),
        (
            TWO + '[[boundary]]\nbody = "c"\nwhere = "x=0"\nfix = ["clamped"]\n',
            r"^boundary\.0\.body: unknown body 'c'; expected one of: a, b",
        ),
        (
            TWO + '[[boundary]]\nwhere = "x=0"\nfix = ["clamped"]\n',
            r"^boundary\.0\.body: required with several bodies \(one of a, b\)",
        ),
        (
            TWO + '[[boundary]]\nbody = "a"\nwhere = "x=9"\nfix = ["clamped"]\n',
            r"^boundary\.0\.where: unknown selector 'x=9'; expected one of: all, x=0",
        ),
        (
            TWO + '[[output.probes]]\nname = "p"\nbody = "b"\nat = [5.0, 0.5, 0.0]\n',
            r"^output\.probes\.0\.at: probe outside the body: expected a point on the strip",
        ),
        (
            TWO + '[mesh]\nkind = "strip"\n',
            r"^mesh: a scene gives one body by \[mesh\] or several by \[\[body\]\] tables",
        ),
        (
            TWO + '[[body.parts]]\nregion = "head"\nE = 5.0\n',
            r"^body\.1\.parts\.0\.region: ",
        ),
        (
            "length = -4.0".join(TWO.rsplit("length = 4.0", 1)),
            r"^body\.1\.mesh\.length: expected a number > 0, found -4",
        ),
        (
            TWO + '[[contact]]\nkind = "plane"\nbody = "ab"\npoint = [0.0, 0.0, -1.0]\n'
            "normal = [0.0, 0.0, 1.0]\n",
            r"^contact\.0\.body: unknown body 'ab'; expected one of: a, b",
        ),
    ],
    ids=[
        "same name",
        "unknown body",
        "no body",
        "selector",
        "probe",
        "mesh too",
        "part",
        "mesh",
        "plane",
    ],
)
def test_bad_bodies_are_refused_in_one_line(tmp_path, extra, message):
    """Each refusal is one line naming the key, in the body's own terms."""
    with pytest.raises(SceneError, match=message) as caught:
        load_scene(write_scene(tmp_path, extra))
    assert "\n" not in str(caught.value)


@pytest.mark.parametrize(
    "at,turn,overlaps",
    [
        ([0.5, 0.0, 0.0], [0.0, 0.0, 0.0], True),  # one on the other, shifted
        # b upright (turned about X) through a along the line y = 0.5, where neither
        # has a node within 0.87 of the other's (their cells are 1 × 1)
        ([0.5, 0.5, -0.5], [90.0, 0.0, 0.0], True),
        ([0.0, 1.3, 0.0], [0.0, 0.0, 0.0], False),  # side by side, 0.3 apart
    ],
    ids=["on top", "crossing", "side by side"],
)
def test_bodies_that_overlap_where_they_start_are_refused(tmp_path, at, turn, overlaps):
    """Bodies whose surfaces cross or coincide at the start are refused in one line;
    bodies 0.3 apart side by side (cells 1 × 1) are not.  Broke: the check before
    (nodes closer than half their spacing): the crossing pair passed, the pair side
    by side was refused."""
    from rftfem.scene.reading import load_scene as load

    text = TWO.replace("at = [0.0, 3.0, 0.0]", f"at = {at}\nturn = {turn}")
    scene = load(write_scene(tmp_path, text))
    if overlaps:
        with pytest.raises(SceneError, match=r"^body\.1\.at: body 'b' overlaps body 'a'"):
            Simulation(scene, out_dir=None, quiet=True)
    else:
        Simulation(scene, out_dir=None, quiet=True)


def test_overlapping_bodies_and_a_body_key_without_bodies(tmp_path):
    """Bodies that start overlapping and a ``body`` key in a one-body scene are
    refused by the command line in one line with exit status 2.  Broke: the overlap
    check's reach 0 (``0.5 * min`` → ``0.0 * min``): the run starts."""
    overlap = TWO.replace("at = [0.0, 3.0, 0.0]", "at = [0.5, 0.0, 0.0]")
    one = (
        'title = "one"\n[mesh]\nkind = "strip"\n[shell]\nthickness = 0.1\nE = 1.0\n'
        '[time]\nend = 0.1\ndt = 0.1\n[[boundary]]\nbody = "a"\nwhere = "x=0"\nfix = ["clamped"]\n'
    )
    for name, text, message in (
        ("overlap.toml", overlap, "rftfem: error: body.1.at: body 'b' overlaps body 'a' where"),
        ("one.toml", one, 'rftfem: error: boundary.0.body: names a body, found "a", but the'),
    ):
        path = write_scene(tmp_path, text, name)
        done = subprocess.run(
            [
                sys.executable,
                "-m",
                "rftfem",
                "run",
                str(path),
                "--out",
                str(tmp_path / f"out-{name}"),
            ],
            capture_output=True,
            text=True,
            cwd=ROOT,
        )
        lines = done.stderr.strip().splitlines()
        print(lines)
        assert done.returncode == 2 and len(lines) == 1 and lines[0].startswith(message)


@pytest.mark.mpi
def test_two_bodies_in_stokes_flow_on_two_processes_match_one(tmp_path, cli_run):
    """Two swimming sheets, the second turned 180° about Z and placed ahead of the
    first, in one Stokes flow (each feels the other's), ten steps on two processes
    against one: every body.csv column (the blocks of both bodies among them) and
    probes.csv column within 1e-11 of its vector's scale: reached 1.1e-12 in the
    liquid's moments about the origin, whose nodal terms (levers to 22) cancel to a
    thousandth of their size, and 1.2e-13 elsewhere.  Broke: a body's Stokes nodes
    not gathered (each process's own mask repeated, ``np.resize(part.nodes, N)``):
    1.1 of the scale."""
    from running import assert_tables_agree
    from stokes_bodies import SWIMMING_SHEET

    strip = '{ kind = "strip", length = 10.0, width = 2.0, divisions = [10, 2] }'
    text = SWIMMING_SHEET.replace(
        '[mesh]\nkind = "strip"\nlength = 10.0\nwidth = 2.0\ndivisions = [10, 2]\n',
        f'[[body]]\nname = "rear"\nmesh = {strip}\n'
        f'[[body]]\nname = "front"\nmesh = {strip}\nat = [22.0, 2.0, 0.0]\n'
        "turn = [0.0, 0.0, 180.0]\n",
    )
    text = text.replace('[[output.probes]]\nname = "front"', '[[output.probes]]\nname = "tip"')
    text = text.replace("at = [10.0, 0.0, 0.0]", 'at = [10.0, 0.0, 0.0]\nbody = "front"')
    text = text.replace("end = 0.15707963267948966", "end = 0.03926990816987242")
    text += "[output]\nfields = false\n"
    scene = write_scene(tmp_path, text)
    one = cli_run(scene, tmp_path / "one")
    two = cli_run(scene, tmp_path / "two", np=2)
    header = (one / "body.csv").read_text().splitlines()[0].split(",")
    assert "rear_fluid_Fx" in header and "front_velocity_z" in header
    assert_tables_agree(one, two, 1e-11, "two bodies in Stokes flow, two processes against one")


@pytest.mark.parametrize("steps", ["fixed", "error-controlled"])
def test_bodies_that_come_close_are_warned_of_once(tmp_path, steps):
    """Body b pushed through body a (a prescribed motion along −Y, 2.5 in 1 s; the gap
    is 2): the run goes on and warns once, at the first step within the thickness
    (0.1) of a, naming both; with fixed steps and with steps chosen by the local
    error.  Broke: the pair not remembered (``self.warned`` not added to): two
    warnings; the error-controlled loop without the components' look at each
    accepted state (as it was): none."""
    text = TWO.replace("end = 0.1", "end = 1.0").replace("dt = 0.1", "dt = 0.05")
    if steps == "error-controlled":
        text = text.replace("dt = 0.05", "dt = 0.05\ntolerance = 1e-3")
    text += (
        '[[motion]]\nbody = "b"\ncomponent = "uy"\nkind = "table"\n'
        "values = [[0.0, 0.0], [1.0, -2.5]]\n"
    )
    path = write_scene(tmp_path, text)
    done = subprocess.run(
        [sys.executable, "-m", "rftfem", "run", str(path), "--out", str(tmp_path / "out")],
        capture_output=True,
        text=True,
        cwd=ROOT,
    )
    warned = [line for line in (done.stdout + done.stderr).splitlines() if "came within" in line]
    print(warned)
    assert done.returncode == 0, done.stderr[-2000:]
    assert len(warned) == 1 and "bodies 'a' and 'b' came within" in warned[0]
    assert "at t = 0.8 " in warned[0]


#: two stiff strips 2 × 0.5 × 0.1 under gravity, a floor under one of them only
ON_ONE_FLOOR = """
title = "a floor under one of two strips"
[[body]]
name = "held"
mesh = {{ kind = "strip", length = 2.0, width = 0.5, divisions = [4, 1] }}
[[body]]
name = "falling"
mesh = {{ kind = "strip", length = 2.0, width = 0.5, divisions = [4, 1] }}
at = [0.0, 2.0, 0.0]
shell = {{ density = 3.0e-9 }}
[shell]
thickness = 0.1
E = 1.2e6
nu = 0.3
density = 1.0e-9
[time]
end = 0.02
dt = 1.0e-3
rho_inf = 0.0
[[load]]
kind = "gravity"
value = [0.0, 0.0, -9810.0]
ramp = "constant"
[[contact]]
kind = "plane"
{body}
point = [0.0, 0.0, -0.05]
normal = [0.0, 0.0, 1.0]
friction = 0.3
"""


def test_a_plane_on_one_body_holds_it_and_lets_the_other_fall(tmp_path):
    """``body`` on [[contact]]: the floor holds the strip it names, whose lower face
    starts on it, and not the other, which falls freely: its centroid at −g t²/2, exact
    for generalized-α under a constant load (reached 6e-14), and the floor's force on it
    (``falling_contact_Fz``) zero; the held strip's ``held_contact_Fz`` is the whole
    plane's.  Broke: the plane's terms not restricted to its body, so the floor held
    the falling strip too (its fall 100 % off)."""
    sim = _run(tmp_path, ON_ONE_FLOOR.format(body='body = "held"'))
    t, g = sim.t, 9810.0
    fall = _column(sim, "falling_centroid_z")
    print(f"fall {fall / (-g * t**2 / 2) - 1:.1e}, held {_column(sim, 'held_centroid_z'):.3g}")
    assert fall == pytest.approx(-g * t**2 / 2, rel=1e-12)
    assert _column(sim, "falling_contact_Fz") == 0.0
    held = _column(sim, "held_contact_Fz")
    assert held > 0.0 and held == pytest.approx(_column(sim, "contact_Fz"), rel=1e-14)
    assert abs(_column(sim, "held_centroid_z")) < 0.1 * 0.1  # within the reach δ = t/10
