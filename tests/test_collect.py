"""``rftfem collect``: the quantity language on hand-written CSV files (exact
answers), the table on hand-written run folders, and the table of three real runs
of demos/rollup.toml (one of them fails on purpose) checked against each run's
summary.json and probes.csv; bad input is one line on stderr with exit status 2."""

from __future__ import annotations

import csv
import io
import json
import os
import re
import shutil
import subprocess
import sys
import time

import numpy as np
import pytest
from conftest import DEMOS, ROOT

from rftfem import cli
from rftfem.errors import SceneError
from rftfem.outputs import collect as C

ROLLUP = DEMOS / "rollup.toml"
COARSE = "mesh.divisions=[8,1]"
#: the load jumps 16-fold in one step at t = 0.55 and no cut is allowed: the run
#: stops with exit status 3 after 10 good steps (rows up to t = 0.5)
FAILING = [
    COARSE,
    "time.max_cuts=0",
    'load.0.ramp="table"',
    "load.0.table=[[0,0],[0.5,0.25],[0.55,4],[2,4]]",
]
RUNS = {"dt10": ([COARSE, "time.dt=0.1"], 0), "dt05": ([COARSE], 0), "jump": (FAILING, 3)}


def write(path, text):
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text, encoding="utf-8")
    return path


def table(text):
    return list(csv.DictReader(io.StringIO(text)))


def rftfem_exe() -> str:
    """The ``rftfem`` on PATH, as an absolute path (PATH may hold relative entries)."""
    exe = shutil.which("rftfem")
    assert exe, "rftfem is not on PATH (run the tests with the venv's bin first on PATH)"
    return os.path.abspath(exe)


def env_with_rftfem() -> dict:
    """The environment with the folder of that ``rftfem`` first on PATH, absolute,
    for scripts run from another folder."""
    return dict(os.environ, PATH=os.path.dirname(rftfem_exe()) + os.pathsep + os.environ["PATH"])


def collect_cli(*args, cwd=ROOT):
    """``rftfem collect ARGS`` in a subprocess (the command on PATH)."""
    return subprocess.run(
        [rftfem_exe(), "collect", *map(str, args)],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=120,
    )


def collect_inproc(capsys, *args):
    status = cli.main(["collect", *map(str, args)])
    out, err = capsys.readouterr()
    return status, out, err


# --- the quantity language ---------------------------------------------------------


@pytest.mark.parametrize(
    "text, expected",
    [
        ("tip_uz@end", ("at", "tip_uz", "end")),
        ("tip_uz@2.5", ("at", "tip_uz", 2.5)),
        (" tip_uz @ start ", ("at", "tip_uz", "start")),
        ("rate(tip_ux, 1, 2)", ("rate", "tip_ux", 1.0, 2.0)),
        ("rate(tip_ux,1e-1)", ("rate", "tip_ux", 0.1, "end")),
        ("mean(drag_power)", ("mean", "drag_power", "start", "end")),
        ("max(centroid_z, start, 1.5)", ("max", "centroid_z", "start", 1.5)),
        ("min(centroid_z, .5, end)", ("min", "centroid_z", 0.5, "end")),
    ],
)
def test_parse(text, expected):
    q = C.parse(text)
    assert (q.func, q.column, q.a, q.b)[: len(expected)] == expected


@pytest.mark.parametrize(
    "text, message",
    [
        ("", "empty expression"),
        ("tip_uz", "expected '@'"),
        ("tip_uz@", "expected a time"),
        ("tip_uz@soon", "expected a time"),
        ("rate(tip_ux, 2, 1)", "the window needs A < B"),
        ("rate(tip_ux, 1, 2, 3)", "at most two times"),
        ("rate(tip_ux, 1", "expected ')'"),
        ("rate", "expected '('"),
        ("speed(tip_ux)", "unknown function 'speed'"),
        ("tip_uz@1 + 2", "unexpected '+'"),
        ("tip_uz@1 2", "unexpected '2'"),
        ("mean(drag_power, 1e999)", "finite"),
    ],
)
def test_parse_errors(text, message):
    with pytest.raises(SceneError, match=re.escape(message)):
        C.parse(text)


