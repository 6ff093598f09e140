"""What a run tells a user who would otherwise be left guessing (docs/running.md):
a limit point under load control, loads already on at t = 0 in a static run, a step
too long for the drive (aliasing), the scene's scales in `rftfem check`, and a quiet
run that succeeds saying nothing.  Each through the command line, as a user meets it.
"""

from __future__ import annotations

import json
import sys

import pytest
from conftest import ROOT, run_command, write_scene
from test_arc_length import F_LIMIT, truss_scene


def rftfem(*args, cwd=ROOT):
    return run_command([sys.executable, "-m", "rftfem", *map(str, args)], cwd=cwd, timeout=600)


def test_limit_point_under_load_control_names_arc_length(tmp_path):
    """The von Mises truss bar under twice its limit load, by load steps: the run
    stops at λ = ½ (exit 3), and its one line says a limit point was met, with the
    tangent's stiffness along the last step at 3e-4 of the first's, and names
    time.scheme = "arc-length".  The same bar under 0.9 of the limit load passes."""
    scene = truss_scene(tmp_path, force=-2 * F_LIMIT)
    text = scene.read_text().replace('scheme = "arc-length"', 'scheme = "static"')
    scene.write_text(text)
    done = rftfem("run", scene, "--out", tmp_path / "out", "--quiet")
    print(done.stderr)
    assert done.returncode == 3
    assert len(done.stderr.strip().splitlines()) == 1
    assert "a limit point: the loads stall at t = 0.5 " in done.stderr
    assert 'time.scheme = "arc-length"' in done.stderr
    scene.write_text(
        text.replace(f"value = [0.0, 0.0, {-2 * F_LIMIT}]", f"value = [0.0, 0.0, {-0.9 * F_LIMIT}]")
    )
    assert rftfem("run", scene, "--out", tmp_path / "ok", "--quiet").returncode == 0


FREE_STRIP = """
title = "a free strip in vacuum under a load on at t = 0"
[mesh]
length = 4.0
width = 1.0
divisions = [2, 1]
[shell]
thickness = 0.1
E = 1.0e3
nu = 0.3
[time]
end = 1.0
dt = 0.5
[[load]]
kind = "edge-force"
where = "x=L"
value = [0.0, 0.0, 1.0e-3]
ramp = "constant"
"""


def test_static_run_with_a_load_on_at_t0_says_to_ramp_it(tmp_path):
    """Nothing holds the strip: the static start fails (exit 3) and says the load
    load.0 is already on at t = 0; the same load ramped from 0 is named nowhere: its
    run fails too (a singular tangent, exit 3), in one line that names no load.
    Broke: loads_at_start without its ramp condition → the ramped run's line said
    "load.0 is already on at t = 0"."""
    scene = write_scene(tmp_path, FREE_STRIP)
    done = rftfem("run", scene, "--out", tmp_path / "out", "--quiet")
    print(done.stderr)
    assert done.returncode == 3
    assert "ramp" in done.stderr and "load.0" in done.stderr
    held = FREE_STRIP + '[[boundary]]\nwhere = "x=0"\nfix = ["clamped"]\n'
    stiff = held.replace("E = 1.0e3", "E = 1.0e-30")  # a singular tangent: every step fails
    done = rftfem("run", write_scene(tmp_path, stiff), "--out", tmp_path / "out2", "--quiet")
    print(done.stderr)
    assert done.returncode == 3 and "load.0 is already on at t = 0" in done.stderr
    ramped = stiff.replace('ramp = "constant"', 'ramp = "linear"')
    done = rftfem("run", write_scene(tmp_path, ramped), "--out", tmp_path / "out3", "--quiet")
    print(done.stderr)
    assert done.returncode == 3 and len(done.stderr.strip().splitlines()) == 1
    assert done.stderr.startswith("rftfem: run failed at t = ")
    assert "already on at t = 0" not in done.stderr and "load.0" not in done.stderr


ALIAS = """
title = "a 5 Hz field sampled every 0.3 s"
[mesh]
length = 10.0
width = 1.0
divisions = [4, 1]
[shell]
thickness = 0.1
E = 1.2e6
nu = 0.0
[time]
end = 0.6
dt = 0.3
[[boundary]]
where = "x=0"
fix = ["clamped"]
[fluid]
drag = [1e-6, 1e-6, 2e-6]
[[magnetic.parts]]
region = "all"
magnetization = 10.0
direction = [1.0, 0.0, 0.0]
[magnetic.field]
strength = 1e-3
frequency = 5.0
"""


