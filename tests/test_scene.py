"""Scene loading: defaults, --set overrides, effects/scheme, and malformed scenes.

Malformed scenes live in tests/scenes_bad/; the first line of each says which
substrings the error message must contain: ``# expect: key.path | other text``.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from rftfem.errors import SceneError
from rftfem.scene import active_effects, apply_override, load_scene, resolved_scheme

BAD = Path(__file__).parent / "scenes_bad"
#: fixtures whose error needs the mesh (second line "# found by: rftfem check") are
#: run by test_cli's `rftfem check` only
BAD_SCENES = sorted(p for p in BAD.glob("*.toml")
                    if "# found by: rftfem check" not in p.read_text())

MINIMAL = """
title = "minimal"
[mesh]
[shell]
[time]
"""

GOOD = """
title = "roll-up"
[mesh]
length = 12
[[mesh.regions]]
name = "end1"
x = [0.0, 1.0]
[shell]
E = 1.2e6
[[shell.parts]]
region = "end1"
E = 400
[time]
end = 1.0
dt = 0.05
[[boundary]]
where = "x=0"
fix = ["clamped"]
[[load]]
kind = "edge-moment"
where = "x=L"
value = [0.0, 52.36, 0.0]
[[output.probes]]
name = "tip"
at = [12.0, 0.5, 0.0]
[solver]
snes_rtol = 1e-8
pc_type = "lu"
"""


def expectations(path: Path) -> list[str]:
    first = path.read_text().splitlines()[0]
    assert first.startswith("# expect:"), path
    return [s.strip() for s in first.split(":", 1)[1].split("|")]


@pytest.fixture
def write(tmp_path):
    def _write(text: str, name: str = "scene.toml") -> Path:
        p = tmp_path / name
        p.write_text(text)
        return p
    return _write


def scene_error(path, overrides=()) -> str:
    with pytest.raises(SceneError) as info:
        load_scene(path, overrides)
    message = str(info.value)
    assert message and "\n" not in message
    return message


# ---------------------------------------------------------------- defaults


def test_minimal_scene_gets_every_default(write):
    p = write(MINIMAL)
    s = load_scene(p)
    assert s["_path"] == str(p.resolve())
    assert s["mesh"] == {"kind": "strip", "length": 10.0, "width": 1.0, "divisions": [16, 1],
                         "cell": "quadrilateral", "file": None, "regions": []}
    assert s["shell"] == {"thickness": 0.1, "E": 1.2e6, "nu": 0.0, "density": 0.0,
                          "axis": [1.0, 0.0, 0.0], "parts": []}
    assert s["time"] == {"end": 1.0, "dt": 0.01, "scheme": "static", "rho_inf": 0.9,
                         "alpha": -0.05, "output_every": 1, "max_cuts": 8,
                         "max_rotation": 0.2}
    assert s["boundary"] == [] and s["load"] == [] and s["motion"] == []
    assert s["fluid"] is None and s["magnetic"] is None
    assert s["output"] == {"probes": [], "fields": True}
    assert s["solver"] == {}


def test_good_scene_values_and_inherited_part_values(write):
    s = load_scene(write(GOOD))
    assert s["mesh"]["length"] == 12.0 and isinstance(s["mesh"]["length"], float)
    part = s["shell"]["parts"][0]
    assert part == {"region": "end1", "E": 400.0, "nu": 0.0, "thickness": 0.1, "density": 0.0}
    assert s["load"][0] == {"kind": "edge-moment", "where": "x=L", "value": [0.0, 52.36, 0.0],
                            "ramp": "linear", "table": None}
    assert s["solver"] == {"snes_rtol": 1e-8, "pc_type": "lu"}
    assert active_effects(s) == ["elasticity", "edge-moment"]


def test_nested_defaults_in_optional_tables(write):
    s = load_scene(write(GOOD + """
