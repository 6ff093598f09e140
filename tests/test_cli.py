"""The command line: exit statuses, one-line errors, PETSc options, check output."""

from __future__ import annotations

import sys
import types
from pathlib import Path

import pytest
from conftest import ROOT, run_command

from rftfem import cli
from rftfem.errors import RunFailed, SceneError

BAD = Path(__file__).parent / "scenes_bad"
BAD_SCENES = sorted(BAD.glob("*.toml"))

GOOD = """
title = "cli cantilever"
[mesh]
length = 10.0
divisions = [4, 1]
[shell]
thickness = 0.1
[time]
end = 1.0
dt = 0.5
[[boundary]]
where = "x=0"
fix = ["clamped"]
[[load]]
kind = "edge-moment"
where = "x=L"
value = [0.0, 0.1, 0.0]
[[output.probes]]
name = "tip"
at = [10.0, 0.5, 0.0]
"""


def rftfem(*args, cwd=None, timeout=60):
    return run_command([sys.executable, "-m", "rftfem", *map(str, args)], cwd=cwd, timeout=timeout)


def assert_one_line_error(proc, *words):
    assert proc.returncode == 2, (proc.returncode, proc.stderr)
    assert "Traceback" not in proc.stderr
    lines = proc.stderr.splitlines()
    assert len(lines) == 1 and lines[0].strip(), proc.stderr
    for w in words:
        assert w in lines[0], (w, lines[0])
    return lines[0]


def expected_words(path: Path) -> list[str]:
    return [s.strip() for s in path.read_text().splitlines()[0].split(":", 1)[1].split("|")]


@pytest.fixture
def good(tmp_path):
    p = tmp_path / "good.toml"
    p.write_text(GOOD)
    return p


# ------------------------------------------------------------ subprocesses


def test_enough_malformed_kinds():
    assert len(BAD_SCENES) >= 10


@pytest.mark.parametrize("path", BAD_SCENES, ids=lambda p: p.stem)
def test_check_bad_scene(path):
    line = assert_one_line_error(rftfem("check", path, cwd=BAD), *expected_words(path))
    assert line.startswith("rftfem: error: ")


def test_run_bad_scene_exits_2_without_running(tmp_path):
    path = BAD / "negative_thickness.toml"
    assert_one_line_error(rftfem("run", path, "-snes_monitor", cwd=tmp_path), "shell.thickness")
    assert not (tmp_path / "results").exists()


def test_bad_set_path(good):
    line = assert_one_line_error(rftfem("check", good, "--set", "mesh.lenght=3"), "mesh.lenght")
    assert "mesh.length" in line
    assert_one_line_error(rftfem("check", good, "--set", "load.4.value=[0,1,0]"), "load.4.value")
    assert_one_line_error(rftfem("check", good, "--set", "shell.nu=0.5"), "shell.nu")
    # a value that starts with '-' is still the value of --set, and its key is named
    assert_one_line_error(rftfem("check", good, "--set", "-=false"), "unknown key '-'")


def test_unknown_options(good):
    assert_one_line_error(rftfem("check", good, "--frobnicate"), "--frobnicate")
    # PETSc options only make sense for `run`
    assert_one_line_error(rftfem("check", good, "-snes_monitor"), "-snes_monitor")
    assert_one_line_error(rftfem("run", good, "--out"), "--out")
    assert_one_line_error(rftfem("explode", good), "explode")
    assert_one_line_error(rftfem(), "COMMAND")
    assert_one_line_error(rftfem("check"), "SCENE.toml")


def test_help():
    for args in (["--help"], ["run", "--help"], ["check", "--help"]):
        proc = rftfem(*args)
        assert proc.returncode == 0 and "usage: rftfem" in proc.stdout


def test_check_good_scene(good):
    proc = rftfem("check", good, timeout=120)
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    assert "scene OK: cli cantilever" in lines
    assert "active effects: elasticity, edge-moment" in lines
    assert "scheme: static" in lines


# ------------------------------------------------------------- in process


def test_split_petsc_options():
    rest, petsc = cli._split_petsc(
        [
            "run",
            "-snes_monitor",
            "a.toml",
            "--set",
            "time.dt=0.1",
            "-ksp_type",
            "preonly",
            "--quiet",
            "-pc_factor_mat_solver_type",
            "mumps",
            "-snes_view",
            "--out",
            "o",
        ]
    )
    assert rest == ["run", "a.toml", "--set", "time.dt=0.1", "--quiet", "--out", "o"]
    assert petsc == [
        "-snes_monitor",
        "-ksp_type",
        "preonly",
        "-pc_factor_mat_solver_type",
        "mumps",
        "-snes_view",
    ]
    assert cli._split_petsc(["check", "a.toml", "-snes_monitor"]) == (
        ["check", "a.toml", "-snes_monitor"],
        [],
    )