@pytest.fixture
def hand_run(tmp_path):
    """probes.csv with u = 3 + 2 t (linear) and v = t² at uneven times; body.csv
    with y = t² at t = 0..4 and a constant column."""
    times = [0.0, 0.5, 1.25, 2.0, 4.0]
    write(
        tmp_path / "run" / "probes.csv",
        "time,p_ux,p_uy,p_uz\n" + "".join(f"{t!r},{3 + 2 * t!r},{t * t!r},0.0\n" for t in times),
    )
    write(
        tmp_path / "run" / "body.csv",
        "time,y,c\n" + "".join(f"{float(t)!r},{float(t * t)!r},7.0\n" for t in range(5)),
    )
    write(
        tmp_path / "run" / "summary.json",
        json.dumps({"status": "ok", "scene": {}, "overrides": [], "counts": {}, "wall_s": {}}),
    )
    return tmp_path / "run"


@pytest.mark.parametrize(
    "expr, exact",
    [
        ("p_ux@start", 3.0),
        ("p_ux@end", 11.0),
        ("p_ux@1.25", 5.5),
        ("p_ux@1.5", 6.0),  # u linear: interpolation is exact
        ("p_uy@1.5", 1.5625 + (4 - 1.5625) / 3),  # v = t² between rows: linear, not 2.25
        ("rate(p_ux, 0.5, 2)", 2.0),
        ("rate(p_ux, 0.75, 3)", 2.0),
        ("rate(p_ux)", 2.0),
        ("rate(p_uy, 1.25, 2)", (4 - 1.5625) / 0.75),
        ("rate(p_uy, 2)", 6.0),
        ("mean(y)", 5.5),  # trapezoid: (0.5 + 2.5 + 6.5 + 12.5) / 4
        ("mean(y, 1, 3)", 4.5),
        ("mean(y, 0.5, 2.5)", 2.75),
        ("mean(c, 0.3, 3.9)", 7.0),
        ("mean(p_ux, 0.5, 2)", 5.5),  # mean of a linear u: its midpoint value
        ("max(y)", 16.0),
        ("max(y, 0.5, 2.5)", 6.5),
        ("min(y, 0.5, 2.5)", 0.5),
        ("min(p_ux, 1, 4)", 5.0),
    ],
)
def test_quantities_exact(hand_run, expr, exact):
    assert C.evaluate(expr, hand_run) == pytest.approx(exact, rel=1e-12, abs=1e-12)
    assert C.evaluate(expr, str(hand_run)) == C.parse(expr).evaluate(C.RunFolder(hand_run))


def test_array_functions_exact():
    t, x = np.array([0.0, 1.0, 3.0]), np.array([1.0, 3.0, -1.0])
    assert C.value_at(t, x, 1.0) == 3.0
    assert C.value_at(t, x, 2.0) == 1.0
    assert C.rate(t, x, 0.0, 1.0) == 2.0
    assert C.rate(t, x, 0.5, 2.0) == (1.0 - 2.0) / 1.5
    assert C.mean(t, x, 0.0, 3.0) == (2.0 + 2.0) / 3.0
    assert C.extreme(t, x, 0.5, 2.5, "max") == 3.0
    assert C.extreme(t, x, 0.5, 2.5, "min") == 0.0


def test_quantity_errors(hand_run):
    with pytest.raises(
        SceneError, match=r"unknown column 'tip_uz' .*\(valid: p_ux, p_uy, p_uz, y, c\)"
    ):
        C.evaluate("tip_uz@end", hand_run)
    with pytest.raises(C.Unavailable, match="time 4.5 is outside the run"):
        C.evaluate("p_ux@4.5", hand_run)
    with pytest.raises(SceneError, match="time -1 is outside the run"):
        C.evaluate("rate(p_ux, -1, 1)", hand_run)
    with pytest.raises(SceneError, match="empty window"):
        C.evaluate("mean(y, end)", hand_run)
    # round-off at the ends is not "outside": clamped to the rows
    assert C.evaluate(f"p_ux@{4.0 + 1e-12!r}", hand_run) == 11.0


# --- the table on hand-written folders ---------------------------------------------