[[motion]]
component = "uz"
amplitude = 0.15
[magnetic]
[[magnetic.parts]]
region = "end1"
magnetization = 62.9
direction = [1, 0, 0]
"""))
    assert s["motion"][0] == {"where": "all", "component": "uz", "kind": "travelling-wave",
                              "amplitude": 0.15, "wavenumber": 0.0, "angular_frequency": 0.0,
                              "origin": 0.0, "values": None}
    assert s["magnetic"]["field"] == {"strength": 0.0, "ramp_time": 0.0,
                                      "direction": [1.0, 0.0, 0.0], "frequency": 0.0,
                                      "rotation_axis": [0.0, 0.0, 1.0]}
    assert s["magnetic"]["parts"][0]["direction"] == [1.0, 0.0, 0.0]


def test_gmsh_file_resolved_relative_to_scene(tmp_path, monkeypatch):
    (tmp_path / "meshes").mkdir()
    (tmp_path / "meshes" / "plate.msh").write_text("$MeshFormat\n")
    scene = tmp_path / "scenes" / "plate.toml"
    scene.parent.mkdir()
    scene.write_text(MINIMAL.replace("[mesh]", '[mesh]\nkind = "gmsh"\nfile = "../meshes/plate.msh"'))
    monkeypatch.chdir(tmp_path / "meshes")  # the current folder must not matter
    s = load_scene("../scenes/plate.toml")
    assert s["mesh"]["file"] == str((tmp_path / "meshes" / "plate.msh").resolve())
    assert s["_path"] == str(scene.resolve())


def test_gmsh_names_are_not_checked_here(tmp_path):
    (tmp_path / "plate.msh").write_text("x")
    p = tmp_path / "s.toml"
    p.write_text(MINIMAL.replace("[mesh]", '[mesh]\nkind = "gmsh"\nfile = "plate.msh"')
                 + '[[boundary]]\nwhere = "left edge"\nfix = ["ux"]\n'
                   '[[shell.parts]]\nregion = "head"\nE = 5.0\n')
    s = load_scene(p)
    assert s["boundary"][0]["where"] == "left edge"
    assert s["shell"]["parts"][0]["region"] == "head"


# --------------------------------------------------------------- overrides


def test_overrides_scalar_array_word_index_and_new_table(write):
    s = load_scene(write(GOOD), [
        "time.dt=0.02",
        "mesh.divisions=[50,4]",
        "mesh.cell=triangle",
        "load.0.value=[0,52.36,0]",
        "fluid.drag=[1,1,2]",
        "boundary.0.where=x=L",
        "solver.ksp_type=preonly",
        'title="a new title"',
    ])
    assert s["time"]["dt"] == 0.02
    assert s["mesh"]["divisions"] == [50, 4]
    assert s["mesh"]["cell"] == "triangle"
    assert s["load"][0]["value"] == [0.0, 52.36, 0.0]
    assert s["fluid"] == {"drag": [1.0, 1.0, 2.0]}
    assert s["boundary"][0]["where"] == "x=L"
    assert s["solver"]["ksp_type"] == "preonly"
    assert s["title"] == "a new title"
    assert active_effects(s) == ["elasticity", "drag", "edge-moment"]
    assert s["time"]["scheme"] == "backward-euler"


def test_overrides_apply_in_order_and_to_nested_optional_table():
    data = {"title": "t"}
    apply_override(data, "magnetic.field.frequency=8")
    apply_override(data, "magnetic.field.frequency=9")
    apply_override(data, "shell.nu=0.3")
    assert data == {"title": "t", "magnetic": {"field": {"frequency": 9}}, "shell": {"nu": 0.3}}


def test_override_value_is_validated_afterwards(write):
    msg = scene_error(write(GOOD), ["shell.thickness=-1"])
    assert msg.startswith("shell.thickness:") and "-1" in msg


@pytest.mark.parametrize("text, words", [
    ("mesh.lenght=3", ["mesh.lenght", "mesh.length"]),
    ("load.3.value=[0,1,0]", ["load.3.value", "out of range"]),
    ("load.first.value=[0,1,0]", ["load.first.value", "index"]),
    ("shell.thickness.x=1", ["shell.thickness.x"]),
    ("output.probes.0.position=[1,0,0]", ["output.probes.0.position", "at"]),
    ("motion.0.component=uz", ["motion.0.component", "out of range"]),
    ("nonsense=1", ["nonsense"]),
    ("time.dt", ["time.dt", "KEY=VALUE"]),
    ("time.end=1.0.0", ["time.end", "TOML value"]),
])
def test_bad_override_paths(write, text, words):
    msg = scene_error(write(GOOD), [text])
    for w in words:
        assert w in msg, msg


# ------------------------------------------------------ effects and scheme


def test_effects_and_schemes(write):
    p = write(GOOD)
    s = load_scene(p, ["shell.density=1e-9"])
    assert active_effects(s) == ["elasticity", "inertia", "edge-moment"]
    assert resolved_scheme(s) == "generalized-alpha" == s["time"]["scheme"]

    s = load_scene(p, ["shell.parts.0.density=1e-9"])
    assert "inertia" in active_effects(s) and s["time"]["scheme"] == "generalized-alpha"

    s = load_scene(p, ["fluid.drag=[3e-9,3e-9,5.67e-9]", "load.0.kind=edge-force"])
    assert active_effects(s) == ["elasticity", "drag", "edge-force"]
    assert s["time"]["scheme"] == "backward-euler"

    s = load_scene(p, ["time.scheme=hht", "shell.density=1"])
    assert s["time"]["scheme"] == "hht"

    s = load_scene(write(GOOD + """
