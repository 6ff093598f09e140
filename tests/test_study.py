"""``rftfem study`` (issue 16): observed orders and Richardson estimates against exact
solutions, failed levels kept, bad options refused; the BDF2 scheme's order.

Exact references: the rigid magnetic plate spinning about its normal in a field
rotating faster than it can follow (docs/verification.md case G; the angle at a
time from Adler's equation solved in closed form), and the roll-up of a cantilever
by an end moment (case B: the tip on a circle).
"""

from __future__ import annotations

import csv
import math
import sys
from pathlib import Path

import pytest
from conftest import ROOT, run_command, write_scene
from test_magnetic import AXES, MB, PLATE, PLATE_L, PLATE_T, PLATE_W

from rftfem.errors import SceneError
from rftfem.studies.study import analyse

PROBES = """
[[output.probes]]
name = "a"
at = [0.0, 0.5, 0.0]
[[output.probes]]
name = "b"
at = [2.0, 0.5, 0.0]
"""

OMEGA_C = MB * PLATE_T * PLATE_L * PLATE_W / AXES["normal"][1]  # π rad/s
OMEGA = 2 * OMEGA_C  # one turn per second
T_END = 0.5  # before the first slip


def adler_angle(t: float, omega: float, omega_c: float) -> float:
    """Angle turned at time t by an overdamped rotor, ζ φ' = m B sin(ω t − φ), φ(0) = 0,
    for ω > ω_c: with ψ = ω t − φ, tan(ψ/2) = (ω_c + Ω tan(Ω t/2 + c))/ω,
    Ω = √(ω² − ω_c²), c = atan(−ω_c/Ω) (valid while Ω t/2 + c < π/2)."""
    big = math.sqrt(omega**2 - omega_c**2)
    c = math.atan(-omega_c / big)
    x = big * t / 2 + c
    assert x < math.pi / 2
    psi = 2 * math.atan((omega_c + big * math.tan(x)) / omega)  # ψ(0) = 0 at x = c
    return omega * t - psi


def study(tmp_path, scene, *args, timeout=1200):
    cmd = [
        sys.executable,
        "-m",
        "rftfem",
        "study",
        str(scene),
        "--out",
        str(tmp_path / "study"),
        *map(str, args),
    ]
    return run_command(cmd, cwd=ROOT, timeout=timeout)