def fake_run(
    folder,
    scene,
    status="ok",
    overrides=(),
    scene_file="/s/a.toml",
    failure=None,
    probes="time,tip_uz\n0.0,0.0\n1.0,2.0\n2.0,4.0\n",
):
    summary = {
        "status": status,
        "scene": scene,
        "scene_file": scene_file,
        "overrides": list(overrides),
        "counts": {"steps": 3, "newton_iterations": 9, "dt_cuts": 1},
        "wall_s": {"total": 1.5},
        "time_reached": 2.0,
        "dofs": 10,
        "mpi_size": 2,
    }
    if failure:
        summary["failure"] = {"time": 1.0, "step": 1, "reason": failure}
    write(folder / "summary.json", json.dumps(summary))
    if probes is not None:
        write(folder / "probes.csv", probes)
    return folder


def test_table_of_fake_runs(tmp_path, capsys):
    """Scene keys that differ are columns (also from different scene files, also
    inside arrays of tables), the others are not; statuses; the failure reason;
    quantities past a failed run's rows are empty cells."""
    base = {
        "title": "A",
        "mesh": {"length": 12.0, "divisions": [8, 1]},
        "time": {"dt": 0.1, "end": 2.0},
        "load": [{"value": [0.0, 1.0, 0.0]}],
        "fluid": None,
        "solver": {},
    }
    other = json.loads(json.dumps(base))
    other.update(title="B", mesh={"length": 10.0, "divisions": [8, 1]})
    other["load"][0]["value"] = [0.0, 2.0, 0.0]
    other["solver"] = {"snes_rtol": 1e-10}
    a = fake_run(tmp_path / "a", base, overrides=["time.dt=0.1"])
    b = fake_run(tmp_path / "b", other, scene_file="/s/b.toml")
    f = fake_run(
        tmp_path / "f",
        base,
        status="failed",
        failure="diverged, badly",
        probes="time,tip_uz\n0.0,0.0\n1.0,2.0\n",
    )
    r = fake_run(tmp_path / "r", base, status="running")
    m = write(tmp_path / "m" / "probes.csv", "time,tip_uz\n0.0,0.0\n0.5,1.0\n1.0,3.0\n").parent
    s = fake_run(tmp_path / "s", base)  # a newer run writes into an old folder
    later = time.time() + 10
    os.utime(s / "probes.csv", (later, later))
    status, out, err = collect_inproc(
        capsys, a, b, f, r, m, s, "--quantity", "late=tip_uz@1.5", "--quantity", "rate(tip_uz, 0.5)"
    )
    assert status == 0, err
    header = out.splitlines()[0].split(",")
    assert header[:3] == ["folder", "status", "failure"]
    assert header[3 : header.index("overrides")] == [
        "title",
        "mesh.length",
        "load.0.value",
        "solver.snes_rtol",
        "scene_file",
    ]
    rows = table(out)
    assert [row["status"] for row in rows] == [
        "ok",
        "ok",
        "failed",
        "running-or-interrupted",
        "missing-summary",
        "running-or-interrupted",
    ]
    ra, rb, rf, rr, rm, rs = rows
    assert rr["steps"] == "3" and rs["steps"] == ""  # the stale summary is ignored
    assert (
        ra["title"],
        ra["mesh.length"],
        ra["load.0.value"],
        ra["solver.snes_rtol"],
        ra["scene_file"],
    ) == ("A", "12.0", "[0.0,1.0,0.0]", "", "/s/a.toml")
    assert (
        rb["title"],
        rb["mesh.length"],
        rb["load.0.value"],
        rb["solver.snes_rtol"],
        rb["scene_file"],
    ) == ("B", "10.0", "[0.0,2.0,0.0]", "1e-10", "/s/b.toml")
    assert ra["overrides"] == "time.dt=0.1" and rb["overrides"] == ""
    assert rf["failure"] == "diverged, badly" and ra["failure"] == ""
    assert (
        ra["steps"],
        ra["newton_iterations"],
        ra["dt_cuts"],
        ra["wall_total_s"],
        ra["dofs"],
        ra["mpi_size"],
        ra["time_reached"],
    ) == ("3", "9", "1", "1.5", "10", "2", "2.0")
    assert ra["late"] == "3.0" and ra["rate(tip_uz,0.5)"] == "2.0"
    assert rf["late"] == "" and rf["rate(tip_uz,0.5)"] == "2.0"
    assert rm["late"] == "" and rm["rate(tip_uz,0.5)"] == "4.0" and rm["steps"] == ""
    assert err.strip() == (
        f"6 runs: 2 ok, 1 failed ({f}), 2 running-or-interrupted ({r}, {s}), "
        f"1 missing-summary ({m})"
    )
    assert len(err.splitlines()) == 1
    # only the runs that differ in dt: one column
    c = fake_run(tmp_path / "c", {**base, "time": {"dt": 0.05, "end": 2.0}})
    status, out, _ = collect_inproc(capsys, a, c)
    assert out.splitlines()[0].split(",")[3:5] == ["time.dt", "overrides"]
    assert [row["time.dt"] for row in table(out)] == ["0.1", "0.05"]


