"""Scene loading: defaults, --set overrides, effects/scheme, and malformed scenes.

Malformed scenes live in tests/scenes_bad/; the first line of each says which
substrings the error message must contain: ``# expect: key.path | other text``.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from rftfem.errors import SceneError
from rftfem.scene.reading import (
    active_effects,
    apply_override,
    hinge_line,
    load_scene,
    resolved_scheme,
)

BAD = Path(__file__).parent / "scenes_bad"
#: fixtures whose error needs the mesh (second line "# found by: rftfem check") are
#: run by test_cli's `rftfem check` only
BAD_SCENES = sorted(
    p for p in BAD.glob("*.toml") if "# found by: rftfem check" not in p.read_text()
)

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
    assert s["mesh"] == {
        "kind": "strip",
        "length": 10.0,
        "width": 1.0,
        "link_width": None,
        "hinge_stiffness": None,
        "divisions": [16, 1],
        "grading": 1.0,
        "cell": "quadrilateral",
        "file": None,
        "regions": [],
    }
    assert s["shell"] == {
        "material": "isotropic",
        "thickness": 0.1,
        "E": 1.2e6,
        "nu": 0.0,
        "density": 0.0,
        "E1": None,
        "E2": None,
        "G12": None,
        "nu12": None,
        "G13": None,
        "G23": None,
        "axis": [1.0, 0.0, 0.0],
        "fibre": None,
        "parts": [],
    }
    assert s["time"] == {
        "end": 1.0,
        "dt": 0.01,
        "scheme": "static",
        "start": "rest",
        "rho_inf": 0.9,
        "alpha": -0.05,
        "output_every": 1,
        "until": "end",
        "period": None,
        "steady_tolerance": 1e-3,
        "max_steps": 1000,
        "max_cuts": 8,
        "tolerance": None,
        "dt_min": None,
        "dt_max": None,
        "max_rotation": 0.2,
    }
    assert s["boundary"] == [] and s["load"] == [] and s["motion"] == [] and s["hinge"] == []
    assert s["fluid"] is None and s["magnetic"] is None
    assert s["output"] == {"probes": [], "fields": True, "render": "none", "checkpoint_every": 0}
    assert s["solver"] == {}


def test_good_scene_values_and_inherited_part_values(write):
    s = load_scene(write(GOOD))
    assert s["mesh"]["length"] == 12.0 and isinstance(s["mesh"]["length"], float)
    part = s["shell"]["parts"][0]
    assert part == {
        "region": "end1",
        "E": 400.0,
        "nu": 0.0,
        "thickness": 0.1,
        "density": 0.0,
        "E1": None,
        "E2": None,
        "G12": None,
        "nu12": None,
        "G13": None,
        "G23": None,
    }
    assert s["load"][0] == {
        "kind": "edge-moment",
        "where": "x=L",
        "value": [0.0, 52.36, 0.0],
        "ramp": "linear",
        "table": None,
    }
    assert s["solver"] == {"snes_rtol": 1e-8, "pc_type": "lu"}
    assert active_effects(s) == ["elasticity", "edge-moment"]


def test_nested_defaults_in_optional_tables(write):
    s = load_scene(
        write(
            GOOD
            + """