def rows_of(tmp_path, quantity=None):
    with open(tmp_path / "study" / "study.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    return [r for r in rows if quantity is None or r["quantity"] == quantity]


def number(text):
    return float(text) if text else None


def assert_estimates_bracket(rows, exact):
    """Each row's Richardson estimate within a factor 2 of its true error."""
    for r in rows:
        error = abs(number(r["value"]) - exact)
        ratio = number(r["error_estimate"]) / error
        print(
            f"  level {r['level']}: {r['value']} vs {exact!r}, error {error:.3e}, estimate "
            f"{r['error_estimate']} (ratio {ratio:.2f}), observed order {r['order']}"
        )
        assert 0.5 <= ratio <= 2.0


# --- the arithmetic -------------------------------------------------------------------


@pytest.mark.parametrize("p", [1.0, 2.0, 3.0])
def test_analyse_on_an_exact_power_law(p):
    """Q_k = Q + C h_k^p with h halved per level: the observed order is p and the
    estimate is the exact error, to round-off; the extrapolation is Q."""
    values = [1.5 + 0.3 * 0.5 ** (p * k) for k in range(4)]
    rows = analyse(values, nominal=p)
    assert rows[0]["change"] is None and rows[1]["order"] is None
    for k in (2, 3):
        assert rows[k]["order"] == pytest.approx(p, abs=1e-9)
        assert rows[k]["error_estimate"] == pytest.approx(values[k] - 1.5, rel=1e-9)
        assert rows[k]["extrapolated"] == pytest.approx(1.5, abs=1e-12)
    # level 1 has no observed order: the nominal one
    assert rows[1]["order_used"] == p
    assert rows[1]["error_estimate"] == pytest.approx(abs(values[1] - values[0]) / (2**p - 1))
    # an observed order above the nominal one is capped there (a larger estimate)
    capped = analyse(values, nominal=p - 0.5)
    assert capped[3]["order"] == pytest.approx(p) and capped[3]["order_used"] == p - 0.5
    assert capped[3]["error_estimate"] > rows[3]["error_estimate"]


def test_analyse_keeps_a_failed_level_as_a_hole():
    rows = analyse([1.0, None, 1.25, 1.0625], nominal=2)
    assert rows[1]["change"] is None and rows[2]["change"] is None
    assert rows[3]["order"] is None and rows[3]["order_used"] == 2
    assert rows[3]["error_estimate"] == pytest.approx(0.1875 / 3)


# --- time: the rigid magnetic plate -----------------------------------------------------


@pytest.mark.parametrize(
    "scheme, order, dt",
    [
        ("backward-euler", 1, 0.05),
        ("bdf2", 2, 0.0125),
        ("generalized-alpha", 2, 0.0125),
    ],
)
def test_time_refinement_of_the_magnetic_plate(tmp_path, scheme, order, dt):
    """docs/verification.md case G at ω = 2 ω_c: the mean rate over [0, 0.5] (the angle
    at 0.5 over 0.5) at dt, dt/2, dt/4, dt/8.  The last two observed orders are the
    scheme's (± 0.2) and the Richardson estimate of the finest two levels is within a
    factor 2 of their exact error.  Generalized-α gets a density small enough to leave
    the overdamped answer (1e-9: an inertial time of 1e-7 s)."""
    scene = write_scene(tmp_path, PLATE + PROBES)
    extra = ["--set", "shell.density=1e-9"] if scheme == "generalized-alpha" else []
    done = study(
        tmp_path,
        scene,
        "--refine",
        "dt",
        "--levels",
        4,
        "--set",
        "magnetic.field.frequency=1.0",
        "--set",
        "magnetic.field.rotation_axis=[0, 0, 1]",
        "--set",
        f"time.end={T_END}",
        "--set",
        f"time.dt={dt}",
        "--set",
        "output.fields=false",
        "--set",
        f'time.scheme="{scheme}"',
        *extra,
        "--quantity",
        f"rate=spin(a, b, z, 0, {T_END})",
    )
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-2000:]
    rows = rows_of(tmp_path)
    assert [r["status"] for r in rows] == ["ok"] * 4
    assert [number(r["dt"]) for r in rows] == pytest.approx([dt / 2**k for k in range(4)])
    exact = adler_angle(T_END, OMEGA, OMEGA_C) / T_END
    orders = [number(r["order"]) for r in rows[2:]]
    print(f"{scheme}: values {[r['value'] for r in rows]}, exact {exact!r}, orders {orders}")
    for p in orders:
        assert abs(p - order) < 0.2, orders
    assert_estimates_bracket(rows[2:], exact)
    text = (tmp_path / "study" / "study.md").read_text()
    assert "rate, refining dt" in text and "rftfem study" in text
    assert (tmp_path / "study" / "study.png").stat().st_size > 10_000


def test_bdf2_coefficients_on_variable_steps():
    """v_{n+1} of BDF2 for u = t² (which it differentiates exactly) after steps of
    0.1, 0.05 (halved) and 0.1 (doubled back), and backward Euler's at the first step."""
    from rftfem.integration.schemes import BDF2

    scheme, t, u = BDF2(), 0.0, lambda s: s**2
    v, w = 0.0, 0.0
    for k, h in enumerate((0.1, 0.05, 0.1)):
        c = scheme.coefficients(h)
        du = u(t + h) - u(t)
        v_new = c.cv * du + c.cv_a * w
        assert v_new == pytest.approx(scheme.update(du, v, w, h)[0], abs=1e-15)
        expected = du / h if k == 0 else 2 * (t + h)
        assert v_new == pytest.approx(expected, rel=1e-12)
        v, w = scheme.update(du, v, w, h)
        t += h


# --- space: the roll-up ----------------------------------------------------------------