def test_window_past_a_finished_run_is_an_empty_cell_with_a_note(tmp_path, capsys):
    """A quantity whose time a finished run does not reach (a periodic run that
    stopped early) leaves its cell empty and says so on stderr; the table is written
    and the other runs' cells are filled."""
    a = fake_run(tmp_path / "a", {"time": {"dt": 0.1}})
    status, out, err = collect_inproc(
        capsys, a, "--quantity", "tip_uz@3", "--quantity", "w=tip_uz@1"
    )
    assert status == 0
    row = table(out)[0]
    assert row["tip_uz@3"] == "" and row["w"] != ""
    notes = err.strip().splitlines()
    assert notes[0].startswith(
        "rftfem collect: quantity 'tip_uz@3': time 3 is outside the run"
    ) and notes[0].endswith(": an empty cell")
    assert notes[-1] == "1 run: 1 ok"


def test_paths_that_are_not_run_folders_are_skipped_with_a_note(tmp_path, capsys):
    """A stray file and a folder without outputs among the paths (a glob of a results
    folder): each skipped with a note, the runs tabled; nothing but such paths is an
    error."""
    a = fake_run(tmp_path / "a", {"time": {"dt": 0.1}})
    (tmp_path / "sweep.log").write_text("log\n", encoding="utf-8")
    (tmp_path / "plots").mkdir()
    status, out, err = collect_inproc(capsys, a, tmp_path / "sweep.log", tmp_path / "plots")
    assert status == 0 and len(table(out)) == 1
    notes = err.strip().splitlines()
    assert notes[0] == f"rftfem collect: skipped {tmp_path / 'sweep.log'}: not a folder"
    assert notes[1].startswith(f"rftfem collect: skipped {tmp_path / 'plots'}: not a run folder")
    assert notes[2] == "1 run: 1 ok"
    status, out, err = collect_inproc(capsys, tmp_path / "sweep.log")
    assert status == 2 and out == ""
    assert err.startswith("rftfem collect: error: no run folders among the paths given")


@pytest.mark.parametrize(
    "quantities, message",
    [
        (["steps=tip_uz@1"], "the name 'steps' is already a column"),
        (["a=tip_uz@1", "a=tip_uz@2"], "the name 'a' is given twice"),
        (["=tip_uz@1"], "no name before '='"),
    ],
)
def test_bad_quantity_names(tmp_path, capsys, quantities, message):
    a = fake_run(tmp_path / "a", {})
    args = [arg for q in quantities for arg in ("--quantity", q)]
    status, out, err = collect_inproc(capsys, a, *args)
    assert status == 2 and out == "" and message in err and len(err.splitlines()) == 1


# --- three real runs ---------------------------------------------------------------


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """Three folders of `rftfem run demos/rollup.toml`: dt 0.1, dt 0.05, and the
    failing one; returns {name: (folder, summary, probes (header, rows), body)}."""
    exe = rftfem_exe()
    base = tmp_path_factory.mktemp("collect")
    out = {}
    for name, (sets, expected) in RUNS.items():
        folder = base / name
        done = subprocess.run(
            [
                exe,
                "run",
                str(ROLLUP),
                "--out",
                str(folder),
                "--quiet",
                *[a for s in sets for a in ("--set", s)],
            ],
            cwd=ROOT,
            capture_output=True,
            text=True,
            timeout=900,
        )
        assert done.returncode == expected, done.stdout[-2000:] + done.stderr[-2000:]
        summary = json.loads((folder / "summary.json").read_text())

        def read(name):
            rows = list(csv.reader(open(folder / name, encoding="utf-8")))
            return rows[0], np.array(rows[1:], dtype=float)

        out[name] = (folder, summary, read("probes.csv"), read("body.csv"))
    return out


