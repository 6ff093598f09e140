"""``rftfem sweep`` and the executors (rftfem/studies/sweep.py, executors.py): a grid
of runs equal to separate ``rftfem run`` calls to the bit, on this process, on a
local Dask cluster, and after a worker dies; --reuse keyed on content (an interrupted
sweep resumed, edits that change runs and edits that do not); the SLURM job script;
bad options."""

from __future__ import annotations

import csv
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from conftest import CANTILEVER, run_command

#: the same in drag, 400 steps: a run of a few seconds to kill a worker during
SLOW = CANTILEVER.replace("dt = 0.25", "dt = 0.0025").replace(
    "[[output.probes]]", "[fluid]\ndrag = [1.0e-3, 1.0e-3, 2.0e-3]\n[[output.probes]]"
)


def rftfem(*args, cwd, timeout=600):
    return run_command([sys.executable, "-m", "rftfem", *map(str, args)], cwd=cwd, timeout=timeout)


def read_rows(path: Path) -> list[dict]:
    with open(path, encoding="utf-8") as fh:
        return list(csv.DictReader(fh))


def tables(folder: Path) -> dict:
    out = {}
    for name in ("probes.csv", "body.csv", "steps.csv"):
        rows = list(csv.reader(open(folder / name, encoding="utf-8")))
        if name == "steps.csv":
            k = rows[0].index("wall_s")
            rows = [r[:k] + r[k + 1 :] for r in rows]
        out[name] = rows
    return out


@pytest.fixture
def scene(tmp_path):
    path = tmp_path / "cantilever.toml"
    path.write_text(CANTILEVER)
    return path


@pytest.mark.parametrize("executor", ["local", "dask"])
def test_a_sweep_equals_separate_runs_to_the_bit(scene, tmp_path, executor):
    """2 × 2 (a list and a range): every run folder's tables are those of `rftfem run`
    with the same --set, bit for bit; sweep.csv has the varied keys first, then status
    and the quantity, which is the closed-form tip deflection's ratios (w ∝ 1/(E t³))."""
    options = ["--executor", executor] + (["--jobs", "2"] if executor == "dask" else [])
    done = rftfem(
        "sweep",
        scene,
        "--vary",
        "shell.E=1e4,2e4",
        "--vary",
        "shell.thickness=0.1:0.2:2",
        "--quantity",
        "w=max(tip_uz)",
        "--out",
        tmp_path / "sweep",
        *options,
        cwd=tmp_path,
    )
    assert done.returncode == 0, done.stderr
    rows = read_rows(tmp_path / "sweep" / "sweep.csv")
    assert list(rows[0])[:4] == ["shell.E", "shell.thickness", "status", "w"]
    assert [(r["shell.E"], r["shell.thickness"], r["status"]) for r in rows] == [
        ("10000.0", "0.1", "ok"),
        ("10000.0", "0.2", "ok"),
        ("20000.0", "0.1", "ok"),
        ("20000.0", "0.2", "ok"),
    ]
    w = {(float(r["shell.E"]), float(r["shell.thickness"])): float(r["w"]) for r in rows}
    assert w[(1e4, 0.1)] / w[(2e4, 0.1)] == pytest.approx(2.0, rel=2e-3)  # 1/E (small w)
    assert w[(1e4, 0.1)] / w[(1e4, 0.2)] == pytest.approx(8.0, rel=2e-2)  # 1/t³
    assert (tmp_path / "sweep" / "sweep.png").stat().st_size > 5000
    for r in rows[::3]:  # two of the four against their own `rftfem run`
        folder = tmp_path / "sweep" / r["folder"]
        alone = tmp_path / f"alone-{r['folder']}"
        done = rftfem(
            "run",
            scene,
            "--out",
            alone,
            "--quiet",
            "--set",
            f"shell.E={r['shell.E']}",
            "--set",
            f"shell.thickness={r['shell.thickness']}",
            cwd=tmp_path,
        )
        assert done.returncode == 0, done.stderr
        assert tables(folder) == tables(alone)