def test_mesh_refinement_of_the_rollup(tmp_path):
    """docs/verification.md case B at M = Mmax/4 (a quarter circle, tip height L/θ with
    θ = π/2) on 2×1, 4×2, 8×4, 16×8 cells: the Richardson estimate of each level from
    the second on is within a factor 2 of its exact error."""
    moment = 2 * math.pi * 100 / 12
    done = study(
        tmp_path,
        ROOT / "demos" / "rollup.toml",
        "--refine",
        "mesh",
        "--levels",
        4,
        "--set",
        "mesh.divisions=[2, 1]",
        "--set",
        "time.end=0.25",
        "--set",
        f"load.0.value=[0.0, {moment / 4!r}, 0.0]",
        "--set",
        "output.fields=false",
        "--quantity",
        "tip=tip_uz@0.25",
    )
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-2000:]
    rows = rows_of(tmp_path)
    assert [r["divisions"] for r in rows] == ["2x1", "4x2", "8x4", "16x8"]
    assert_estimates_bracket(rows[1:], exact=-12 / (math.pi / 2))


# --- failures and refusals -------------------------------------------------------------

GMSH_SCENE = """
title = "a mesh from a file"
[mesh]
kind = "gmsh"
file = "{}"
[shell]
thickness = 0.1
E = 1.0e3
nu = 0.3
[time]
scheme = "static"
[[output.probes]]
name = "tip"
at = [0.0, 0.0, 0.0]
"""


def test_a_failed_level_stays_in_the_table(tmp_path):
    """The plate turning about an in-plane axis with the field (ω = 2π rad/s, below its
    ω_c there) by 0.63 rad per step of 0.1, against time.max_rotation = 0.4 and no
    halving allowed: level 0 fails (exit 3 of its run), the finer levels run; the
    study exits 0 and names the failure in every table."""
    scene = write_scene(tmp_path, PLATE + PROBES)
    done = study(
        tmp_path,
        scene,
        "--refine",
        "dt",
        "--levels",
        3,
        "--set",
        "magnetic.field.frequency=1.0",
        "--set",
        "magnetic.field.rotation_axis=[0, 1, 0]",
        "--set",
        "time.end=0.4",
        "--set",
        "time.dt=0.1",
        "--set",
        "time.max_cuts=0",
        "--set",
        "time.max_rotation=0.4",
        "--set",
        "output.fields=false",
        "--quantity",
        "rate=spin(a, b, y, 0, 0.4)",
    )
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-2000:]
    rows = rows_of(tmp_path)
    assert [r["status"] for r in rows] == ["failed", "ok", "ok"]
    assert "max_rotation" in rows[0]["failure"]
    assert rows[0]["value"] == "" and rows[1]["change"] == ""
    assert "failed: " in (tmp_path / "study" / "study.md").read_text()
    assert "2 of 3 runs ok" in done.stderr
    assert "max_rotation" in (tmp_path / "study" / "level-0" / "run.log").read_text()


def test_levels_in_this_process_equal_separate_processes(tmp_path):
    """One level at a time the levels run in the study's own process (rftfem/studies/batch.py),
    a failed level among them; with --processes each is a child `rftfem run`: the
    same statuses and the same values to round-off, and the levels after a failure
    in the same process are unharmed; so on a local Dask cluster of two workers."""
    scene = write_scene(tmp_path, PLATE + PROBES)
    sets = [
        "--refine",
        "dt",
        "--levels",
        3,
        "--set",
        "magnetic.field.frequency=1.0",
        "--set",
        "magnetic.field.rotation_axis=[0, 1, 0]",
        "--set",
        "time.end=0.4",
        "--set",
        "time.dt=0.1",
        "--set",
        "time.max_cuts=0",
        "--set",
        "time.max_rotation=0.4",
        "--set",
        "output.fields=false",
        "--quantity",
        "rate=spin(a, b, y, 0, 0.4)",
    ]
    tables = {}
    ways = {"here": [], "processes": ["--processes"], "dask": ["--executor", "dask", "--jobs", "2"]}
    for way, options in ways.items():
        out = tmp_path / way
        done = study(out, scene, *sets, *options)
        assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-2000:]
        tables[way] = rows_of(out)
    for way in ("processes", "dask"):
        assert len(tables[way]) == len(tables["here"])
        for here, child in zip(tables["here"], tables[way]):
            assert here["status"] == child["status"]
            if here["value"]:
                assert number(here["value"]) == pytest.approx(number(child["value"]), rel=1e-12)
    assert [r["status"] for r in tables["here"]] == ["failed", "ok", "ok"]