@pytest.mark.parametrize(
    "field, words",
    [
        (
            "strength = 1e-3\nfrequency = 5.0",
            "a quarter of the field's rotation period at 5 Hz, 0.2 (magnetic.field.frequency)",
        ),
        (
            'kind = "expression"\nB = ["1e-3*cos(2*pi*5*t)", "1e-3*sin(10*pi*t + 1)", "0"]',
            "a quarter of the period of the field's sin or cos of t, 0.2 (magnetic.field.B)",
        ),
        (
            'kind = "table"\nvalues = [[0, 0, 0, 0], [0.5, 1e-3, 0, 0], [0.6, 0, 0, 0]]',
            "longer than the table's shortest interval, 0.1 (magnetic.field.values)",
        ),
    ],
    ids=["rotating", "formula", "table"],
)
def test_a_step_longer_than_a_quarter_period_warns_once_and_is_kept(tmp_path, field, words):
    """dt = 0.3 against a 5 Hz drive (rotating field, sin and cos of t in a formula)
    or a table whose rows are 0.1 apart (a step jumps over a row): one warning line on stderr
    with --quiet,
    the same in summary.json's `warnings` and in `rftfem check`; exit 0, nothing on
    stdout.  At dt = 0.05 (a quarter period) nothing is said."""
    text = ALIAS.replace("strength = 1e-3\nfrequency = 5.0", field)
    scene = write_scene(tmp_path, text)
    done = rftfem("run", scene, "--out", tmp_path / "out", "--quiet")
    print(done.stderr)
    assert done.returncode == 0 and done.stdout == ""
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and words in lines[0] and lines[0].startswith("warning: time.dt = 0.3")
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["warnings"] == lines
    assert words in rftfem("check", scene).stdout
    done = rftfem("run", scene, "--out", tmp_path / "fine", "--quiet", "--set", "time.dt=0.05")
    assert done.returncode == 0 and done.stdout == "" and done.stderr == ""
    assert json.loads((tmp_path / "fine" / "summary.json").read_text())["warnings"] == []


def test_periods_read_from_formulas():
    """sin/cos/tan arguments linear in t give their periods; others give none."""
    from rftfem.scene.expressions import parse, periods_in_time

    def periods(text):
        return periods_in_time(parse(text, "k", ("x", "y", "z", "t")))

    assert periods("2*sin(2*pi*5*t + x)") == pytest.approx([0.2])
    assert periods("cos(-3*t)*tan(4*t)") == pytest.approx(
        [2 * 3.141592653589793 / 3, 3.141592653589793 / 4]
    )
    assert periods("sin(t^2) + sin(x) + t") == []


def test_check_prints_the_scales_and_shows_a_unit_slip(tmp_path):
    """`rftfem check` of the swimming sheet prints its steps per drive period (32),
    L/t, the relaxation time against the period and the sperm number; a strip under
    a tip force with E written in Pa instead of MPa shows a deflection over the
    length a million times smaller, flagged as a possible unit slip."""
    done = rftfem("check", ROOT / "demos" / "swimming_sheet.toml")
    print(done.stdout)
    rows = {
        line[:32].strip(): line[32:].split()[0]
        for line in done.stdout.splitlines()
        if line.startswith("  ")
    }
    assert float(rows["steps per drive period"]) == 32
    assert float(rows["L/t"]) == 200
    assert "sperm number" in rows and "relaxation time / drive period" in rows
    strip = FREE_STRIP + '[[boundary]]\nwhere = "x=0"\nfix = ["clamped"]\n'
    mpa = rftfem("check", write_scene(tmp_path, strip.replace("E = 1.0e3", "E = 1.2e6"))).stdout
    pa = rftfem("check", write_scene(tmp_path, strip.replace("E = 1.0e3", "E = 1.2e12"))).stdout
    print(mpa, pa)

    def deflection(text):
        line = next(ln for ln in text.splitlines() if "deflection / length" in ln)
        return float(line.split()[3]), line

    (a, line_a), (b, line_b) = deflection(mpa), deflection(pa)
    # P L² / (3 D W), D = E t³ / (12 (1 − ν²))
    assert a == pytest.approx(1e-3 * 16 / (3 * 1.2e6 * 1e-3 / (12 * 0.91)), rel=2e-3)
    assert b == pytest.approx(a * 1e-6, rel=2e-3)
    assert "units" in line_b and "units" not in line_a


def _group_line(text, name):
    return next(ln for ln in text.splitlines() if ln.startswith(f"  {name} "))


