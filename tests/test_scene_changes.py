"""Changing a scene from the command line and from Python (issue 62): removing a key
(``--unset KEY``, ``del scene[KEY]``, ``scene.pop``, a value None in ``update``),
tuples and numpy arrays where the scene takes lists, and whole floats where it takes
integers."""

from __future__ import annotations

import sys

import numpy as np
import pytest
from conftest import ROOT, run_command

import rftfem
from rftfem.errors import SceneError
from rftfem.scene.overrides import as_arguments
from rftfem.scene.reading import load_scene, unset_text

SHEET = ROOT / "demos" / "swimming_sheet.toml"
STOKES = ["fluid.model=stokes", unset_text("fluid.drag"), "fluid.viscosity=1e-9"]


def test_switching_the_sheet_to_stokes_flow_from_the_command_line():
    """The shipped RFT sheet in Stokes flow with three options and no edit: the drag
    is removed by --unset; left in, the refusal says how to drop it."""
    done = run_command(
        [sys.executable, "-m", "rftfem", "check", str(SHEET), "--set", "fluid.model=stokes"],
        cwd=ROOT,
    )
    assert done.returncode == 2
    assert "drop the drag with --unset fluid.drag" in done.stderr
    assert 'del scene["fluid.drag"]' in done.stderr
    done = run_command(
        [sys.executable, "-m", "rftfem", "check", str(SHEET), *as_arguments(STOKES)], cwd=ROOT
    )
    assert done.returncode == 0, done.stderr
    assert "fluid: stokes" in done.stdout


def test_unset_in_scene_files_and_override_texts():
    """--unset removes a key of a table or an entry of an array of tables; a key the
    scene does not set is left alone; a misspelt key, or one component of a vector,
    is refused naming --unset; the texts go to a child run as the same options."""
    scene = load_scene(SHEET, STOKES)
    assert scene["fluid"]["model"] == "stokes" and scene["fluid"]["drag"] is None
    assert scene["_overrides"][1] == "--unset fluid.drag"
    assert as_arguments(STOKES) == [
        "--set",
        "fluid.model=stokes",
        "--unset",
        "fluid.drag",
        "--set",
        "fluid.viscosity=1e-9",
    ]
    shear = ROOT / "demos" / "end_shear.toml"
    assert load_scene(shear, [unset_text("load.0")])["load"] == []
    assert load_scene(SHEET, [unset_text("magnetic.field")]) is not None  # not set: no-op
    with pytest.raises(
        SceneError,
        match=r"^--unset: unknown key 'fluid.dragg' "
        r"\(did you mean 'fluid.drag'\?\)",
    ):
        load_scene(SHEET, [unset_text("fluid.dragg")])
    with pytest.raises(
        SceneError,
        match=r"^--unset load.0.value.1: 'load.0.value' is a "
        r"value: unset it whole",
    ):
        load_scene(shear, [unset_text("load.0.value.1")])


def test_python_removes_keys_and_takes_python_values():
    """del, pop and None in update remove keys (recorded as --unset, as summary.json
    keeps them); tuples, numpy arrays and whole floats are taken where the scene
    wants lists and integers."""
    scene = rftfem.load_scene(SHEET)
    scene.update({"fluid.model": "stokes", "fluid.drag": None, "fluid.viscosity": 1e-9})
    assert scene["fluid.model"] == "stokes" and scene["fluid.drag"] is None
    assert scene.overrides == ['fluid.model="stokes"', "--unset fluid.drag", "fluid.viscosity=1e-9"]
    other = rftfem.load_scene(SHEET)
    assert other.pop("output.probes")[0]["name"] == "front"
    assert other.get("output.probes") == [] and other.pop("output.probes", 7) == 7
    with pytest.raises(KeyError):
        del other["output.probes"]
    with pytest.raises(SceneError, match="give either fluid.drag or fluid.viscosity"):
        del other["fluid.drag"]  # alone it leaves RFT without coefficients
    scene["mesh.divisions"] = (20, 4)
    assert scene["mesh.divisions"] == [20, 4]
    scene["mesh.divisions"] = np.array([10, 2])
    assert scene["mesh.divisions"] == [10, 2] and scene.overrides[-1] == "mesh.divisions=[10, 2]"
    scene["mesh.divisions"] = [30.0, 6.0]
    assert scene["mesh.divisions"] == [30, 6]
    assert all(type(n) is int for n in scene.to_dict()["mesh"]["divisions"])
    scene["shell.axis"] = np.array([1.0, 0.0, 0.0])
    with pytest.raises(SceneError, match=r"found \[20.5, 4\]"):
        scene["mesh.divisions"] = [20.5, 4.0]