@pytest.mark.parametrize(
    "args, words",
    [
        (["--refine", "mesh", "--quantity", "t=tip_uz@end"], ["--refine mesh", "divisions"]),
        (["--refine", "time", "--quantity", "t=tip_uz@end"], ["--refine", "time"]),
        (["--refine", "dt", "--quantity", "t=tip_uz@end"], ["--refine dt", "static"]),
        (["--refine", "mesh"], ["--quantity"]),
        (["--refine", "mesh", "--levels", "1", "--quantity", "t=tip_uz@end"], ["--levels"]),
        (
            ["--refine", "mesh", "--jobs", "2", "--np", "2", "--quantity", "t=tip_uz@end"],
            ["--jobs", "--np"],
        ),
        (["--refine", "mesh", "--quantity", "t=spin(tip, tip, w)"], ["axis"]),
        (["--refine", "mesh", "--quantity", "t=tip_uz@end", "--out", "FILE"], ["--out"]),
    ],
)
def test_bad_study_options_are_one_line_errors(tmp_path, args, words):
    """Refused before anything runs, exit 2 and one line naming the option."""
    scene = ROOT / "demos" / "rollup.toml"
    if words == ["--refine mesh", "divisions"]:  # a mesh from a file has no divisions
        scene = write_scene(
            tmp_path, GMSH_SCENE.format(ROOT / "tests" / "data" / "two_quads_v22.msh")
        )
    if "FILE" in args:  # an --out that is a file (the last --out given wins)
        (tmp_path / "file").write_text("")
        args = [str(tmp_path / "file") if a == "FILE" else a for a in args]
    done = study(tmp_path, scene, *args, timeout=120)
    assert done.returncode == 2, done.stdout + done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in done.stderr, done.stderr
    for w in words:
        assert w in lines[0], (w, lines[0])
    assert not (tmp_path / "study").exists()  # refused before anything ran


def test_reuse_keeps_finished_levels(tmp_path):
    """--reuse reads the levels a study already ran (same content) and computes the
    tables again, with a quantity added; a level whose overrides changed runs again."""
    scene = write_scene(tmp_path, PLATE + PROBES)
    sets = [
        "--set",
        "magnetic.field.frequency=1.0",
        "--set",
        "time.end=0.1",
        "--set",
        "time.dt=0.05",
        "--set",
        "output.fields=false",
    ]
    first = study(tmp_path, scene, "--levels", 2, *sets, "--quantity", "x=b_ux@end")
    assert first.returncode == 0, first.stderr
    stamps = {
        d.name: (d / "summary.json").stat().st_mtime_ns
        for d in (tmp_path / "study").iterdir()
        if d.is_dir()
    }
    again = study(
        tmp_path,
        scene,
        "--levels",
        3,
        "--reuse",
        *sets,
        "--quantity",
        "x=b_ux@end",
        "--quantity",
        "y=b_uy@end",
    )
    assert again.returncode == 0, again.stderr
    for name, stamp in stamps.items():
        assert (tmp_path / "study" / name / "summary.json").stat().st_mtime_ns == stamp
    rows = rows_of(tmp_path, "y")
    assert [r["status"] for r in rows] == ["ok"] * 3 and rows[2]["value"]
    changed = study(
        tmp_path,
        scene,
        "--levels",
        2,
        "--reuse",
        *sets,
        "--set",
        "time.end=0.2",
        "--quantity",
        "x=b_ux@end",
    )
    assert changed.returncode == 0, changed.stderr
    assert (tmp_path / "study" / "level-0" / "summary.json").stat().st_mtime_ns != stamps["level-0"]


