"""The Python API (docs/python.md): scenes validated like the command line's, runs
equal to the command line's to the bit, results as DataFrames, pickling."""

from __future__ import annotations

import io
import pickle
import re
import subprocess
import sys
from contextlib import redirect_stderr
from pathlib import Path

import numpy as np
import pytest
from conftest import CANTILEVER, run_command

import rftfem
from rftfem import cli

BAD = Path(__file__).parent / "scenes_bad"
DEMOS = Path(__file__).parents[1] / "demos"


#: a short swim in drag (RFT, backward Euler) with a travelling wave: every table
SWIM = ["time.end=0.0125", "time.dt=0.003125", "time.until=end", "output.fields=false"]


def cli_error(*argv) -> str:
    """The one line `rftfem ARGV` says on stderr, run in this process."""
    err = io.StringIO()
    with redirect_stderr(err):
        status = cli.main([str(a) for a in argv])
    assert status == 2, err.getvalue()
    lines = err.getvalue().splitlines()
    assert len(lines) == 1, lines
    return lines[0]


def api_error(call) -> str:
    with pytest.raises(rftfem.SceneError) as info:
        call()
    return f"rftfem: error: {info.value}"


# ------------------------------------------------------------------ scenes


def test_import_is_cheap_and_public_names_load_on_use():
    code = (
        "import sys, rftfem; heavy = [m for m in ('dolfinx', 'ufl', 'numpy', 'pandas', "
        "'pyvista') if m in sys.modules]; assert not heavy, heavy; "
        "assert rftfem.load_scene.__module__ == 'rftfem.api'; "
        "assert rftfem.Result.__module__ == 'rftfem.result'; print('ok')"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.stdout.strip() == "ok", done.stderr


@pytest.mark.parametrize("path", sorted(BAD.glob("*.toml")), ids=lambda p: p.stem)
def test_every_bad_scene_gives_the_command_line_message(path):
    def load_and_check():
        rftfem.load_scene(path).check()

    assert api_error(load_and_check) == cli_error("check", path)


@pytest.mark.parametrize(
    "key, value, text",
    [
        ("shell.E", -5, "-5"),
        ("shell.EE", 1.0, "1.0"),
        ("load.3.value", [0, 0, 1], "[0,0,1]"),
        ("time.scheme", "leapfrog", "leapfrog"),
        ("mesh.divisions", [0, 1], "[0,1]"),
        ("time.dt.x", 1, "1"),
    ],
)
def test_a_bad_change_gives_the_command_line_message(tmp_path, key, value, text):
    """The command line's words, in Python's form: ``scene["KEY"]: ...`` where the
    command line says ``--set KEY: ...`` (a new user read "--set" from Python as a
    mistake of their own)."""
    path = tmp_path / "cantilever.toml"
    path.write_text(CANTILEVER)
    cli = cli_error("check", path, "--set", f"{key}={text}")
    # the same words, naming the key in Python's form where the command line names --set
    expected = cli.replace(f"--set {key}: ", f'scene["{key}"]: ').replace(
        "--set: ", f'scene["{key}"]: '
    )
    assert ("--set" in cli) == (expected != cli) and "--set" not in expected
    assert api_error(lambda: rftfem.load_scene(path, set={key: value})) == expected
    scene = rftfem.load_scene(path)
    before = scene.to_dict()
    assert api_error(lambda: scene.__setitem__(key, value)) == expected
    assert scene.to_dict() == before and scene.overrides == []  # refused as a whole


def test_changes_are_validated_and_read_back(tmp_path):
    scene = rftfem.scene_from_toml(CANTILEVER, folder=tmp_path)
    assert scene["shell.E"] == 1.0e4 and scene["shell.nu"] == 0.0  # a default filled in
    assert scene["load.0.value"] == [0.0, 0.0, 1.0e-3]
    assert scene["fluid"] is None and scene.get("fluid.drag", "none") == "none"
    scene["shell.E"] = 2.0e4
    assert scene["shell.E"] == 2.0e4 and scene.overrides == ["shell.E=20000.0"]
    with pytest.raises(rftfem.SceneError, match="time.dt: expected a number <= time.end"):
        scene["time.dt"] = 2.0
    scene.update({"time.dt": 2.0, "time.end": 4.0})  # together they agree
    assert (scene["time.dt"], scene["time.end"]) == (2.0, 4.0)
    value = scene["load.0.value"]
    value[2] = 99.0  # a copy: the scene is changed only through assignment
    assert scene["load.0.value"][2] == 1.0e-3
    with pytest.raises(rftfem.SceneError, match="unknown key 'shell.EE'"):
        scene["shell.EE"]


def test_a_scene_from_a_dict_or_text_is_the_file_scene(tmp_path):
    import tomllib

    path = DEMOS / "swimming_sheet.toml"
    from_file = rftfem.load_scene(path)
    raw = tomllib.loads(path.read_text())
    assert rftfem.scene_from_dict(raw) == from_file
    assert rftfem.scene_from_toml(path.read_text()) == from_file
    assert rftfem.scene_from_toml(from_file.to_toml()) == from_file
    with pytest.raises(rftfem.SceneError, match="scene text is not valid TOML"):
        rftfem.scene_from_toml("title = ")


def test_scenes_results_and_errors_pickle(tmp_path):
    scene = rftfem.load_scene(DEMOS / "three_link.toml", set={"time.end": 0.5})
    scene["shell.E"] = 3.0e5
    back = pickle.loads(pickle.dumps(scene))
    assert back == scene and back.overrides == scene.overrides and back.path == scene.path
    (tmp_path / "summary.json").write_text('{"status": "ok"}')
    result = pickle.loads(pickle.dumps(rftfem.Result(tmp_path)))
    assert result.folder == tmp_path and result.ok
    failed = rftfem.RunFailed("Newton diverged", 0.25, 3)
    failed.folder = tmp_path
    again = pickle.loads(pickle.dumps(failed))
    assert (str(again), again.time, again.step, again.folder) == (str(failed), 0.25, 3, tmp_path)
    error = pickle.loads(pickle.dumps(rftfem.SceneError("shell.E: expected ...")))
    assert str(error) == "shell.E: expected ..."


# ------------------------------------------------------------------ runs


def test_an_api_run_is_the_command_line_run_to_the_bit(tmp_path, capfd):
    scene_file = DEMOS / "swimming_sheet.toml"
    overrides = dict(s.split("=", 1) for s in SWIM)
    values = {"time.end": 0.0125, "time.dt": 0.003125, "time.until": "end", "output.fields": False}
    assert set(values) == set(overrides)
    scene = rftfem.load_scene(scene_file, set=values)
    capfd.readouterr()
    result = rftfem.run(scene, out=tmp_path / "api")
    said = capfd.readouterr()
    assert said.out == "" and said.err == ""  # quiet by default
    sets = [a for s in SWIM for a in ("--set", s)]
    done = run_command(
        [
            sys.executable,
            "-m",
            "rftfem",
            "run",
            scene_file,
            *sets,
            "--out",
            tmp_path / "cli",
            "--quiet",
        ],
        timeout=300,
    )
    assert done.returncode == 0, done.stderr
    cli_result = rftfem.Result(tmp_path / "cli")
    for name in ("probes", "body", "steps"):
        ours, theirs = getattr(result, name), getattr(cli_result, name)
        if name == "steps":
            ours, theirs = ours.drop(columns="wall_s"), theirs.drop(columns="wall_s")
        assert list(ours.columns) == list(theirs.columns)
        assert len(ours) > 1
        assert np.array_equal(ours.to_numpy(), theirs.to_numpy()), name
    assert result.summary["scene"] == cli_result.summary["scene"]
    assert result.ok and result.summary["overrides"] == [
        "time.end=0.0125",
        "time.dt=0.003125",
        'time.until="end"',
        "output.fields=false",
    ]
    # a quantity is collect's
    assert result.quantity("max(front_uz)") == result.probes["front_uz"].max()


def test_a_failed_run_raises_run_failed_and_keeps_its_outputs(tmp_path, recwarn):
    """The first step fails: RunFailed at t = 0.25, step 1, its folder's summary says
    so, steps.csv has its header and no row, probes.csv the t = 0 row; the failure is
    raised once, not also warned (no RunWarning, the summary's warnings empty).
    Broke: rftfem.run also warning the failure (warn(str(exc)) before raising) →
    the RunWarning "run failed at t = 0.25 (step 1): ..." recorded."""
    scene = rftfem.scene_from_toml(CANTILEVER, folder=tmp_path)
    # a load that Newton cannot follow in a step: a huge tip force, no step cuts
    scene.update({"load.0.value": [0.0, 0.0, 1.0e9], "time.max_cuts": 0})
    with pytest.raises(rftfem.RunFailed) as info:
        rftfem.run(scene, out=tmp_path / "out", petsc={"snes_max_it": 3})
    assert info.value.folder == tmp_path / "out"
    assert (info.value.time, info.value.step) == (0.25, 1)
    result = rftfem.Result(info.value.folder)
    assert result.status == "failed"
    assert result.summary["failure"]["step"] == 1 and result.summary["warnings"] == []
    assert list(result.steps.columns[:4]) == ["time", "dt", "newton_its", "residual"]
    assert len(result.steps) == 0  # no step was accepted
    assert result.probes["time"].tolist() == [0.0]  # the t = 0 row was kept
    assert [str(w.message) for w in recwarn if issubclass(w.category, rftfem.RunWarning)] == []


FIRST_RUN_WARNS = """
import sys, warnings
import rftfem

scene = rftfem.scene_from_toml(open(sys.argv[2]).read(), folder=sys.argv[1])
with warnings.catch_warnings(record=True) as seen:   # as pytest.warns does
    warnings.simplefilter("always")
    result = rftfem.run(scene, out=sys.argv[1] + "/out")   # dolfinx and ffcx loaded here
said = [str(w.message) for w in seen if w.category is rftfem.RunWarning]
assert said == result.summary["warnings"] and len(said) == 1, (said, result.summary["warnings"])
print("ok")
"""


def test_a_quiet_run_warns_through_warnings(tmp_path):
    """A 5 Hz field stepped at dt = 0.3 (test_run_messages.ALIAS): the quiet run
    issues the aliasing warning once as a rftfem.RunWarning, at the line that called
    rftfem.run, with the summary's words; also as a script's first run, whose imports
    (the reference stack's ffcx sends warnings to logging) come inside the
    caller's catch_warnings.  Broke: stacklevel=3 as before → the warning was issued
    at rftfem/integration/simulation.py; showwarning not restored after the
    imports → the script's record was [] (reference stack)."""
    from test_run_messages import ALIAS

    scene = rftfem.scene_from_toml(ALIAS, folder=tmp_path)
    with pytest.warns(rftfem.RunWarning, match=r"^warning: time\.dt = 0\.3 is longer ") as seen:
        result = rftfem.run(scene, out=tmp_path / "here")
    ours = [w for w in seen if w.category is rftfem.RunWarning]
    assert [str(w.message) for w in ours] == result.summary["warnings"] and len(ours) == 1
    assert "(magnetic.field.frequency)" in str(ours[0].message) and result.ok
    assert Path(ours[0].filename) == Path(__file__), ours[0].filename
    (tmp_path / "alias.toml").write_text(ALIAS)
    done = run_command(
        [sys.executable, "-c", FIRST_RUN_WARNS, tmp_path, tmp_path / "alias.toml"], timeout=300
    )
    assert done.returncode == 0 and done.stdout.strip() == "ok", done.stderr


def test_a_restart_goes_on_to_the_uninterrupted_run_to_the_bit(tmp_path):
    """The short swim (SWIM, 4 steps) run to t = 0.00625 with a checkpoint at step 2,
    then restarted with time.end = 0.0125 (rftfem.run(..., restart=folder)): its
    probes, body and steps tables are the uninterrupted run's to the bit (reached:
    equal on both stacks), it names the checkpoint it went on from, and a restart
    from a finished run's time says to raise time.end.  Broke: the restart's
    generalized-α forces F_n left at zero (restart.py) → front_ux at t = 0.0125
    -0.013125 against -0.013115."""
    values = {
        "time.end": 0.0125,
        "time.dt": 0.003125,
        "time.until": "end",
        "output.fields": False,
        "time.output_every": 1,
        "output.checkpoint_every": 2,
    }
    sheet = DEMOS / "swimming_sheet.toml"
    whole = rftfem.run(rftfem.load_scene(sheet, set=values), out=tmp_path / "whole")
    first = rftfem.run(
        rftfem.load_scene(sheet, set={**values, "time.end": 0.00625}), out=tmp_path / "part"
    )
    assert first.probes["time"].tolist() == [0.0, 0.003125, 0.00625]
    with pytest.raises(rftfem.SceneError, match="not before time.end = 0.00625; raise"):
        rftfem.run(
            rftfem.load_scene(sheet, set={**values, "time.end": 0.00625}), restart=tmp_path / "part"
        )
    again = rftfem.run(rftfem.load_scene(sheet, set=values), restart=tmp_path / "part")
    assert again.folder == tmp_path / "part" and again.ok
    assert again.summary["restarts"] == [
        {"time": 0.00625, "step": 2, "checkpoint": "step-00000002"}
    ]
    for name in ("probes", "body", "steps"):
        ours, theirs = getattr(again, name), getattr(whole, name)
        if name == "steps":
            ours, theirs = ours.drop(columns="wall_s"), theirs.drop(columns="wall_s")
        assert list(ours.columns) == list(theirs.columns) and len(ours) == 5 - (name == "steps")
        assert np.array_equal(ours.to_numpy(), theirs.to_numpy()), (
            name,
            np.abs(ours.to_numpy() - theirs.to_numpy()).max(),
        )


def test_a_result_says_which_folder_or_file_is_missing(tmp_path):
    """Result of a missing folder, of a file, of an empty folder; a table the run did
    not write; a render option render does not take (also an abbreviation of one,
    which argparse alone would take) or a value it refuses: each a SceneError of one
    line naming it.  Broke: Result.render without its check of the names →
    "render: unrecognized arguments: --colour tip_uz" (argparse's words)."""
    with pytest.raises(rftfem.SceneError, match=r"nope: no such run folder$"):
        rftfem.Result(tmp_path / "nope")
    (tmp_path / "file").write_text("")
    with pytest.raises(rftfem.SceneError, match=r"file: not a folder$"):
        rftfem.Result(tmp_path / "file")
    with pytest.raises(
        rftfem.SceneError,
        match=r"not a run folder \(no summary.json, "
        r"probes.csv, body.csv, steps.csv\)$",
    ):
        rftfem.Result(tmp_path)
    (tmp_path / "summary.json").write_text('{"status": "ok"}')
    result = rftfem.Result(tmp_path)
    for name, file in (("probes", "probes.csv"), ("body", "body.csv"), ("steps", "steps.csv")):
        with pytest.raises(rftfem.SceneError, match=rf"{file}: this run wrote no {file}$"):
            getattr(result, name)
    (tmp_path / "summary.json").unlink()
    (tmp_path / "steps.csv").write_text("time,dt\n")
    with pytest.raises(rftfem.SceneError, match=r"summary.json: missing \(the run has not"):
        rftfem.Result(tmp_path).summary
    takes = "(render takes color, time, view, trail, fps, every, scale, size)"
    for options, words in [
        ({"colour": "tip_uz"}, f"unknown option colour {takes}"),
        ({"col": "tip_uz"}, f"unknown option col {takes}"),
        ({"t": 0.5, "zoom": 2}, f"unknown options t, zoom {takes}"),
        ({"view": "top"}, "argument --view: invalid choice: 'top'"),
        ({"fps": "fast"}, "argument --fps: invalid float value: 'fast'"),
    ]:
        with pytest.raises(rftfem.SceneError) as info:
            result.render(tmp_path / "x.png", **options)
        assert str(info.value).startswith(f"render: {words}"), (options, str(info.value))
        assert "\n" not in str(info.value) and not (tmp_path / "x.png").exists()


@pytest.mark.parametrize(
    "change, words",
    [
        (
            {"shell.E": "stiff"},
            "shell.E: expected a number > 0, a formula of X, Y, Z or a "
            'profile file; found the string "stiff"',
        ),
        ({"shell.E": {1, 2}}, "shell.E: expected a number > 0, found a set value {1, 2}"),
        (
            {"mesh.divisions": "4x1"},
            "mesh.divisions: expected [n_length, n_width], two "
            'integers >= 1, found the string "4x1"',
        ),
        ({"shell": 3.0}, "shell: expected a table [shell], found 3"),
        ({5: 1.0}, "expected a dotted key path like shell.thickness, found 5"),
        (
            [("shell.E", 2.0)],
            "Scene.update: expected a dict of dotted keys to values "
            "({'time.dt': 0.01}), found list",
        ),
        (
            "shell.E=2",
            "Scene.update: expected a dict of dotted keys to values ({'time.dt': 0.01}), found str",
        ),
    ],
    ids=[
        "string-for-number",
        "set",
        "string-for-pair",
        "number-for-table",
        "int-key",
        "list-of-pairs",
        "set-text",
    ],
)
def test_a_change_of_the_wrong_type_says_which_key(change, words):
    """A value, a key or a change of a type the scene cannot take: one line naming
    the key (or what Scene.update takes), the scene unchanged.  Broke: Scene.update
    without its dict check → AttributeError: 'list' object has no attribute 'items'."""
    scene = rftfem.scene_from_toml(CANTILEVER)
    before = scene.to_dict()
    with pytest.raises(rftfem.SceneError) as info:
        scene.update(change)
    assert str(info.value).startswith(words) and "\n" not in str(info.value), str(info.value)
    assert scene.to_dict() == before and scene.overrides == []
    if isinstance(change, dict):  # the same through scene[key] = value
        ((key, value),) = change.items()
        with pytest.raises(rftfem.SceneError, match=re.escape(words)):
            scene[key] = value
    else:  # and through load_scene(set=...)
        with pytest.raises(
            rftfem.SceneError, match=re.escape(words.replace("Scene.update", "load_scene(set=...)"))
        ):
            rftfem.load_scene(DEMOS / "swimming_sheet.toml", set=change)


FIELDS_AND_PICTURES = """
import sys
import numpy as np
import rftfem

folder = sys.argv[1]
scene = rftfem.scene_from_toml(open(sys.argv[2]).read(), folder=folder)
result = rftfem.run(scene, out=folder + "/out")   # loads pyvista before dolfinx
mesh = result.fields(0.5, warp=True)
assert mesh.field_data["time"][0] == 0.5 and mesh.n_points > 0
u = mesh.point_data["displacement"]
np.testing.assert_allclose(mesh.points, result.fields(0.5).points + u)
tip = result.probes.set_index("time").loc[0.5, "tip_uz"]
assert np.isclose(u[:, 2].max(), tip, rtol=1e-9), (u[:, 2].max(), tip)
picture = result.render(size="320x240")
assert picture.is_file() and picture.stat().st_size > 1000
try:
    result.render(folder + "/x.png", color="nope")
except rftfem.SceneError as exc:
    assert "--color nope: not a field" in str(exc), exc
else:
    raise AssertionError("no error")
print("ok")
"""


def test_a_result_gives_fields_and_pictures(tmp_path):
    """In a fresh process, as a user's script: rftfem.run loads pyvista first."""
    (tmp_path / "scene.toml").write_text(CANTILEVER)
    done = run_command(
        [sys.executable, "-c", FIELDS_AND_PICTURES, tmp_path, tmp_path / "scene.toml"], timeout=300
    )
    assert done.returncode == 0 and done.stdout.strip().endswith("ok"), done.stderr


def test_a_picture_is_drawn_in_a_child_when_dolfinx_came_first(tmp_path):
    """This test process has imported dolfinx: render() draws in a child process."""
    import dolfinx  # noqa: F401

    scene = rftfem.scene_from_toml(CANTILEVER, folder=tmp_path)
    result = rftfem.run(scene, out=tmp_path / "out")
    picture = result.render(tmp_path / "p.png", view="xz", size="320x240")
    assert picture.stat().st_size > 1000
    with pytest.raises(rftfem.SceneError, match="--color nope: not a field"):
        result.render(tmp_path / "x.png", color="nope")