[[motion]]
component = "uz"
amplitude = 0.15
[magnetic]
[[magnetic.parts]]
region = "end1"
magnetization = 62.9
direction = [1, 0, 0]
"""
        )
    )
    assert s["motion"][0] == {
        "where": "all",
        "name": None,
        "component": "uz",
        "kind": "travelling-wave",
        "amplitude": 0.15,
        "wavenumber": 0.0,
        "angular_frequency": 0.0,
        "origin": 0.0,
        "ramp_time": 0.0,
        "rotation_axis": [0.0, 0.0, 1.0],
        "centre": [0.0, 0.0, 0.0],
        "phase": 0.0,
        "values": None,
    }
    assert s["magnetic"]["field"] == {
        "kind": "rotating",
        "strength": 0.0,
        "ramp_time": 0.0,
        "direction": [1.0, 0.0, 0.0],
        "frequency": 0.0,
        "rotation_axis": [0.0, 0.0, 1.0],
        "B": None,
        "values": None,
        "interpolation": None,
        "moment": None,
        "position": None,
        "path": None,
    }
    assert s["magnetic"]["parts"][0]["direction"] == [1.0, 0.0, 0.0]


def test_gmsh_file_resolved_relative_to_scene(tmp_path, monkeypatch):
    (tmp_path / "meshes").mkdir()
    (tmp_path / "meshes" / "plate.msh").write_text("$MeshFormat\n")
    scene = tmp_path / "scenes" / "plate.toml"
    scene.parent.mkdir()
    scene.write_text(
        MINIMAL.replace("[mesh]", '[mesh]\nkind = "gmsh"\nfile = "../meshes/plate.msh"')
    )
    monkeypatch.chdir(tmp_path / "meshes")  # the current folder must not matter
    s = load_scene("../scenes/plate.toml")
    assert s["mesh"]["file"] == str((tmp_path / "meshes" / "plate.msh").resolve())
    assert s["_path"] == str(scene.resolve())


def test_gmsh_names_are_not_checked_here(tmp_path):
    (tmp_path / "plate.msh").write_text("x")
    p = tmp_path / "s.toml"
    p.write_text(
        MINIMAL.replace("[mesh]", '[mesh]\nkind = "gmsh"\nfile = "plate.msh"')
        + '[[boundary]]\nwhere = "left edge"\nfix = ["ux"]\n'
        '[[shell.parts]]\nregion = "head"\nE = 5.0\n'
    )
    s = load_scene(p)
    assert s["boundary"][0]["where"] == "left edge"
    assert s["shell"]["parts"][0]["region"] == "head"


# --------------------------------------------------------------- overrides


def test_overrides_scalar_array_word_index_and_new_table(write):
    s = load_scene(
        write(GOOD),
        [
            "time.dt=0.02",
            "mesh.divisions=[50,4]",
            "mesh.cell=triangle",
            "load.0.value=[0,52.36,0]",
            "fluid.drag=[1,1,2]",
            "boundary.0.where=x=L",
            "solver.ksp_type=preonly",
            'title="a new title"',
        ],
    )
    assert s["time"]["dt"] == 0.02
    assert s["mesh"]["divisions"] == [50, 4]
    assert s["mesh"]["cell"] == "triangle"
    assert s["load"][0]["value"] == [0.0, 52.36, 0.0]
    assert s["fluid"]["drag"] == [1.0, 1.0, 2.0] and s["fluid"]["model"] == "rft"
    assert s["boundary"][0]["where"] == "x=L"
    assert s["solver"]["ksp_type"] == "preonly"
    assert s["title"] == "a new title"
    assert active_effects(s) == ["elasticity", "drag", "edge-moment"]
    assert s["time"]["scheme"] == "backward-euler"


PARAMETERS = (
    MINIMAL
    + """