def test_reuse_runs_again_the_levels_an_edited_scene_changes(tmp_path):
    """--reuse keys the levels on content as sweep does (rftfem/studies/reuse.py): the
    scene unchanged, both levels are kept; the base scene file edited (shell.E, which
    no override replaces), both run again and stderr says why in sweep's words.
    Broke: run_level back on the path-and-overrides match (the old batch.finished)
    → the edited scene's levels kept, stderr only 'rftfem study: 2 of 2 runs ok in
    1 s; study.csv, ...'."""
    scene = write_scene(tmp_path, PLATE + PROBES)
    args = [
        "--levels",
        2,
        "--set",
        "magnetic.field.frequency=1.0",
        "--set",
        "time.end=0.1",
        "--set",
        "time.dt=0.05",
        "--set",
        "output.fields=false",
        "--quantity",
        "x=b_ux@end",
    ]
    assert study(tmp_path, scene, *args).returncode == 0
    folders = [tmp_path / "study" / name for name in ("level-0", "dt-1")]
    assert all((f / "reuse.json").is_file() for f in folders)

    def stamps():
        return [(f / "summary.json").stat().st_mtime_ns for f in folders]

    first = stamps()
    same = study(tmp_path, scene, *args, "--reuse")
    assert same.returncode == 0 and "not reused" not in same.stderr, same.stderr
    assert stamps() == first
    scene.write_text(scene.read_text().replace("E = 1.0e7", "E = 2.0e7"))
    edited = study(tmp_path, scene, *args, "--reuse")
    assert edited.returncode == 0, edited.stderr
    assert (
        "rftfem study: 2 finished run(s) run again, not reused (the completed scene "
        "changed since); the first: level-0"
    ) in edited.stderr, edited.stderr
    assert all(a != b for a, b in zip(stamps(), first))
    assert [r["status"] for r in rows_of(tmp_path)] == ["ok", "ok"]


def test_levels_under_mpirun(tmp_path, mpirun):
    """--np 2 runs every level on two processes (summary mpi_size) and gets the serial
    values; a level whose launch fails says why in one line of its table row."""
    import json
    import os

    exe, env = mpirun
    scene = write_scene(tmp_path, PLATE + PROBES)
    sets = [
        "--set",
        "magnetic.field.frequency=1.0",
        "--set",
        "time.end=0.1",
        "--set",
        "time.dt=0.05",
        "--set",
        "output.fields=false",
    ]
    values = {}
    for np_ in (1, 2):
        cmd = [
            sys.executable,
            "-m",
            "rftfem",
            "study",
            str(scene),
            "--levels",
            "2",
            "--np",
            str(np_),
            "--out",
            str(tmp_path / f"np{np_}"),
            *sets,
            "--quantity",
            "x=b_ux@end",
        ]
        done = run_command(cmd, cwd=ROOT, env=env, timeout=600)
        assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
        with open(tmp_path / f"np{np_}" / "study.csv", newline="") as f:
            rows = list(csv.DictReader(f))
        assert [r["status"] for r in rows] == ["ok", "ok"]
        values[np_] = [float(r["value"]) for r in rows]
        for r in rows:
            summary = json.loads((Path(r["folder"]) / "summary.json").read_text())
            assert summary["mpi_size"] == np_
    # equal to the Newton tolerance (the reductions differ in the last bits by rank count)
    assert values[2] == pytest.approx(values[1], rel=1e-8, abs=1e-14)
    # as root without Open MPI's two variables: rftfem's own launch sets them (a
    # container's root could not), so the levels run (before, mpirun refused them)
    bare = {k: v for k, v in env.items() if not k.startswith("OMPI_ALLOW")}
    version = run_command([exe, "--version"], env=env, timeout=60).stdout
    if os.geteuid() == 0 and "Open MPI" in version:
        done = run_command(
            [
                sys.executable,
                "-m",
                "rftfem",
                "study",
                str(scene),
                "--levels",
                "2",
                "--np",
                "2",
                "--out",
                str(tmp_path / "root"),
                *sets,
                "--quantity",
                "x=b_ux@end",
            ],
            cwd=ROOT,
            env=bare,
            timeout=600,
        )
        assert done.returncode == 0
        with open(tmp_path / "root" / "study.csv", newline="") as f:
            assert [r["status"] for r in csv.DictReader(f)] == ["ok", "ok"]