def test_check_flags_fluid_groups_and_thickness_in_other_units(tmp_path):
    """The slips a new user made, each flagged by `rftfem check` ("units?"), the same
    scene in the right units not: drag coefficients a million times too large (a
    viscosity in Pa·s for N·s/mm²) put the relaxation time at 1.6e6 drive periods
    and the sperm number at 56, outside 1e-4 … 1e4 only for the relaxation; a
    thickness in µm (1000 times too thick) puts L/t at 0.2, below 5.  The RFT
    coefficients are printed with where they came from."""
    sheet = ROOT / "demos" / "swimming_sheet.toml"
    good = rftfem("check", sheet).stdout
    thick = rftfem("check", sheet, "--set", "shell.thickness=50.0").stdout
    pa = rftfem("check", sheet, "--set", "fluid.drag=[3e-3,3e-3,5.67e-3]").stdout
    print(good, thick, pa)
    assert "fluid: drag coefficients [3e-09, 3e-09, 5.67e-09] from fluid.drag" in good
    assert "units?" not in good and "no thin shell" not in good
    assert "no thin shell" in _group_line(thick, "L/t")
    relax = _group_line(pa, "relaxation time / drive period")
    assert float(relax.split()[5]) == pytest.approx(1.58e6, rel=0.01)
    assert "units?" in relax and "1 mPa·s = 1e-9 N·s/mm²" in relax
    assert "units?" not in _group_line(pa, "sperm number")
    assert "outside 1e-4 … 1e4: units?" in relax
    # from the viscosity: the slender-body coefficients of the sheet's length and width
    text = sheet.read_text(encoding="utf-8")
    drag = next(ln for ln in text.splitlines() if ln.startswith("drag = "))
    visc = rftfem(
        "check", write_scene(tmp_path, text.replace(drag, "viscosity = 1.0e-9"), "viscous.toml")
    ).stdout
    line = next(ln for ln in visc.splitlines() if ln.startswith("fluid: drag coefficients"))
    print(line)
    assert "from fluid.viscosity = 1e-09 (slender-body drag" in line
    C = [float(c) for c in line.split("[")[1].split("]")[0].split(",")]
    assert C[0] < C[1] == C[2]  # along the axis, across it and normal


def test_quiet_run_that_succeeds_prints_nothing_and_its_compile_is_setup(tmp_path):
    """--quiet on success: no byte on stdout or stderr; summary.json's compile time is
    within its set-up time."""
    scene = write_scene(
        tmp_path,
        FREE_STRIP.replace('ramp = "constant"', 'ramp = "linear"')
        + '[[boundary]]\nwhere = "x=0"\nfix = ["clamped"]\n',
    )
    done = rftfem("run", scene, "--out", tmp_path / "out", "--quiet")
    assert done.returncode == 0 and done.stdout == "" and done.stderr == ""
    wall = json.loads((tmp_path / "out" / "summary.json").read_text())["wall_s"]
    assert wall["compile"] <= wall["setup"]


def test_a_slow_set_up_says_it_is_compiling(tmp_path, capsys, monkeypatch):
    """A set-up longer than COMPILE_NOTICE_AFTER (its forms not yet in the JIT cache)
    says "compiling forms ..." once, before the run's own lines; --quiet does not."""
    from conftest import run_scene

    from rftfem.integration import simulation
    from rftfem.scene.reading import load_scene

    monkeypatch.setattr(simulation, "COMPILE_NOTICE_AFTER", 0.0)
    scene = write_scene(
        tmp_path,
        FREE_STRIP.replace('ramp = "constant"', 'ramp = "linear"')
        + '[[boundary]]\nwhere = "x=0"\nfix = ["clamped"]\n',
    )
    sim = simulation.Simulation(load_scene(scene, []), quiet=False)
    try:
        sim.run()
    finally:
        sim.close()
    out = capsys.readouterr().out
    assert out.count("compiling forms for this scene's effects (once; about 20-50 s)") == 1
    assert out.index("compiling forms") < out.index("rftfem ")
    run_scene(scene)  # quiet
    assert "compiling" not in capsys.readouterr().out


@pytest.mark.parametrize(
    "extra, words",
    [
        (
            {"motion": [{"kind": "travelling-wave", "angular_frequency": 20 * 3.141592653589793}]},
            "a quarter of the travelling wave's period, 0.1 (motion.0)",
        ),
        (
            {"load": [{"ramp": "table", "table": [[0.0, 0.0], [0.5, 1.0], [0.54, 0.0]]}]},
            "longer than the table's shortest interval, 0.04 (load.0.table)",
        ),
        ({"load": [{"ramp": "table", "table": [[0.0, 0.0], [0.5, 1.0], [0.55, 0.0]]}]}, None),
        ({"load": [{"ramp": "table", "table": [[0.0, 1.0], [1e-12, 0.0], [1.0, 0.0]]}]}, None),
        (
            {"motion": [{"kind": "table", "values": [[-10.0, 0.0], [-9.99, 1.0], [10.0, 0.0]]}]},
            None,
        ),
    ],
    ids=["travelling-wave", "load-table", "rows-at-steps", "release-jump", "table-outside-the-run"],
)
def test_aliasing_of_waves_and_tables(extra, words):
    """dt = 0.05 against a travelling wave of period 0.1 and a load table with rows
    0.04 apart: one warning each; rows 0.05 apart (each step lands on a row), a jump
    on purpose (a release 1e-12 after t = 0) and rows outside [0, time.end] none."""
    from rftfem.scene.scales import aliasing_warnings

    lines = aliasing_warnings({"time": {"dt": 0.05, "end": 1.0}, **extra})
    print(lines)
    if words is None:
        assert lines == []
    else:
        assert len(lines) == 1 and words in lines[0]