@pytest.mark.mpi
def test_a_dask_worker_runs_np_processes_under_mpirun(scene, tmp_path):
    """--np 2 on a Dask worker: the worker starts `mpirun -n 2 rftfem run`; the run
    reports two processes and its tip deflection is the serial one to round-off."""
    common = ["--vary", "shell.E=1e4", "--quantity", "w=max(tip_uz)"]
    for name, options in (("serial", []), ("mpi", ["--executor", "dask", "--np", "2"])):
        done = rftfem("sweep", scene, *common, "--out", tmp_path / name, *options, cwd=tmp_path)
        assert done.returncode == 0, done.stderr
    serial, mpi = (read_rows(tmp_path / n / "sweep.csv")[0] for n in ("serial", "mpi"))
    assert mpi["status"] == "ok", mpi["reason"]
    summary = (tmp_path / "mpi" / mpi["folder"] / "summary.json").read_text()
    assert '"mpi_size": 2' in summary
    assert float(mpi["w"]) == pytest.approx(float(serial["w"]), rel=1e-10)


def test_reuse_runs_only_what_is_missing_and_a_failed_run_is_a_row(scene, tmp_path):
    out = tmp_path / "sweep"
    args = [
        "sweep",
        scene,
        "--vary",
        "shell.E=1e4,2e4,-1",
        "--quantity",
        "w=max(tip_uz)",
        "--out",
        out,
    ]
    # E = -1 is refused before anything runs: every combination is checked first
    done = rftfem(*args, cwd=tmp_path)
    assert done.returncode == 2 and "shell.E" in done.stderr and not out.exists()
    # one Newton update a step and no step cuts cannot follow the bending: a failure
    args[3] = "solver.snes_max_it=1,50"
    args += ["--set", "time.max_cuts=0"]
    done = rftfem(*args, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    rows = read_rows(out / "sweep.csv")
    assert [r["status"] for r in rows] == ["failed", "ok"]
    assert "run failed" in rows[0]["reason"] and rows[0]["w"] == ""
    stamp = (out / rows[1]["folder"] / "summary.json").stat().st_mtime_ns
    done = rftfem(*args, "--reuse", cwd=tmp_path)
    rows = read_rows(out / "sweep.csv")
    assert [r["status"] for r in rows] == ["failed", "reused"]
    assert (out / rows[1]["folder"] / "summary.json").stat().st_mtime_ns == stamp


def sweep_here(*args, capsys=None) -> tuple[int, str]:
    """`rftfem sweep ARGS` in this process (in-process runs, about 0.2 s each once
    the first has loaded the forms): its exit status and what it said on stderr."""
    from rftfem import cli

    if capsys is not None:
        capsys.readouterr()
    status = cli.main(["sweep", *map(str, args)])
    return status, capsys.readouterr().err if capsys is not None else ""


def stamps(out: Path) -> list:
    return [(f / "summary.json").stat().st_mtime_ns for f in sorted(out.glob("0*"))]


def without(rows: list[dict], *columns) -> list[dict]:
    return [{k: v for k, v in r.items() if k not in columns} for r in rows]


#: three runs of the cantilever, the tip deflection of each; two
GRID = ["--vary", "shell.E=1e4,2e4,3e4", "--quantity", "w=max(tip_uz)"]
PAIR = ["--vary", "shell.E=1e4,2e4", "--quantity", "w=max(tip_uz)"]


def test_an_interrupted_sweep_resumed_with_reuse_equals_an_uninterrupted_one(
    scene, tmp_path, monkeypatch, capsys
):
    """Ctrl-C as the second of three runs ends (its outputs complete, its reuse key
    not yet written; the third never started): --reuse keeps the first, runs the
    second again (a folder without reuse.json is not reused, and stderr says so) and
    the third, and sweep.csv and every run's tables are the uninterrupted sweep's to
    the bit. Broke: the key written as a run starts, not once it ended well
    (write_key before executor.run in run_point) → 0002 held a reuse.json after the
    cut ([True, True]); past that check, the resume ran only ['0003_E=30000']."""
    from rftfem.studies import executors

    assert sweep_here(scene, *GRID, "--out", tmp_path / "whole")[0] == 0
    real, calls, stop = executors.LocalExecutor.run, [], [2]

    def cut(self, scene_file, overrides, folder, petsc_args=None):
        calls.append(Path(folder).name)
        status = real(self, scene_file, overrides, folder, petsc_args)
        if len(calls) in stop:
            raise KeyboardInterrupt
        return status

    monkeypatch.setattr(executors.LocalExecutor, "run", cut)
    out = tmp_path / "cut"
    assert sweep_here(scene, *GRID, "--out", out)[0] == 130  # interrupted
    assert [r["status"] for r in read_rows(out / "sweep.csv")] == ["ok", "pending", "pending"]
    assert [(f / "reuse.json").exists() for f in sorted(out.glob("0*"))] == [True, False]
    first = (out / calls[0] / "summary.json").stat().st_mtime_ns
    calls.clear()
    stop.clear()
    status, err = sweep_here(scene, *GRID, "--out", out, "--reuse", capsys=capsys)
    assert status == 0, err
    assert calls == ["0002_E=20000", "0003_E=30000"]  # only what is missing
    assert (out / "0001_E=10000" / "summary.json").stat().st_mtime_ns == first
    assert "1 finished run(s) run again, not reused (no reuse.json" in err, err
    resumed, whole = (read_rows(p / "sweep.csv") for p in (out, tmp_path / "whole"))
    assert [r["status"] for r in resumed] == ["reused", "ok", "ok"]
    assert without(resumed, "status", "wall_s") == without(whole, "status", "wall_s")
    for r in whole:
        assert tables(out / r["folder"]) == tables(tmp_path / "whole" / r["folder"])


def test_reuse_runs_again_what_an_edited_scene_or_profile_changes(tmp_path, capsys):
    """The base scene's load doubled, then its thickness profile (a CSV the scene
    names) changed: --reuse runs both runs again each time (stderr names what
    changed), and their rows are a fresh sweep's of the edited files to the bit, not
    the stale ones; unedited once more, both are reused. Broke: the file digests left
    out of the key (files = {} in reuse.key_of) → after the profile edit
    ('reused', w 0.79397) where the fresh sweep has ('ok', 0.099909); the completed
    scene's digest left out ("scene": "") → after the load edit ('reused', 0.39894),
    fresh ('ok', 0.79397)."""
    scene = tmp_path / "cantilever.toml"
    scene.write_text(CANTILEVER.replace("thickness = 0.1", 'thickness = "t.csv"'))
    profile = tmp_path / "t.csv"
    profile.write_text("X,Y,Z,t\n0,0,0,0.1\n10,0,0,0.1\n")
    grid, out = PAIR, tmp_path / "sweep"
    assert sweep_here(scene, *grid, "--out", out)[0] == 0
    before = read_rows(out / "sweep.csv")
    edits = [
        (
            scene,
            "value = [0.0, 0.0, 1.0e-3]",
            "value = [0.0, 0.0, 2.0e-3]",
            "the completed scene changed since",
        ),
        (profile, ",0.1\n", ",0.2\n", "the content of shell.thickness.profile changed"),
    ]
    for k, (path, old, new, said) in enumerate(edits):
        path.write_text(path.read_text().replace(old, new))
        status, err = sweep_here(scene, *grid, "--out", out, "--reuse", capsys=capsys)
        assert status == 0, err
        rows = read_rows(out / "sweep.csv")
        assert sweep_here(scene, *grid, "--out", tmp_path / f"fresh{k}")[0] == 0
        fresh = read_rows(tmp_path / f"fresh{k}" / "sweep.csv")
        assert [(r["status"], r["w"]) for r in rows] == [("ok", r["w"]) for r in fresh]
        assert f"2 finished run(s) run again, not reused ({said}" in err, err
        assert all(
            abs(float(a["w"]) - float(b["w"])) > 1e-3 * abs(float(b["w"]))
            for a, b in zip(rows, before)
        )  # the edit changed w (×2, then ×1/8)
        before = rows
    kept = stamps(out)
    assert sweep_here(scene, *grid, "--out", out, "--reuse")[0] == 0
    assert [r["status"] for r in read_rows(out / "sweep.csv")] == ["reused", "reused"]
    assert stamps(out) == kept


def test_reuse_keeps_runs_through_edits_the_completed_scene_does_not_show(scene, tmp_path, capsys):
    """A comment, a value spelled otherwise (0.25 as 2.5e-1), a default written out
    (nu = 0.0), the file's shell.E (every run's --vary replaces it) and the scene
    file moved and renamed: no completed scene changes, so --reuse keeps every run
    untouched. Broke: the scene file's path kept in the key (_path not in
    reuse._BOOKKEEPING) → the moved file's runs ['ok', 'ok'], run again; the scene as
    written kept (_raw) → the edited file's ['ok', 'ok']."""
    grid, out = PAIR, tmp_path / "sweep"
    assert sweep_here(scene, *grid, "--out", out)[0] == 0
    kept = stamps(out)
    edited = (
        ("# edited: nothing a run sees\n" + CANTILEVER)
        .replace("dt = 0.25", "dt = 2.5e-1  # the same")
        .replace("E = 1.0e4", "E = 7.0e4\nnu = 0.0")
    )
    assert edited.count("2.5e-1") == edited.count("7.0e4") == edited.count("nu = 0.0") == 1
    moved = tmp_path / "elsewhere" / "renamed.toml"
    moved.parent.mkdir()
    for path in (scene, moved):
        path.write_text(edited)
        status, err = sweep_here(path, *grid, "--out", out, "--reuse", capsys=capsys)
        assert status == 0, err
        assert [r["status"] for r in read_rows(out / "sweep.csv")] == ["reused", "reused"]
        assert "run again" not in err and stamps(out) == kept


MAGNETIC_GMSH = """
title = "a gmsh mesh and a magnetization profile"
[mesh]
kind = "gmsh"
file = "m.msh"
[shell]
E = 50.0
[time]
end = 0.1
dt = 0.05
[[magnetic.parts]]
region = "all"
profile = "m.csv"
[magnetic.field]
kind = "expression"
B = ["0", "0.3*t", "0.6*t"]
"""


def test_the_reuse_key_covers_the_mesh_file_a_profile_and_the_petsc_options(tmp_path):
    """The key of a scene on a gmsh mesh with a magnetization profile (no run: the
    keys only): a finished run is reused with the same key; a node of the mesh file
    moved, a profile value changed, or a PETSc option added, and the reason names
    that (the content, not the file's time: restored, the key is the first one); a
    folder without reuse.json is not reused and says why; a failed run says nothing.
    Broke: mesh.file left out of reuse.files_read → the moved node kept the key
    (why_not_reused None)."""
    import json
    import shutil

    from rftfem.scene.reading import load_scene
    from rftfem.studies import reuse

    shutil.copy(Path(__file__).parent / "data" / "two_quads_v22.msh", tmp_path / "m.msh")
    (tmp_path / "m.csv").write_text("X,Y,Z,mx,my,mz\n0,0,0,1,0,0\n2,0,0,1,0,0\n")
    scene = tmp_path / "s.toml"
    scene.write_text(MAGNETIC_GMSH)
    key = reuse.key_of(load_scene(scene))
    assert sorted(key["files"]) == ["magnetic.parts.0.profile", "mesh.file"]
    run = tmp_path / "run"
    run.mkdir()
    (run / "summary.json").write_text(json.dumps({"status": "ok"}))
    assert (
        reuse.why_not_reused(run, key) == f"no {reuse.KEY_FILE}: a run from before "
        "--reuse compared content, or one cut short before its key was written"
    )
    reuse.write_key(run, key)
    assert reuse.why_not_reused(run, key) is None
    for name, old, new, said in (
        ("m.msh", "\n2 1 0 0\n", "\n2 1.5 0 0\n", "the content of mesh.file"),
        ("m.csv", "\n2,0,0,1,", "\n2,0,0,2,", "the content of magnetic.parts.0.profile"),
    ):
        text = (tmp_path / name).read_text()
        assert text.count(old) == 1
        (tmp_path / name).write_text(text.replace(old, new))
        assert reuse.why_not_reused(run, reuse.key_of(load_scene(scene))) == f"{said} changed since"
        (tmp_path / name).write_text(text)
        assert reuse.key_of(load_scene(scene)) == key
    petsc = reuse.key_of(load_scene(scene), ["-snes_rtol", "1e-12"])
    assert reuse.why_not_reused(run, petsc) == "the PETSc options changed since"
    (run / "summary.json").write_text(json.dumps({"status": "failed"}))
    assert reuse.why_not_reused(run, key) == ""


def _children_running(pid: int, folder_part: str) -> list:
    import psutil

    found = []
    for proc in psutil.Process(pid).children(recursive=True):
        try:
            line = " ".join(proc.cmdline())
        except psutil.Error:
            continue
        if " run " in f" {line} " and folder_part in line:
            found.append(proc)
    return found


@pytest.mark.long
def test_a_dead_worker_costs_one_retry_then_a_failed_row_that_reuse_finishes(tmp_path):
    """Four Dask workers, four runs of a few seconds. The worker running the first run
    is killed (its child run dies with it), and so is the worker the run is given to
    next: the sweep still ends with every row, the first one failed because its worker
    died; `--reuse` then runs only that one."""
    import psutil  # distributed's dependency

    scene = tmp_path / "slow.toml"
    scene.write_text(SLOW)
    out = tmp_path / "sweep"
    args = [
        sys.executable,
        "-m",
        "rftfem",
        "sweep",
        str(scene),
        "--vary",
        "shell.E=1e4,2e4,3e4,4e4",
        "--quantity",
        "w=max(tip_uz)",
        "--out",
        str(out),
        "--executor",
        "dask",
        "--jobs",
        "4",
    ]
    sweep = subprocess.Popen(
        args, cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    killed, orphans = [], []
    try:
        deadline = time.time() + 240
        while len(killed) < 2 and time.time() < deadline and sweep.poll() is None:
            runs = _children_running(sweep.pid, "0001_E=10000")
            workers = {r.parent().pid for r in runs if r.parent() is not None}
            for worker in workers - set(killed):
                os.kill(worker, signal.SIGKILL)
                killed.append(worker)
                time.sleep(1.0)  # the run (seconds long) dies with its worker at once
                orphans += [
                    r.pid for r in runs if r.is_running() and r.status() != psutil.STATUS_ZOMBIE
                ]
            time.sleep(0.2)
        stdout, stderr = sweep.communicate(timeout=600)
    finally:
        if sweep.poll() is None:
            sweep.kill()
    assert len(killed) == 2, (killed, stderr[-2000:])
    assert sweep.returncode == 0, stderr[-2000:]
    rows = read_rows(out / "sweep.csv")
    assert [r["status"] for r in rows] == ["failed", "ok", "ok", "ok"], rows
    assert "worker" in rows[0]["reason"] and "died" in rows[0]["reason"]
    # the killed workers' runs died with them (no orphan writes into the folder)
    assert not orphans, orphans
    done = run_command([*args, "--reuse"], cwd=tmp_path, timeout=600)
    assert done.returncode == 0, done.stderr
    rows = read_rows(out / "sweep.csv")
    assert [r["status"] for r in rows] == ["ok", "reused", "reused", "reused"]


def test_the_slurm_job_script_has_its_directives(scene, tmp_path):
    config = tmp_path / "cluster.toml"
    config.write_text(
        '[slurm]\nqueue = "short"\naccount = "soft-robots"\njob_extra = ["--constraint=cpu"]\n'
    )
    done = rftfem(
        "sweep",
        scene,
        "--vary",
        "shell.E=1e4,2e4",
        "--executor",
        "slurm",
        "--executor-config",
        config,
        "--slurm",
        "walltime=00:20:00",
        "--slurm",
        "memory=2GB",
        "--np",
        "2",
        "--print-job-script",
        "--out",
        tmp_path / "s",
        cwd=tmp_path,
    )
    assert done.returncode == 0, done.stderr
    script = done.stdout
    directives = [ln for ln in script.splitlines() if ln.startswith("#SBATCH")]
    for expected in (
        "-p short",
        "-A soft-robots",
        "-t 00:20:00",
        "--cpus-per-task=2",
        "--constraint=cpu",
    ):
        assert any(expected in d for d in directives), (expected, directives)
    assert any("--mem=" in d for d in directives)
    assert script.startswith("#!/")
    assert sys.executable in script and "distributed.cli.dask_worker" in script
    assert not (tmp_path / "s").exists()  # nothing ran, nothing submitted


def _one_line(done, *words):
    assert done.returncode == 2, (done.returncode, done.stderr)
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in done.stderr, done.stderr
    for w in words:
        assert w in lines[0], (w, lines[0])


def test_bad_options_are_one_line_and_exit_2(scene, tmp_path):
    vary = ["--vary", "shell.E=1e4,2e4"]
    _one_line(
        rftfem("sweep", scene, *vary, "--executor", "spark", cwd=tmp_path),
        "--executor spark",
        "dask://HOST:PORT",
    )
    t0 = time.perf_counter()
    _one_line(
        rftfem("sweep", scene, *vary, "--executor", "dask://127.0.0.1:9", cwd=tmp_path),
        "no Dask scheduler answers",
        "127.0.0.1:9",
    )
    assert time.perf_counter() - t0 < 10 + 5  # the interpreter's start included
    _one_line(
        rftfem("sweep", scene, "--vary", "time.scheme=1:2:3", cwd=tmp_path),
        "time.scheme",
        "numeric key",
    )
    _one_line(
        rftfem("sweep", scene, "--vary", "shell.E=a:b:3", cwd=tmp_path),
        "--vary shell.E=a:b:3",
        "numbers",
    )
    _one_line(
        rftfem(
            "sweep", scene, "--vary", "shell.E=1:2:3:log", "--vary", "shell.E=3,4", cwd=tmp_path
        ),
        "a key is given twice",
    )
    _one_line(
        rftfem("sweep", scene, "--vary", "shell.EE=1,2", cwd=tmp_path), "unknown key 'shell.EE'"
    )
    _one_line(rftfem("sweep", scene, *vary, "--slurm", "queue=x", cwd=tmp_path), "--executor slurm")
    _one_line(
        rftfem(
            "sweep",
            scene,
            *vary,
            "--executor",
            "slurm",
            "--slurm",
            "nodes=3",
            "--print-job-script",
            cwd=tmp_path,
        ),
        "--slurm nodes=3",
    )
    _one_line(rftfem("sweep", scene, cwd=tmp_path), "--vary")


def test_ranges_and_lists_parse_as_documented():
    from rftfem.errors import SceneError
    from rftfem.studies.sweep import parse_vary

    scene = {
        "shell": {"E": 1.0},
        "time": {"output_every": 1, "scheme": "bdf2"},
        "mesh": {"divisions": [4, 1]},
    }
    assert parse_vary("shell.E=1:3:3", scene).values == [1.0, 2.0, 3.0]
    np.testing.assert_allclose(
        parse_vary("shell.E=1e3:1e5:3:log", scene).values, [1e3, 1e4, 1e5], rtol=1e-14
    )
    assert parse_vary("time.output_every=1:4:4", scene).values == [1, 2, 3, 4]
    assert parse_vary("mesh.divisions=[4,1],[8,2]", scene).values == [[4, 1], [8, 2]]
    assert parse_vary("time.scheme=bdf2,backward-euler", scene).values == ["bdf2", "backward-euler"]
    with pytest.raises(SceneError, match="log range needs LO and HI > 0"):
        parse_vary("shell.E=0:1:3:log", scene)


def test_a_quantity_that_cannot_be_read_marks_its_row(scene, tmp_path):
    """A quantity the runs cannot give (a column no run writes): the rows say
    "ok, quantity missing" with the reason, the other quantity is there, and stderr
    says so once; before, the row read "ok" with an empty cell and nothing said."""
    out = tmp_path / "sweep"
    done = rftfem(
        "sweep",
        scene,
        "--vary",
        "shell.E=1e4,2e4",
        "--quantity",
        "w=max(tip_uz)",
        "--quantity",
        "v=max(no_such_column)",
        "--out",
        out,
        cwd=tmp_path,
    )
    assert done.returncode == 0, done.stderr
    rows = read_rows(out / "sweep.csv")
    assert [r["status"] for r in rows] == ["ok, quantity missing"] * 2
    assert all(r["w"] and not r["v"] and "v: " in r["reason"] for r in rows)
    assert "2 run(s) ok without every quantity (status 'quantity missing')" in done.stderr


def test_sweep_png_gives_each_quantity_its_own_axis(tmp_path):
    """Quantities of different units (a speed and a power) are drawn in panels of their
    own, each labelled on its y axis, not on one axis (the first's scale flattened
    the other); with a second, non-numeric key, a row of panels per quantity."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from rftfem.studies import sweep_report
    from rftfem.studies.sweep import Point, Vary

    def points(varies):
        out = []
        for k, values in enumerate(np.ndindex(*[len(v.values) for v in varies])):
            vals = tuple(v.values[i] for v, i in zip(varies, values))
            out.append(
                Point(
                    k,
                    vals,
                    tmp_path / f"p{k}",
                    [],
                    status="ok",
                    quantities={"speed": 1e-3 * k, "power": 1e-9 * k * k},
                )
            )
        return out

    one = [Vary("shell.E", [1.0, 2.0, 3.0])]
    pts = points(one)
    fig = sweep_report._lines(
        plt,
        pts,
        one,
        ["speed", "power"],
        {p.values: p for p in pts},
        np.array([1.0, 2.0, 3.0]),
        None,
    )
    assert [ax.get_ylabel() for ax in fig.axes] == ["speed", "power"]
    plt.close(fig)
    two = [Vary("shell.E", [1.0, 2.0]), Vary("mesh.cell", ["quadrilateral", "triangle"])]
    pts = points(two)
    fig = sweep_report._lines(
        plt, pts, two, ["speed", "power"], {p.values: p for p in pts}, np.array([1.0, 2.0]), None
    )
    assert [ax.get_ylabel() for ax in fig.axes] == ["speed", "speed", "power", "power"]
    plt.close(fig)
    assert sweep_report.plot(pts, two, ["speed", "power"], tmp_path / "s.png", "x.toml")
