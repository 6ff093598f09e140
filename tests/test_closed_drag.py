"""RFT drag on a closed body (issue 59): with C₁ = C₂ the liquid resists every tangent
direction alike and the drag needs no material axis (forms.drag.transverse_drag_tensor),
so a sphere, on which no axis is tangent everywhere, is a legal RFT scene; with
C₁ ≠ C₂ it is refused in one line naming a point where the axis meets the normal."""

from __future__ import annotations

import sys

import numpy as np
import pytest
from conftest import ROOT, run_command, write_scene
from stokes_bodies import write_ellipsoid

RHO, T, G = 1.0e-9, 0.01, 9810.0

SPHERE = f"""
title = "a closed spherical shell sinking in a liquid"
[mesh]
kind = "gmsh"
file = "sphere.msh"
[shell]
thickness = {T}
E = 1.0e3
nu = 0.3
density = {RHO}
[fluid]
drag = DRAG
[time]
scheme = "backward-euler"
end = 0.3
dt = 0.1
[[load]]
kind = "gravity"
value = [0.0, 0.0, -{G}]
ramp = "constant"
"""


@pytest.fixture(scope="module")
def sphere(tmp_path_factory):
    folder = tmp_path_factory.mktemp("sphere")
    write_ellipsoid(folder / "sphere.msh", size=0.5)
    return folder


@pytest.mark.parametrize(
    "drag", [(2e-6, 2e-6, 2e-6), (1e-6, 1e-6, 5e-6)], ids=["isotropic", "transverse"]
)
def test_sphere_sinks_at_its_terminal_speed(sphere, drag):
    """A sphere sinking under its weight translates at ρ t g / C̄ with C̄ the drag
    tensor averaged over the sphere's normals, (2 C₁ + C₃) / 3 (the mean of n⊗n over a
    sphere is I/3), to 1e-3: reached 1.15e-4 and 1.12e-4 on this mesh of 9-node
    cells, where the weight (quadrature degree 2) and the drag (degree 4) integrate
    the curved cells' area differently by about that much.  A wrong tensor is far
    off: C₁ and C₃ swapped would sink 36 % slower."""
    c1, _, c3 = drag
    scene = write_scene(sphere, SPHERE.replace("DRAG", str(list(drag))), name=f"sphere-{c3}.toml")
    out = sphere / f"out-{c3}"
    done = run_command(
        [
            sys.executable,
            "-m",
            "rftfem",
            "run",
            str(scene),
            "--out",
            str(out),
            "--quiet",
            "--set",
            "output.fields=false",
        ],
        cwd=ROOT,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    import json

    fluid = json.loads((out / "summary.json").read_text())["fluid"]
    assert fluid == {"model": "rft", "drag": list(drag), "from": "fluid.drag", "axis_free": True}
    body = np.genfromtxt(out / "body.csv", delimiter=",", names=True)
    speed = -np.diff(body["centroid_z"]) / np.diff(body["time"])
    exact = RHO * T * G / ((2 * c1 + c3) / 3)
    print(f"{drag}: speeds {speed}, exact {exact}")
    assert np.abs(speed / exact - 1).max() < 1e-3
    for axis in "xy":
        assert (
            np.abs(body[f"centroid_{axis}"] - body[f"centroid_{axis}"][0]).max()
            < 1e-3 * exact * body["time"][-1]
        )


def _model(folder, text, name):
    from mpi4py import MPI

    from rftfem.meshes import build_body
    from rftfem.model.shell_model import Model
    from rftfem.scene.reading import load_scene

    scene = load_scene(write_scene(folder, text, name=name))
    return Model(
        scene, build_body(MPI.COMM_SELF, scene["mesh"], scene_dir=folder), compile_forms=False
    )


def test_anisotropic_drag_on_a_sphere_names_the_point(sphere):
    """C₁ ≠ C₂ needs the material axis in the tangent plane; given along the reference
    director of one node of the sphere it is refused in one line naming the count and
    that node (or its opposite one); with C₁ = C₂ the same axis is accepted."""
    from rftfem.errors import SceneError

    isotropic = SPHERE.replace("DRAG", "[1e-6, 1e-6, 5e-6]")
    model = _model(sphere, isotropic, "probe.toml")
    D = model.D.x.array.reshape(-1, 3)
    k = int(np.argmax(D[:, 0] + 0.3 * D[:, 1] + 0.1 * D[:, 2]))  # a node off every axis
    node = model.Vu.tabulate_dof_coordinates()[k]
    with_axis = isotropic.replace("nu = 0.3", f"nu = 0.3\naxis = {[float(v) for v in D[k]]}")
    _model(sphere, with_axis, "axis.toml")  # C1 = C2: no axis needed
    with pytest.raises(SceneError) as error:
        _model(sphere, with_axis.replace("[1e-6, 1e-6,", "[1e-6, 2e-6,"), "anisotropic.toml")
    text = str(error.value)
    print(text)
    assert "\n" not in text
    assert text.startswith("shell.axis: expected a direction not along the shell normal")
    assert "give fluid.drag with C1 = C2" in text
    count = int(text.split("along the normal at ")[1].split(" node(s)")[0])
    assert count in (1, 2), text
    named = np.array([float(v) for v in text.split("the first at (")[1].split(")")[0].split(",")])
    assert np.allclose(np.abs(named), np.abs(node), atol=1e-5), (named, node)