@pytest.fixture
def fake_simulation(monkeypatch):
    """Stand-ins for rftfem.integration.simulation (run) and model_setup (check) that
    record their calls."""
    module = types.ModuleType("rftfem.integration.simulation")
    module.calls = []
    module.options = []
    module.outcome = None

    def run(scene, out_dir, quiet, petsc_args, signals=False, restart=None):
        module.calls.append(("run", scene, out_dir, quiet, petsc_args))
        module.options.append({"signals": signals, "restart": restart})
        if module.outcome is not None:
            raise module.outcome
        return {"status": "ok"}

    def check(scene):
        module.calls.append(("check", scene))
        if module.outcome is not None:
            raise module.outcome
        return ["elasticity", "edge-moment"]

    def check_report(scene):
        return check(scene), [], []

    module.run, module.check, module.check_report = run, check, check_report
    monkeypatch.setitem(sys.modules, "rftfem.integration.simulation", module)
    monkeypatch.setitem(sys.modules, "rftfem.integration.model_setup", module)
    return module


def test_run_passes_scene_out_dir_and_petsc_args(
    good, fake_simulation, tmp_path, monkeypatch, capsys
):
    monkeypatch.chdir(tmp_path)
    status = cli.main(
        [
            "run",
            str(good),
            "--set",
            "time.dt=0.25",
            "--quiet",
            "-snes_monitor",
            "-ksp_type",
            "preonly",
        ]
    )
    assert status == 0
    kind, scene, out_dir, quiet, petsc = fake_simulation.calls[0]
    assert scene["time"]["dt"] == 0.25
    assert out_dir == Path("results") / "good"
    assert quiet is True and petsc == ["-snes_monitor", "-ksp_type", "preonly"]
    assert cli.main(["run", str(good), "--out", "elsewhere"]) == 0
    assert fake_simulation.calls[1][2] == Path("elsewhere")
    assert fake_simulation.calls[1][3] is False
    # the command line stops on signals (the Python API does not); --restart is the folder
    assert fake_simulation.options[:2] == [{"signals": True, "restart": None}] * 2
    assert cli.main(["run", str(good), "--restart", "earlier"]) == 0
    assert fake_simulation.calls[2][2] == Path("earlier")
    assert fake_simulation.options[2] == {"signals": True, "restart": Path("earlier")}


def test_run_failed_exits_3(good, fake_simulation, capsys):
    fake_simulation.outcome = RunFailed("SNES diverged after 8 dt cuts", 0.375, 12)
    assert cli.main(["run", str(good), "--out", "out/x"]) == 3
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert err.startswith("rftfem: run failed at t = 0.375 (step 12): SNES diverged")
    assert err.rstrip().endswith("; outputs so far are in " + str(Path("out/x")))


def test_scene_error_from_simulation_exits_2(good, fake_simulation, capsys):
    fake_simulation.outcome = SceneError("boundary.0.where: 'left' matches no physical group")
    assert cli.main(["check", str(good)]) == 2
    assert cli.main(["run", str(good)]) == 2
    err = capsys.readouterr().err.splitlines()
    assert err == ["rftfem: error: boundary.0.where: 'left' matches no physical group"] * 2


def test_check_uses_simulation_check(good, fake_simulation, capsys):
    assert cli.main(["check", str(good)]) == 0
    assert fake_simulation.calls[0][0] == "check"
    out = capsys.readouterr().out.splitlines()
    assert out == [
        "scene OK: cli cantilever",
        "active effects: elasticity, edge-moment",
        "scheme: static",
    ]