def reference_value(t, x, at):
    return float(np.interp(at, t, x))


def reference_mean(t, x, a, b):
    """Time average of the piecewise-linear x over [a, b], by np.interp and sums."""
    tw = np.concatenate(([a], t[(t > a) & (t < b)], [b]))
    xw = np.interp(tw, t, x)
    return float(np.sum((xw[1:] + xw[:-1]) / 2 * np.diff(tw)) / (b - a))


QUANTITIES = [
    "--quantity",
    "tip=tip_uz@end",
    "--quantity",
    "mid=tip_uz@0.275",
    "--quantity",
    "late=tip_uz@1.5",
    "--quantity",
    "speed=rate(tip_ux, 0.125, 0.475)",
    "--quantity",
    "energy=mean(elastic_energy, 0.2)",
    "--quantity",
    "top=max(centroid_z, 0.1, 0.45)",
]


def test_rows_against_summaries(runs, tmp_path):
    names = list(RUNS)
    folders = [runs[n][0] for n in names]
    done = collect_cli(*folders, "--out", tmp_path / "table.csv", *QUANTITIES)
    assert done.returncode == 0, done.stderr
    assert done.stdout == ""
    assert done.stderr == (
        f"3 runs: 2 ok, 1 failed ({runs['jump'][0]}); table in {tmp_path / 'table.csv'}\n"
    )
    text = (tmp_path / "table.csv").read_text()
    # without --out: the same table on stdout
    printed = collect_cli(*folders, *QUANTITIES)
    assert printed.returncode == 0 and printed.stdout == text
    rows = {row["folder"]: row for row in table(text)}
    assert list(rows) == [str(f) for f in folders]
    for name in names:
        folder, s, (ph, probes), (bh, body) = runs[name]
        row = rows[str(folder)]
        print(name, row)
        assert row["status"] == s["status"] == ("failed" if name == "jump" else "ok")
        assert row["overrides"] == ";".join(s["overrides"])
        assert row["overrides"].split(";") == RUNS[name][0]
        for key in ("steps", "newton_iterations", "dt_cuts"):
            assert int(row[key]) == s["counts"][key]
        assert float(row["wall_total_s"]) == s["wall_s"]["total"]
        assert float(row["time_reached"]) == s["time_reached"]
        assert int(row["dofs"]) == s["dofs"] and int(row["mpi_size"]) == s["mpi_size"] == 1
        t, uz, ux = probes[:, 0], probes[:, ph.index("tip_uz")], probes[:, ph.index("tip_ux")]
        assert float(row["tip"]) == uz[-1]  # a copy of the last row
        assert float(row["mid"]) == pytest.approx(reference_value(t, uz, 0.275), abs=1e-12)
        assert not np.any(np.isclose(t, 0.275))  # interpolated, not a row
        rate = (reference_value(t, ux, 0.475) - reference_value(t, ux, 0.125)) / 0.35
        assert float(row["speed"]) == pytest.approx(rate, abs=1e-12)
        tb, energy = body[:, 0], body[:, bh.index("elastic_energy")]
        assert float(row["energy"]) == pytest.approx(
            reference_mean(tb, energy, 0.2, tb[-1]), abs=1e-12
        )
        cz = body[:, bh.index("centroid_z")]
        inside = cz[(tb > 0.1) & (tb < 0.45)]
        top = max(inside.max(), reference_value(tb, cz, 0.1), reference_value(tb, cz, 0.45))
        assert float(row["top"]) == pytest.approx(top, abs=1e-12)
        if name == "jump":
            assert row["failure"] == s["failure"]["reason"]
            assert "step not resolved" in row["failure"]
            assert t[-1] == 0.5 and row["late"] == ""  # past its last row
        else:
            assert row["failure"] == ""
            assert float(row["late"]) == pytest.approx(reference_value(t, uz, 1.5), abs=1e-12)
    assert float(rows[str(runs["jump"][0])]["energy"]) > 0