[parameters]
wavelength = 3.7
phase = 0.5
[[magnetic.parts]]
region = "all"
magnetization = "62*cos(phase)"
direction = ["cos(2*pi*X/wavelength + phase)", "0", "sin(2*pi*X/wavelength+phase)"]
[magnetic.field]
strength = 1e-6
"""
)


def test_parameters_are_numbers_in_the_formulas(write):
    """[parameters]: each use in a formula becomes its number (a formula left without
    variables is a number), one --set changes every use; names the formulas own and
    names not defined are refused."""
    s = load_scene(write(PARAMETERS), ["parameters.wavelength=5"])
    part = s["magnetic"]["parts"][0]
    assert part["direction"] == ["cos(2*pi*X/(5.0) + (0.5))", 0.0, "sin(2*pi*X/(5.0)+(0.5))"]
    assert part["magnetization"] == pytest.approx(62 * math.cos(0.5), rel=1e-15)
    assert s["parameters"] == {"wavelength": 5, "phase": 0.5}
    assert "'phas'" in scene_error(write(PARAMETERS.replace("+phase)", "+phas)")))
    assert scene_error(write(PARAMETERS), ["parameters.t=1"]).startswith("parameters.t: expected")
    assert scene_error(write(PARAMETERS), ["parameters.k=x"]).startswith("parameters.k: expected")


def test_overrides_apply_in_order_and_to_nested_optional_table():
    data = {"title": "t"}
    apply_override(data, "magnetic.field.frequency=8")
    apply_override(data, "magnetic.field.frequency=9")
    apply_override(data, "shell.nu=0.3")
    assert data == {"title": "t", "magnetic": {"field": {"frequency": 9}}, "shell": {"nu": 0.3}}


def test_override_value_is_validated_afterwards(write):
    msg = scene_error(write(GOOD), ["shell.thickness=-1"])
    assert msg.startswith("shell.thickness:") and "-1" in msg


@pytest.mark.parametrize(
    "text, words",
    [
        ("mesh.lenght=3", ["mesh.lenght", "mesh.length"]),
        ("load.3.value=[0,1,0]", ["load.3.value", "out of range"]),
        ("load.first.value=[0,1,0]", ["load.first.value", "index"]),
        ("shell.thickness.x=1", ["shell.thickness.x"]),
        ("output.probes.0.position=[1,0,0]", ["output.probes.0.position", "at"]),
        ("motion.0.component=uz", ["motion.0.component", "out of range"]),
        ("nonsense=1", ["nonsense"]),
        ("time.dt", ["time.dt", "KEY=VALUE"]),
        ("time.end=1.0.0", ["time.end", "TOML value"]),
    ],
)
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

    s = load_scene(
        write(
            GOOD
            + """
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
""",
            "all.toml",
        ),
        ["shell.density=1", "fluid.drag=[1,1,1]"],
    )
    assert active_effects(s) == [
        "elasticity",
        "inertia",
        "drag",
        "magnetic",
        "edge-force",
        "edge-moment",
        "prescribed-motion",
    ]


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
    assert 'found the string "many"' in scene_error(write(GOOD), ['mesh.divisions="many"'])
    # a whole float is the integer it is (issue 62: Python and numpy give them)
    assert load_scene(write(GOOD), ["mesh.divisions=[16.0, 1]"])["mesh"]["divisions"] == [16, 1]
    msg = scene_error(write(GOOD), ["mesh.divisions=[16.5, 1]"])
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
    assert msg.startswith("solver.-pc_type:")


def test_missing_required(write):
    assert scene_error(write(GOOD.replace('title = "roll-up"', ""))).startswith(
        "missing required key 'title'"
    )
    msg = scene_error(write(GOOD.replace('kind = "edge-moment"\n', "")))
    assert "load.0.kind" in msg and "edge-moment" in msg
    assert scene_error(write(MINIMAL.replace("[shell]", ""))) == "missing required section [shell]"


def test_scene_file_problems(tmp_path):
    msg = scene_error(tmp_path / "absent.toml")
    assert "absent.toml" in msg and "not found" in msg
    msg = scene_error(tmp_path)
    assert "directory" in msg
    binary = tmp_path / "binary.toml"
    binary.write_bytes(b"\xff\xfe\x00\x01title")
    assert "binary.toml" in scene_error(binary)


THREE_LINK = """
title = "three-link"
[mesh]
kind = "three-link"
length = 5.0
divisions = [10, 2]
[shell]
[time]
"""


def test_three_link_defaults_and_width(write):
    s = load_scene(write(THREE_LINK))
    assert s["mesh"] == {
        "kind": "three-link",
        "length": 5.0,
        "width": 1.5,
        "link_width": 0.5,
        "hinge_stiffness": 0.0,
        "divisions": [10, 2],
        "grading": 1.0,
        "cell": "quadrilateral",
        "file": None,
        "regions": [],
    }
    assert s["hinge"] == []
    s = load_scene(write(THREE_LINK), ["mesh.link_width=0.4", "mesh.hinge_stiffness=2"])
    assert s["mesh"]["width"] == pytest.approx(1.2) and s["mesh"]["hinge_stiffness"] == 2.0
    # the three-link keys are dropped for another kind, as mesh.file is
    s = load_scene(
        write(THREE_LINK), ["mesh.link_width=0.4", "mesh.hinge_stiffness=2", "mesh.kind=strip"]
    )
    assert s["mesh"]["width"] == 1.0
    assert s["mesh"]["link_width"] is None and s["mesh"]["hinge_stiffness"] is None
    # the width of a three-link body comes from link_width only
    msg = scene_error(write(GOOD), ["mesh.kind=three-link", "mesh.width=1.5"])
    assert msg.startswith("mesh.width:") and "mesh.link_width" in msg
    assert scene_error(write(THREE_LINK), ["mesh.link_width=-1"]).startswith("mesh.link_width:")
    assert scene_error(write(THREE_LINK), ["mesh.link_width=1e308"]).startswith("mesh.link_width:")
    msg = scene_error(write(THREE_LINK), ["mesh.hinge_stiffness=-1"])
    assert msg.startswith("mesh.hinge_stiffness:") and ">= 0" in msg
    msg = scene_error(write(THREE_LINK), ["mesh.kind=three-links"])
    assert msg.startswith("mesh.kind:") and 'did you mean "three-link"' in msg


def test_three_link_probes_span_three_links(write):
    probe = '[[output.probes]]\nname = "p"\nat = [5.0, {y}, 0.0]\n'
    assert load_scene(write(THREE_LINK + probe.format(y=1.5)))["output"]["probes"][0]["at"] == [
        5.0,
        1.5,
        0.0,
    ]
    msg = scene_error(write(THREE_LINK + probe.format(y=1.6)))
    assert msg.startswith("output.probes.0.at:") and "0 <= y <= 1.5" in msg


def test_y_bands_and_rectangles(write):
    s = load_scene(
        write(
            MINIMAL
            + """