@pytest.mark.parametrize("ratio", [1.5, 3.0])
def test_analyse_with_another_refinement_factor(ratio):
    """h divided by ``ratio`` per level: the observed order and the estimate are exact
    on a power law (with log2 and 2^p they were off by log2(ratio))."""
    values = [1.5 + 0.3 * ratio ** (-2 * k) for k in range(4)]
    rows = analyse(values, nominal=2, ratio=ratio)
    assert rows[3]["order"] == pytest.approx(2.0, abs=1e-9)
    assert rows[3]["error_estimate"] == pytest.approx(values[3] - 1.5, rel=1e-9)
    assert rows[1]["error_estimate"] == pytest.approx(abs(values[1] - values[0]) / (ratio**2 - 1))


def test_one_direction_and_other_factors(tmp_path):
    """--refine mesh.x refines the strip's divisions along X only (a Stokes sheet's
    dense operator grows with the nodes: doubling both ways quadruples them),
    --factor 1.5 rounds divisions to whole cells; dt takes whole factors only; a
    Stokes scene's mesh levels assume order 1 (blobs) or 1.5 (the layer) until one is
    observed."""
    from rftfem.scene.reading import load_scene
    from rftfem.studies.study import plan
    from rftfem.studies.study_report import nominal_order

    scene = load_scene(ROOT / "demos" / "swimming_sheet.toml", ["mesh.divisions=[20, 4]"])
    plans = plan(scene, ["mesh.x", "mesh.y", "mesh"], 3, tmp_path, factor=1.5)
    assert [lv.divisions for lv in plans["mesh.x"]] == [[20, 4], [30, 4], [45, 4]]
    assert [lv.divisions for lv in plans["mesh.y"]] == [[20, 4], [20, 6], [20, 9]]
    assert [lv.divisions for lv in plans["mesh"]] == [[20, 4], [30, 6], [45, 9]]
    assert plans["mesh.x"][1].overrides == ["mesh.divisions=[30,4]"]
    with pytest.raises(SceneError, match=r"--factor 1.5 with --refine dt"):
        plan(scene, ["dt"], 3, tmp_path, factor=1.5)
    assert [lv.dt for lv in plan(scene, ["dt"], 3, tmp_path, factor=3.0)["dt"]] == pytest.approx(
        [scene["time"]["dt"] / 3**k for k in range(3)]
    )
    assert nominal_order("mesh.x", "generalized-alpha", stokes="blobs") == 1
    assert nominal_order("fluid", "generalized-alpha", stokes="layer") == 1.5
    assert nominal_order("mesh", "generalized-alpha") == 2
    # --refine fluid: fluid.refine 0, 1, 2 at the same shell mesh; only for the layer
    stokes = load_scene(
        ROOT / "demos" / "swimming_sheet.toml",
        [
            "mesh.divisions=[10, 2]",
            "--unset fluid.drag",
            'fluid.model="stokes"',
            "fluid.viscosity=1e-9",
        ],
    )
    fluid = plan(stokes, ["fluid"], 3, tmp_path)["fluid"]
    assert [lv.overrides for lv in fluid] == [[], ["fluid.refine=1"], ["fluid.refine=2"]]
    assert [lv.divisions for lv in fluid] == [[10, 2]] * 3
    with pytest.raises(SceneError, match=r"^--refine fluid: the scene's liquid is not the "):
        plan(scene, ["fluid"], 3, tmp_path)
    with pytest.raises(SceneError, match=r"^--factor 3 with --refine fluid"):
        plan(stokes, ["fluid"], 3, tmp_path, factor=3.0)
    done = study(
        tmp_path,
        ROOT / "demos" / "rollup.toml",
        "--refine",
        "mesh",
        "--factor",
        "1",
        "--quantity",
        "t=tip_uz@end",
        timeout=120,
    )
    assert done.returncode == 2 and "--factor: expected a number > 1" in done.stderr