[[load]]
kind = "edge-force"
where = "x=L"
value = [0, 0, 1]
[[motion]]
component = "uz"
kind = "table"
values = [[0, 0], [1, 0.1]]
[magnetic]
[[magnetic.parts]]
region = "end1"
magnetization = 1
direction = [1, 0, 0]
""", "all.toml"), ["shell.density=1", "fluid.drag=[1,1,1]"])
    assert active_effects(s) == ["elasticity", "inertia", "drag", "magnetic", "edge-force",
                                 "edge-moment", "prescribed-motion"]


def test_explicit_second_order_scheme_needs_density(write):
    for scheme in ("generalized-alpha", "hht"):
        msg = scene_error(write(GOOD), [f"time.scheme={scheme}"])
        assert msg.startswith("time.scheme:") and "shell.density > 0" in msg


def test_resolved_scheme_on_plain_dict():
    assert resolved_scheme({"time": {"scheme": "auto"}, "shell": {"density": 0.0}}) == "static"
    with pytest.raises(SceneError):
        resolved_scheme({"time": {"scheme": "hht"}, "shell": {"density": 0.0}})


# ----------------------------------------------------------- malformed scenes


def test_there_are_enough_bad_scenes():
    assert len(BAD_SCENES) >= 13


@pytest.mark.parametrize("path", BAD_SCENES, ids=lambda p: p.stem)
def test_bad_scene_fixture(path):
    msg = scene_error(path)
    for text in expectations(path):
        assert text in msg, f"{path.name}: {text!r} not in {msg!r}"


def test_unknown_key_suggests_nearest(write):
    msg = scene_error(write(GOOD.replace("E = 1.2e6", "thicknes = 0.1\nE = 1.2e6")))
    assert msg == "unknown key 'shell.thicknes' (did you mean 'shell.thickness'?)"


def test_unknown_key_without_close_match_lists_keys(write):
    msg = scene_error(write(GOOD.replace("[time]", "[time]\nbanana = 1")))
    assert "time.banana" in msg and "end" in msg and "dt" in msg


def test_wrong_types(write):
    assert "found the string \"many\"" in scene_error(write(GOOD), ['mesh.divisions="many"'])
    msg = scene_error(write(GOOD), ["mesh.divisions=[16.0, 1]"])
    assert msg.startswith("mesh.divisions:") and "integers" in msg
    msg = scene_error(write(GOOD), ["shell.density=true"])  # bools are not numbers
    assert msg.startswith("shell.density:") and "boolean" in msg
    msg = scene_error(write(GOOD), ["output.fields=1"])
    assert msg.startswith("output.fields:") and "true or false" in msg
    msg = scene_error(write(GOOD), ["shell.axis=[0,0,0]"])
    assert msg.startswith("shell.axis:") and "nonzero" in msg
    msg = scene_error(write(GOOD), ["time.rho_inf=1.5"])
    assert msg.startswith("time.rho_inf:")
    msg = scene_error(write(GOOD), ["time.max_cuts=-1"])
    assert msg.startswith("time.max_cuts:")


def test_nu_range(write):
    assert load_scene(write(GOOD), ["shell.nu=0.49"])["shell"]["nu"] == 0.49
    for bad in ("0.5", "-1", "0.7"):
        assert scene_error(write(GOOD), [f"shell.nu={bad}"]).startswith("shell.nu:")
    assert scene_error(write(GOOD), ["shell.parts.0.nu=0.5"]).startswith("shell.parts.0.nu:")


def test_probes(write):
    s = load_scene(write(GOOD), ["output.probes.0.at=[0, 0, 0]"])
    assert s["output"]["probes"][0]["at"] == [0.0, 0.0, 0.0]
    msg = scene_error(write(GOOD), ["output.probes.0.at=[6, 1.5, 0]"])
    assert msg.startswith("output.probes.0.at:") and "probe outside the body" in msg
    # the strip changes length with --set: the probe at x = 12 falls off a 10 mm strip
    msg = scene_error(write(GOOD), ["mesh.length=10"])
    assert msg.startswith("output.probes.0.at:") and "probe outside the body" in msg


def test_regions(write):
    msg = scene_error(write(GOOD), ["mesh.regions.0.x=[2, 1]"])
    assert msg.startswith("mesh.regions.0.x:") and "selects nothing" in msg
    msg = scene_error(write(GOOD), ["mesh.regions.0.name=all"])
    assert msg.startswith("mesh.regions.0.name:")
    msg = scene_error(write(GOOD), ['mesh.regions.0.name="end 1"'])
    assert msg.startswith("mesh.regions.0.name:")


def test_unknown_where_lists_valid_selectors(write):
    msg = scene_error(write(GOOD), ["load.0.where=tip"])
    assert msg.startswith("load.0.where:")
    for valid in ("all", "x=0", "x=L", "y=0", "y=W", "end1"):
        assert valid in msg
    assert load_scene(write(GOOD), ["load.0.where=end1"])["load"][0]["where"] == "end1"


def test_table_ramp_and_motion_values(write):
    s = load_scene(write(GOOD), ["load.0.ramp=table", "load.0.table=[[0,0],[1,2]]"])
    assert s["load"][0]["table"] == [[0.0, 0.0], [1.0, 2.0]]
    msg = scene_error(write(GOOD), ["load.0.ramp=table"])
    assert "load.0.table" in msg
    msg = scene_error(write(GOOD), ["load.0.table=[[0,0],[1,2]]"])
    assert msg.startswith("load.0.table:") and "ramp" in msg
    msg = scene_error(write(GOOD + '[[motion]]\ncomponent = "uz"\nkind = "table"\n'))
    assert "motion.0.values" in msg


def test_solver_option_names(write):
    msg = scene_error(write(GOOD.replace("pc_type", '"-pc_type"')))
    assert msg.startswith('solver.-pc_type:')


def test_missing_required(write):
    assert scene_error(write(GOOD.replace('title = "roll-up"', ""))) \
        .startswith("missing required key 'title'")
    msg = scene_error(write(GOOD.replace('kind = "edge-moment"\n', "")))
    assert "load.0.kind" in msg and "edge-moment" in msg
    assert scene_error(write(MINIMAL.replace("[shell]", ""))) == \
        "missing required section [shell]"


def test_scene_file_problems(tmp_path):
    msg = scene_error(tmp_path / "absent.toml")
    assert "absent.toml" in msg and "not found" in msg
    msg = scene_error(tmp_path)
    assert "directory" in msg
    binary = tmp_path / "binary.toml"
    binary.write_bytes(b"\xff\xfe\x00\x01title")
    assert "binary.toml" in scene_error(binary)


def test_gmsh_mesh_file_changed_by_override(tmp_path):
    p = tmp_path / "s.toml"
    (tmp_path / "a.msh").write_text("x")
    p.write_text(MINIMAL.replace("[mesh]", '[mesh]\nkind = "gmsh"\nfile = "a.msh"'))
    msg = scene_error(p, ["mesh.file=b.msh"])
    assert msg.startswith("mesh.file:") and "b.msh" in msg
    # switching to a strip ignores the file
    assert load_scene(p, ["mesh.kind=strip"])["mesh"]["file"] is None