[[mesh.regions]]
name = "band"
y = [0.0, 0.5]
[[mesh.regions]]
name = "corner"
x = [0, 1]
y = [0.5, 1]
"""
        )
    )
    assert s["mesh"]["regions"] == [
        {"name": "band", "x": None, "y": [0.0, 0.5]},
        {"name": "corner", "x": [0.0, 1.0], "y": [0.5, 1.0]},
    ]
    assert load_scene(write(GOOD))["mesh"]["regions"][0]["y"] is None
    msg = scene_error(write(GOOD), ["mesh.regions.0.y=[0.5, 0.5]"])
    assert msg.startswith("mesh.regions.0.y:") and "selects nothing" in msg
    msg = scene_error(write(GOOD), ["mesh.regions.0.y=[0.5, 1.2]"])
    assert msg.startswith("mesh.regions.0.y:") and "mesh.width = 1" in msg
    msg = scene_error(write(GOOD), ["mesh.regions.0.y=[0, 1, 2]"])
    assert msg.startswith("mesh.regions.0.y:") and "interval" in msg
    # the y band follows the width given by --set
    s = load_scene(write(GOOD), ["mesh.regions.0.y=[0.5, 1.2]", "mesh.width=1.2"])
    assert s["mesh"]["regions"][0]["y"] == [0.5, 1.2]
    # three-link: y bands against 3 * link_width, built-in names refused
    region = '[[mesh.regions]]\nname = "{name}"\ny = [{a}, {b}]\n'
    s = load_scene(write(THREE_LINK + region.format(name="edge", a=1.2, b=1.5)))
    assert s["mesh"]["regions"][0]["y"] == [1.2, 1.5]
    msg = scene_error(write(THREE_LINK + region.format(name="edge", a=1.2, b=1.6)))
    assert msg.startswith("mesh.regions.0.y:") and "3 * mesh.link_width = 1.5" in msg
    for name in ("left", "middle", "right", "hinge-left", "hinge-right"):
        msg = scene_error(write(THREE_LINK + region.format(name=name, a=0, b=1)))
        assert msg.startswith("mesh.regions.0.name:") and f"found '{name}'" in msg
    # on a strip those names are ordinary region names
    s = load_scene(write(MINIMAL + region.format(name="middle", a=0.25, b=0.75)))
    assert s["mesh"]["regions"][0]["name"] == "middle"


def test_three_link_built_in_regions_are_references(write):
    s = load_scene(
        write(
            THREE_LINK
            + """