def test_distinguishing_columns(runs):
    names = list(RUNS)
    done = collect_cli(*[runs[n][0] for n in names])
    assert done.returncode == 0, done.stderr
    header = done.stdout.splitlines()[0].split(",")
    keys = header[3 : header.index("overrides")]
    assert keys == ["time.dt", "time.max_cuts", "load.0.ramp", "load.0.table"]
    for row, name in zip(table(done.stdout), names):
        scene = runs[name][1]["scene"]
        assert float(row["time.dt"]) == scene["time"]["dt"]
        assert int(row["time.max_cuts"]) == scene["time"]["max_cuts"]
        assert row["load.0.ramp"] == scene["load"][0]["ramp"]
        table_ = scene["load"][0]["table"]
        assert (json.loads(row["load.0.table"]) if row["load.0.table"] else None) == table_
    assert [r["time.dt"] for r in table(done.stdout)] == ["0.1", "0.05", "0.05"]
    # the two ok runs differ only in dt
    done = collect_cli(runs["dt10"][0], runs["dt05"][0])
    assert done.stdout.splitlines()[0].split(",")[3:5] == ["time.dt", "overrides"]
    assert done.stderr == "2 runs: 2 ok\n"


@pytest.mark.parametrize(
    "case, message",
    [
        ("missing", "no such folder"),
        ("empty", "not a run folder (no summary.json, probes.csv, steps.csv, body.csv)"),
        ("bad quantity", "quantity 'rate(tip_ux, 2, 1)': the window needs A < B"),
        ("bad syntax", "quantity 'tip_uz': expected '@'"),
        ("unknown column", "quantity 'tipx_uz@end': unknown column 'tipx_uz' in"),
        ("before", "quantity 'tip_uz@-1': time -1 is outside the run"),
    ],
)
def test_bad_input_one_line(runs, tmp_path, case, message):
    ok = runs["dt05"][0]
    args = {
        "missing": [tmp_path / "nope"],
        "empty": [tmp_path],
        "bad quantity": [ok, "--quantity", "v=rate(tip_ux, 2, 1)"],
        "bad syntax": [ok, "--quantity", "tip_uz"],
        "unknown column": [ok, "--quantity", "tipx_uz@end"],
        "before": [ok, "--quantity", "tip_uz@-1"],
    }[case]
    done = collect_cli(*args)
    assert done.returncode == 2
    assert done.stdout == ""
    assert len(done.stderr.splitlines()) == 1, done.stderr
    assert done.stderr.startswith("rftfem collect: error: ")
    assert message in done.stderr
    if case == "unknown column":
        assert (
            "(valid: tip_ux, tip_uy, tip_uz, load_factor, centroid_x, centroid_y, "
            "centroid_z, elastic_energy)" in done.stderr
        )


def test_collect_module_is_light():
    """collect is imported by every `rftfem` command: no dolfinx, pyvista, mpi4py."""
    code = (
        "import json, sys, rftfem.outputs.collect; print(json.dumps(sorted(m for m in "
        "('dolfinx', 'pyvista', 'mpi4py', 'ufl', 'petsc4py') if m in sys.modules)))"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, timeout=120
    )
    assert done.returncode == 0, done.stderr
    # rftfem/__init__.py may set up the FEniCSx stack; collect itself adds nothing
    base = subprocess.run(
        [sys.executable, "-c", code.replace("rftfem.outputs.collect", "rftfem")],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=120,
    )
    assert json.loads(done.stdout) == json.loads(base.stdout)


# --- the demos that use collect ---------------------------------------------------


@pytest.mark.slow
def test_strip_sweep_table(tmp_path):
    """demos/strip_sweep.sh, two short coarse runs: its collect table (runs.csv)
    has the speed that the demo's own sweep code puts in sweep.csv; a second call
    keeps the finished runs."""
    env = dict(
        env_with_rftfem(),
        FREQS="16 32",
        PERIODS="1",
        WINDOW="0.03",
        STEPS="20",
        PYTHON=sys.executable,
    )
    cmd = [
        "bash",
        str(DEMOS / "strip_sweep.sh"),
        str(tmp_path / "sweep"),
        "--set",
        "mesh.divisions=[10,2]",
        "--set",
        "output.fields=false",
    ]
    done = subprocess.run(cmd, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=3600)
    print(done.stdout[-3000:], done.stderr[-3000:])
    assert done.returncode == 0
    runs_ = table((tmp_path / "sweep" / "runs.csv").read_text())
    sweep = table((tmp_path / "sweep" / "sweep.csv").read_text())
    assert [r["magnetic.field.frequency"] for r in runs_] == ["16.0", "32.0"]
    assert [r["status"] for r in runs_] == ["ok", "ok"]
    for r, s in zip(runs_, sweep):
        assert float(r["mean_speed_mm_s"]) == pytest.approx(float(s["mean_speed_mm_s"]), rel=1e-5)
    assert (tmp_path / "sweep" / "sweep.png").stat().st_size > 0
    again = subprocess.run(cmd, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600)
    assert again.returncode == 0 and again.stdout.count("done before, kept") == 2