def test_check_falls_back_without_simulation_module(good, monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "rftfem.integration.model_setup", None)  # -> ImportError
    assert cli.main(["check", str(good), "--set", "shell.density=1"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out == [
        "scene OK: cli cantilever",
        "active effects: elasticity, inertia, edge-moment",
        "scheme: generalized-alpha",
    ]


def test_run_rejects_bad_petsc_option_and_out(tmp_path, good):
    """A PETSc option PETSc does not know, and an --out that is a file: exit 2 with
    one line each (not a petsc4py or OSError traceback)."""
    line = assert_one_line_error(
        rftfem("run", good, "--out", tmp_path / "o", "--set", "solver.pc_type=bogus", timeout=300),
        "solver",
        "bogus",
    )
    assert "PETSc rejected" in line
    (tmp_path / "afile").write_text("not a folder")
    assert_one_line_error(
        rftfem("run", good, "--out", tmp_path / "afile", timeout=300), "--out", "found a file"
    )
    assert_one_line_error(
        rftfem("run", good, "--out", tmp_path / "afile" / "sub", timeout=300),
        "--out",
        "cannot make this folder",
    )


def test_out_of_memory_is_one_line(good, fake_simulation, capsys):
    """A MemoryError (a run under a memory limit) is exit 2 with one line naming what
    to change, not a traceback (found by tests/test_fuzz.py under ulimit -v)."""
    fake_simulation.outcome = MemoryError()
    assert cli.main(["run", str(good)]) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].startswith("rftfem: error: out of memory")
    assert "mesh.divisions" in err[0]


def _help_examples():
    """(command, its arguments) of every example in the --help of sweep, study and
    optimize, continuation lines joined."""
    import shlex

    from rftfem.studies import optimize, study, sweep

    out = []
    for module in (sweep, study, optimize):
        text = module.EPILOG.split("examples:")[1]
        text = text.replace("\\\n", " ")
        for line in text.splitlines():
            words = shlex.split(line.strip()) if line.strip().startswith("rftfem ") else []
            if words:
                out.append(pytest.param(words[1], words[2:], id=f"{words[1]}-{words[2]}"))
    return out


@pytest.mark.parametrize("command, args", _help_examples())
def test_help_examples_name_keys_their_scenes_have(command, args):
    """Every example of `sweep`, `study` and `optimize --help` names a shipped scene,
    and every key it varies or sets is one that scene takes at the example's first
    value (sweep's help once varied magnetic.field.frequency of a scene whose field
    is an expression: exit 2)."""
    assert _load_example(args) or command == "study", args


def _load_example(args) -> list[str]:
    """Load an example's scene with its --set, --unset and the first value of each
    --vary (a SceneError names a key the scene does not take); the changes made."""
    from rftfem.scene.reading import load_scene, unset_text

    scene, rest = ROOT / args[0], args[1:]
    assert scene.is_file(), scene
    sets = []
    for option, value in zip(rest, rest[1:]):
        if option in ("--vary", "--vary-field"):
            key, values = value.split("=", 1)
            sets.append(f"{key}={values.replace(':', ',').split(',')[0]}")
        elif option == "--set":
            sets.append(value)
        elif option == "--unset":
            sets.append(unset_text(value))
    load_scene(scene, sets)
    return sets


def test_a_vector_component_has_one_address_everywhere(tmp_path):
    """`load.0.value.2` addresses the third component of a vector value in --set, the
    Python API and sweep's --vary alike, as it does in optimize's --vary and in
    scene(KEY) (it was refused: "'load.0.value' is a value, not a table"); a
    component past the vector's end, or of a value that is no vector, is named in one
    line."""
    import rftfem
    from rftfem.scene.reading import load_scene
    from rftfem.studies.sweep import parse_vary

    demo = ROOT / "demos" / "end_shear.toml"
    assert load_scene(demo, ["load.0.value.2=3.5"])["load"][0]["value"] == [0.0, 0.0, 3.5]
    scene = rftfem.load_scene(demo)
    scene["load.0.value.1"] = 2.0
    assert scene["load.0.value"] == [0.0, 2.0, 4.0] and scene["load.0.value.1"] == 2.0
    vary = parse_vary("load.0.value.2=1:3:3", load_scene(demo))
    assert vary.values == [1.0, 2.0, 3.0]
    for value in vary.values:
        assert load_scene(demo, [f"load.0.value.2={value!r}"])["load"][0]["value"][2] == value
    with pytest.raises(SceneError, match=r"index 5 out of range, 'load.0.value' has 3 "):
        load_scene(demo, ["load.0.value.5=1"])
    with pytest.raises(SceneError, match=r"'load.0.ramp' is 'linear', not a vector"):
        load_scene(demo, ["load.0.ramp.1=1"])
    done = run_command(
        [sys.executable, "-m", "rftfem", "check", str(demo), "--set", "load.0.value.2=-4"], cwd=ROOT
    )
    assert done.returncode == 0, done.stderr


def _doc_examples():
    """Every `rftfem run|check|sweep|study|optimize` line in README.md and docs/ that
    names a shipped scene (continuation lines joined; synopses with SCENE.toml and
    lines with shell variables are not examples of one scene)."""
    import re
    import shlex

    out = []
    for md in [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]:
        text = re.sub(r"\\\n\s*", " ", md.read_text(encoding="utf-8"))
        for n, line in enumerate(text.splitlines()):
            s = line.strip()
            m = re.match(r"(?:\.venv/bin/)?rftfem (run|check|sweep|study|optimize) (.*)", s)
            if not m or "$" in s or "SCENE.toml" in s:
                continue
            words = shlex.split(m[2].split(" #")[0])
            if words and words[0].endswith(".toml"):
                out.append(pytest.param(m[1], words, id=f"{md.name}:{n + 1}"))
    return out


@pytest.mark.parametrize("command, args", _doc_examples())
def test_doc_examples_name_keys_their_scenes_have(command, args):
    """Every example in the docs names a shipped scene and keys it takes (as
    test_help_examples_name_keys_their_scenes_have does for --help)."""
    _load_example(args)