[[shell.parts]]
region = "middle"
E = 10.0
[magnetic]
[[magnetic.parts]]
region = "left"
magnetization = 1.0
direction = [0, 1, 0]
[[magnetic.parts]]
region = "right"
magnetization = 1.0
direction = [0, -1, 0]
"""
        )
    )
    assert s["shell"]["parts"][0]["region"] == "middle"
    assert [p["region"] for p in s["magnetic"]["parts"]] == ["left", "right"]
    # on a strip they are not regions
    msg = scene_error(write(GOOD.replace('region = "end1"', 'region = "middle"')))
    assert msg.startswith("shell.parts.0.region:") and "unknown region 'middle'" in msg


def test_hinge_defaults_and_numbers(write):
    s = load_scene(write(GOOD + '[[hinge]]\nwhere = "y=0.5"\n'))
    assert s["hinge"] == [{"where": "y=0.5", "stiffness": 0.0}]
    for where in ("x=6", "x=6.", "x=.5", "x=+6.5", "y=5e-1", "y=5E-1", "x=1.1e+1", "x=11.999"):
        s = load_scene(write(GOOD + f'[[hinge]]\nwhere = "{where}"\nstiffness = 2\n'))
        assert s["hinge"] == [{"where": where, "stiffness": 2.0}]
    assert hinge_line("y=5e-1") == ("y", 0.5) and hinge_line("x=-1") == ("x", -1.0)
    for where in ("x=abc", "x = 1", "x=1e999", "z=1", "x=", "x=1,5", "end1", "x=0x1"):
        assert hinge_line(where) is None
        msg = scene_error(write(GOOD + f'[[hinge]]\nwhere = "{where}"\n'))
        assert msg.startswith("hinge.0.where:") and '"x=c" or "y=c"' in msg, msg
    msg = scene_error(write(GOOD + '[[hinge]]\nwhere = "y=0.5"\nstiffness = -1e-9\n'))
    assert msg.startswith("hinge.0.stiffness:") and ">= 0" in msg
    msg = scene_error(write(GOOD + "[[hinge]]\nstiffness = 1\n"))
    assert "hinge.0.where" in msg and msg.startswith("missing required key")
    msg = scene_error(write(GOOD + '[[hinge]]\nwhere = "y=0.5"\nangle = 1\n'))
    assert "hinge.0.angle" in msg


@pytest.mark.parametrize(
    "where, words",
    [
        ("x=0", ["lies on the body's boundary", "a hinge joins two sides", "0 < c < 12"]),
        ("x=12", ["lies on the body's boundary"]),
        ("x=L", ["lies on the body's boundary", "0 < c < 12"]),
        ("y=0", ["lies on the body's boundary", "0 < c < 1"]),
        ("y=W", ["lies on the body's boundary"]),
        ("y=1.0", ["lies on the body's boundary"]),
        ("y=0.999999999999", ["lies on the body's boundary"]),  # within 1e-9 of the width
        ("x=-0.0", ["lies on the body's boundary"]),
        ("x=13", ['"x=13" is not a line of the mesh', "the body spans x in [0, 12]"]),
        ("y=-0.5", ['"y=-0.5" is not a line of the mesh', "the body spans y in [0, 1]"]),
    ],
)
def test_hinge_must_lie_inside_the_body(write, where, words):
    msg = scene_error(write(GOOD + f'[[hinge]]\nwhere = "{where}"\n'))
    assert msg.startswith("hinge.0.where:"), msg
    for w in words:
        assert w in msg, msg


def test_two_hinges_on_one_line(write):
    two = '[[hinge]]\nwhere = "{}"\n[[hinge]]\nwhere = "{}"\n'
    for a, b in (("y=0.5", "y=0.5"), ("y=0.5", "y=0.50"), ("x=3", "x=3.000000000001")):
        msg = scene_error(write(GOOD + two.format(a, b)))
        assert msg.startswith("hinge.1.where: two hinges on one line"), msg
        assert f'hinge.0.where = "{a}"' in msg
    s = load_scene(write(GOOD + two.format("x=3", "y=0.5") + two.format("x=3.01", "y=0.25")))
    assert [h["where"] for h in s["hinge"]] == ["x=3", "y=0.5", "x=3.01", "y=0.25"]
    # three-link: its built-in hinges at y = w and 2w are lines already
    hinge = '[[hinge]]\nwhere = "{}"\n'
    for where in ("y=0.5", "y=1", "y=1.0000000000001", "hinge-left", "hinge-right"):
        msg = scene_error(write(THREE_LINK + hinge.format(where)))
        assert msg.startswith("hinge.0.where: two hinges on one line"), msg
        assert "mesh.hinge_stiffness" in msg
    # the lines follow mesh.link_width
    msg = scene_error(write(THREE_LINK + hinge.format("y=0.5")), ["mesh.link_width=0.25"])
    assert msg.startswith("hinge.0.where: two hinges on one line") and "y = 0.5" in msg
    msg = scene_error(write(THREE_LINK + hinge.format("y=0.8")), ["mesh.link_width=0.25"])
    assert msg.startswith("hinge.0.where:") and "the body spans y in [0, 0.75]" in msg
    s = load_scene(write(THREE_LINK + hinge.format("y=0.25") + hinge.format("x=2.5")))
    assert [h["where"] for h in s["hinge"]] == ["y=0.25", "x=2.5"]


def test_gmsh_hinges_are_curve_names_or_lines(tmp_path):
    (tmp_path / "plate.msh").write_text("x")
    p = tmp_path / "s.toml"
    text = MINIMAL.replace("[mesh]", '[mesh]\nkind = "gmsh"\nfile = "plate.msh"')
    hinge = '[[hinge]]\nwhere = "{}"\n'
    p.write_text(text + hinge.format("fold 1") + hinge.format("x=40") + hinge.format("x=-2"))
    s = load_scene(p)
    assert [h["where"] for h in s["hinge"]] == ["fold 1", "x=40", "x=-2"]
    for hinges, words in (
        (("fold", "fold"), ["hinge.1.where", "two hinges on one line"]),
        (("x=1", "x=1.0"), ["hinge.1.where", "two hinges on one line"]),
        (("x=L",), ["hinge.0.where", "boundary"]),
        (("x=one",), ["hinge.0.where", "physical curve name"]),
    ):
        p.write_text(text + "".join(hinge.format(h) for h in hinges))
        msg = scene_error(p)
        for w in words:
            assert w in msg, msg


def test_hinge_lines_are_selectors(write):
    s = load_scene(
        write(
            GOOD
            + """