@pytest.mark.slow
def test_parameter_study_demo(tmp_path):
    """demos/parameter_study.sh from another folder: four runs, two at a time, and
    the table with the two varied keys; the speed grows with the amplitude."""
    done = subprocess.run(
        ["bash", str(DEMOS / "parameter_study.sh"), "-j", "2", "study"],
        cwd=tmp_path,
        env=env_with_rftfem(),
        capture_output=True,
        text=True,
        timeout=3600,
    )
    print(done.stdout[-3000:], done.stderr[-3000:])
    assert done.returncode == 0
    rows = table((tmp_path / "study" / "table.csv").read_text())
    assert [(r["motion.0.amplitude"], r["motion.0.wavenumber"], r["status"]) for r in rows] == [
        ("0.1", "0.5", "ok"),
        ("0.1", "1.0", "ok"),
        ("0.2", "0.5", "ok"),
        ("0.2", "1.0", "ok"),
    ]
    speed = {(r["motion.0.amplitude"], r["motion.0.wavenumber"]): float(r["speed"]) for r in rows}
    assert speed[("0.2", "0.5")] > 2 * speed[("0.1", "0.5")] > 0


def test_parameter_sweep_demo_is_the_parameter_study(tmp_path):
    """demos/parameter_sweep.sh (one `rftfem sweep`) gives the runs of
    demos/parameter_study.sh (a shell loop and `rftfem collect`): the same speeds and
    powers to the bit, in sweep.csv with the varied keys first."""
    env = env_with_rftfem()
    for script, out in (("parameter_study.sh", "study"), ("parameter_sweep.sh", "sweep")):
        done = subprocess.run(
            ["bash", str(DEMOS / script), "-j", "2", out],
            cwd=tmp_path,
            env=env,
            capture_output=True,
            text=True,
            timeout=3600,
        )
        assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    study_rows = table((tmp_path / "study" / "table.csv").read_text())
    sweep_rows = table((tmp_path / "sweep" / "sweep.csv").read_text())
    key = ("motion.0.amplitude", "motion.0.wavenumber")
    assert list(sweep_rows[0])[:3] == [*key, "status"]
    study_values = {tuple(r[k] for k in key): (r["speed"], r["power"]) for r in study_rows}
    sweep_values = {tuple(r[k] for k in key): (r["speed"], r["power"]) for r in sweep_rows}
    assert len(sweep_values) == 4 and all(r["status"] == "ok" for r in sweep_rows)
    for k, (speed, power) in sweep_values.items():
        assert float(speed) == float(study_values[k][0]) and float(power) == float(
            study_values[k][1]
        ), k
    assert (tmp_path / "sweep" / "sweep.png").stat().st_size > 5000


def test_quantities_take_arithmetic_and_scene_values(tmp_path, capsys):
    """collect, sweep, study and Result.quantity take optimize's formulas of quantities
    (they refused '/'): a rate over a scene value, a difference of two quantities."""
    from rftfem import Result

    scene = {
        "title": "A",
        "time": {"dt": 0.1, "end": 2.0},
        "magnetic": {"field": {"frequency": 4.0}},
    }
    run = fake_run(tmp_path / "a", scene)
    status, out, _ = collect_inproc(
        capsys,
        run,
        "--quantity",
        "step=rate(tip_uz, 0, 2) / scene(magnetic.field.frequency)",
        "--quantity",
        "d=tip_uz@2 - tip_uz@1",
    )
    assert status == 0
    rows = list(csv.DictReader(io.StringIO(out)))
    assert float(rows[0]["step"]) == pytest.approx(2.0 / 4.0)
    assert float(rows[0]["d"]) == pytest.approx(2.0)
    assert Result(run).quantity("rate(tip_uz, 0, 2)/2") == pytest.approx(1.0)