[[hinge]]
where = "y=0.5"
[[hinge]]
where = "x=6"
stiffness = 1.0
[[motion]]
where = "x=6"
component = "uz"
"""
        ),
        ["boundary.0.where=y=0.5", "load.0.where=x=6"],
    )
    assert (s["boundary"][0]["where"], s["load"][0]["where"], s["motion"][0]["where"]) == (
        "y=0.5",
        "x=6",
        "x=6",
    )
    # a line that is not a hinge is not a selector; the message lists the hinge lines
    msg = scene_error(write(GOOD + '[[hinge]]\nwhere = "y=0.5"\n'), ["load.0.where=y=0.50"])
    assert msg.startswith("load.0.where: unknown selector 'y=0.50'")
    assert "y=W, y=0.5, end1" in msg and "did you mean 'y=0.5'" in msg
    assert scene_error(write(GOOD), ["load.0.where=hinge-left"]).startswith("load.0.where:")


def test_three_link_selectors(write):
    scene = (
        THREE_LINK
        + """
[[hinge]]
where = "x=2.5"
[[mesh.regions]]
name = "tip"
x = [4.5, 5.0]
"""
    )
    for where in (
        "hinge-left",
        "hinge-right",
        "left",
        "middle",
        "right",
        "x=2.5",
        "tip",
        "y=W",
        "all",
    ):
        s = load_scene(
            write(
                scene + f'[[boundary]]\nwhere = "{where}"\nfix = ["uz"]\n'
                f'[[motion]]\nwhere = "{where}"\ncomponent = "uz"\n'
            )
        )
        assert s["boundary"][0]["where"] == s["motion"][0]["where"] == where
    msg = scene_error(write(scene + '[[boundary]]\nwhere = "midle"\nfix = ["uz"]\n'))
    assert msg == (
        "boundary.0.where: unknown selector 'midle'; expected one of: all, x=0, "
        "x=L, y=0, y=W, hinge-left, hinge-right, x=2.5, left, middle, right, tip "
        "(did you mean 'middle'?)"
    )


def test_hinge_effects(write):
    hinge = '[[hinge]]\nwhere = "y=0.5"\nstiffness = {}\n'
    assert active_effects(load_scene(write(GOOD))) == ["elasticity", "edge-moment"]
    assert active_effects(load_scene(write(GOOD + hinge.format(0)))) == [
        "elasticity",
        "hinge",
        "edge-moment",
    ]
    s = load_scene(
        write(GOOD + hinge.format(0) + hinge.replace("0.5", "0.25").format(1e-3)),
        ["shell.density=1"],
    )
    assert active_effects(s) == ["elasticity", "hinge", "hinge-spring", "inertia", "edge-moment"]
    assert active_effects(load_scene(write(THREE_LINK))) == ["elasticity", "hinge"]
    s = load_scene(write(THREE_LINK), ["mesh.hinge_stiffness=0.5"])
    assert active_effects(s) == ["elasticity", "hinge", "hinge-spring"]
    # mesh.hinge_stiffness is dropped with the three-link kind
    s = load_scene(write(THREE_LINK), ["mesh.hinge_stiffness=0.5", "mesh.kind=strip"])
    assert active_effects(s) == ["elasticity"]
    # plain dicts (as summary.json echoes them)
    assert active_effects({"mesh": {"kind": "three-link", "hinge_stiffness": 1.0}}) == [
        "elasticity",
        "hinge",
        "hinge-spring",
    ]


def test_gmsh_mesh_file_changed_by_override(tmp_path):
    p = tmp_path / "s.toml"
    (tmp_path / "a.msh").write_text("x")
    p.write_text(MINIMAL.replace("[mesh]", '[mesh]\nkind = "gmsh"\nfile = "a.msh"'))
    msg = scene_error(p, ["mesh.file=b.msh"])
    assert msg.startswith("mesh.file:") and "b.msh" in msg
    # switching to a strip ignores the file
    assert load_scene(p, ["mesh.kind=strip"])["mesh"]["file"] is None
