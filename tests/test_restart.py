"""Checkpoints and restart, end to end through ``rftfem run`` (docs/scenes.md,
"Checkpoints and restart").

A run interrupted at a random step and restarted with ``--restart`` must
reproduce the uninterrupted run: every row of probes.csv and body.csv to 1e-10
(relative to the largest value of the vector each column belongs to; serially
the sheet and the strip are equal bit for bit), the same steps
and Newton iterations, and a fields.xdmf whose time steps (the first part's and
the restart's, in their own HDF5 files) read back like the reference's.  Two
scenes: the swimming sheet (prescribed motion, drag, inertia) and the magnetic
strip, coarse (drag, magnetism, inertia), serially and under mpirun -n 2, and
a rigid magnetic plate with error-controlled BDF2 steps; Stokes flow, contact, and a
free pair of magnets acting on each other (broke for it: the step's start forces,
the interactions among them, not restored: 1.3e-2 off).  A
checkpoint killed while it is written is never the one a restart reads, and a
restart that cannot be one says why in one line.

The interrupt step is drawn from a generator seeded with RESTART_SEED and the
case (a fixed seed; RFTFEM_RESTART_SEED=<n> draws other steps) and printed with
the seed, so a failure names the step and how to draw it again.
"""

from __future__ import annotations

import json
import os
import random
import re
import shutil
import signal
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import DEMOS, ROOT, fields_at, run_command
from running import finish, rank_pids, start_run, tables, vector_scales, wait_for_steps
from stokes_bodies import swimming_sheet_scene

#: seed of the interrupt steps' draws: fixed, or RFTFEM_RESTART_SEED
RESTART_SEED = int(os.environ.get("RFTFEM_RESTART_SEED") or 17)

SHEET_DT = 0.0019634954084936207  # demos/swimming_sheet.toml: a 32nd of the period
CASES = {
    # 51 steps; a checkpoint every 4, a row every 3
    "sheet": (
        DEMOS / "swimming_sheet.toml",
        51,
        ["time.end=0.1", "time.until=end", "time.output_every=3", "output.checkpoint_every=4"],
    ),
    # the field's ramp (phase 1), 30 steps; a checkpoint every 4, a row every 5
    "strip": (
        DEMOS / "bidirectional_strip.toml",
        30,
        [
            "mesh.divisions=[10, 2]",
            "time.end=0.06",
            "time.output_every=5",
            "output.checkpoint_every=4",
        ],
    ),
    # error-controlled BDF2 (its last step and the controller's next one are state):
    # the rigid plate of test_magnetic slipping behind a field turning at 1 Hz,
    # 28 steps to t = 1 (2 rejected); a checkpoint every 3 steps, rows every 0.05
    "plate-bdf2-tolerance": (lambda folder: plate_scene(folder), 28, ["output.checkpoint_every=3"]),
    # Stokes flow (a nonlocal effect) under generalized-α: a sheet swimming by a
    # travelling wave, 40 steps; a checkpoint every 4, a row every 3
    "stokes-sheet": (
        lambda folder: swimming_sheet_scene(folder),
        40,
        ["time.output_every=3", "output.checkpoint_every=4"],
    ),
    # magnetic interactions: a free magnetized pair pulling together under
    # generalized-α (tests/test_magnetic_interactions.py), 40 steps; a checkpoint every 4
    "magnetic-pair": (
        lambda folder: magnetic_pair_scene(folder),
        40,
        ["time.output_every=3", "output.checkpoint_every=4"],
    ),
    # contact: a strip sliding down a slope with anisotropic friction, its friction
    # measured from each step's start (generalized-α), 40 steps; a checkpoint every 4
    "contact-slope": (
        lambda folder: slope_scene(folder),
        40,
        ["time.output_every=3", "output.checkpoint_every=4"],
    ),
}


def magnetic_pair_scene(folder: Path) -> Path:
    from test_magnetic_interactions import PAIR

    text = PAIR.format(end=0.02, dt=0.0005).replace("E = 1.0\n", "E = 1000.0\n")
    text = text.replace("10000.0", "3000.0")
    path = Path(folder) / "pair.toml"
    path.write_text(text, encoding="utf-8")
    return path


def slope_scene(folder: Path) -> Path:
    import math

    from test_contact import STRIP, tilted

    text = STRIP.format(
        end=0.04,
        dt=1e-3,
        rho_inf=0.5,
        gravity=list(tilted(math.atan(0.4))),
        mu_k=[0.2, 0.3, 0.5],
        mu_s=[0.25, 0.35, 0.6],
        extra='[[output.probes]]\nname = "corner"\nat = [2.0, 0.5, 0.0]\n',
    )
    path = Path(folder) / "slope.toml"
    path.write_text(text, encoding="utf-8")
    return path


def plate_scene(folder: Path) -> Path:
    from test_magnetic import PLATE

    text = PLATE.replace(
        'scheme = "backward-euler"',
        'scheme = "bdf2"\nend = 1.0\ndt = 0.01\ntolerance = 1e-3\noutput_every = 5',
    )
    text += (
        "rotation_axis = [0.0, 0.0, 1.0]\nfrequency = 1.0\n"
        '[[output.probes]]\nname = "corner"\nat = [2.0, 1.0, 0.0]\n'
    )
    path = Path(folder) / "plate.toml"
    path.write_text(text, encoding="utf-8")
    return path


def checkpoint_every(sets) -> int:
    return next(int(s.split("=")[1]) for s in sets if s.startswith("output.checkpoint_every="))


def rftfem_run(scene, out, sets, mpirun=None, np_=1, restart=False, timeout=900):
    where = ["--restart", str(out)] if restart else ["--out", str(out)]
    cmd = [sys.executable, "-m", "rftfem", "run", str(scene), *where, "--quiet"]
    cmd += [a for s in sets for a in ("--set", s)]
    env = None
    if np_ > 1:
        exe, env = mpirun
        cmd = [exe, "-n", str(np_), *cmd]
    return run_command(cmd, cwd=ROOT, env=env, timeout=timeout)


def xdmf_times(path: Path) -> dict:
    """The time steps of each field of an XDMF file."""
    text = path.read_text()
    out = {}
    for name, body in re.findall(
        r'<Grid Name="(\w+)" GridType="Collection"[^>]*>(.*?)</Grid>\s*'
        r'(?=<Grid Name="\w+" GridType="Collection"|</Domain>)',
        text,
        flags=re.S,
    ):
        out[name] = [float(v) for v in re.findall(r'<Time Value="([^"]+)"', body)]
    return out


def assert_same_run(ref: Path, run: Path, rtol=1e-10):
    """The restarted run's tables, counts and fields against the reference's."""
    for name in ("probes.csv", "body.csv"):
        a = np.loadtxt(ref / name, delimiter=",", skiprows=1, ndmin=2)
        b = np.loadtxt(run / name, delimiter=",", skiprows=1, ndmin=2)
        assert a.shape == b.shape, (name, a.shape, b.shape)
        np.testing.assert_array_equal(b[:, 0], a[:, 0], err_msg=name)
        scale = np.maximum(vector_scales(ref / name, a), 1e-300)
        assert (np.abs(b - a) <= rtol * scale).all(), (name, np.abs(b - a).max(axis=0) / scale)
    a = np.loadtxt(ref / "steps.csv", delimiter=",", skiprows=1, ndmin=2)
    b = np.loadtxt(run / "steps.csv", delimiter=",", skiprows=1, ndmin=2)
    np.testing.assert_array_equal(b[:, :3], a[:, :3])  # time, dt, Newton its: no row twice
    s_ref = json.loads((ref / "summary.json").read_text())
    s_run = json.loads((run / "summary.json").read_text())
    assert s_run["status"] == "ok" and s_run["restarts"], s_run["status"]
    assert s_run["counts"] == s_ref["counts"]
    assert s_run["time_reached"] == s_ref["time_reached"]
    times = tables(run)[0][:, 0]
    for name, t in xdmf_times(run / "fields.xdmf").items():
        np.testing.assert_allclose(t, times, rtol=0, atol=1e-12, err_msg=name)
    # read back by VTK's XDMF reader (the restart's steps live in fields-1.h5)
    corner = [10.0, 2.0, 0.0]
    _, f_ref = fields_at(ref, corner)
    _, f_run = fields_at(run, corner)
    assert f_ref.shape == f_run.shape
    np.testing.assert_allclose(f_run, f_ref, rtol=0, atol=1e-10 * np.abs(f_ref).max())


def ended_before_signal(out, status) -> bool:
    """The run had finished (summary status ok) when the signal came: exit 0, or
    -SIGTERM when it landed after the run had given its handlers back."""
    summary = out / "summary.json"
    return (
        status in (0, -signal.SIGTERM)
        and summary.exists()
        and json.loads(summary.read_text()).get("status") == "ok"
    )


def interrupt_at_random_step(scene, out, sets, n_steps, mpirun=None, np_=1, case=""):
    """Start a run, SIGTERM it (one of its ranks) after a step drawn at random (seeded
    with RESTART_SEED, ``case`` and ``np_``, and printed); the step."""
    k = random.Random(f"{RESTART_SEED}/{case}/{np_}").randrange(6, n_steps - 6)
    print(
        f"{case} on {np_} process(es): interrupted after step {k} of {n_steps} "
        f"(RFTFEM_RESTART_SEED={RESTART_SEED})"
    )
    for attempt in range(3):
        proc = start_run(scene, out, sets, mpirun, np_)
        ranks = rank_pids(proc, np_)
        wait_for_steps(proc, out, k)
        # frozen first, so that a busy machine cannot let it finish before the signal
        # lands (the test process may be descheduled between its polls)
        os.kill(ranks[-1], signal.SIGSTOP)
        os.kill(ranks[-1], signal.SIGTERM)
        os.kill(ranks[-1], signal.SIGCONT)
        status, stderr = finish(proc)
        if status != 0 and not ended_before_signal(out, status):
            break
        # it had ended all its steps before it was frozen (exit 0, or killed by the
        # signal on its way out, after its handlers were gone): again, stopped earlier
        print(f"the run ended before the signal; again, after step {max(6, k // 2)}")
        k = max(6, k // 2)
        shutil.rmtree(out)
    assert status == 143, stderr[-2000:]
    return k


@pytest.mark.parametrize(
    "np_", [1, pytest.param(2, marks=[pytest.mark.mpi, pytest.mark.long])], ids=["serial", "np2"]
)
@pytest.mark.parametrize(
    "case",
    [
        c if c in ("sheet", "stokes-sheet") else pytest.param(c, marks=pytest.mark.long)
        for c in CASES
    ],
)  # the current leg: the sheet only (CI time)
def test_restart_reproduces_the_run(tmp_path, mpirun, case, np_):
    scene, n_steps, sets = CASES[case]
    scene = scene(tmp_path) if callable(scene) else scene
    ref, run = tmp_path / "reference", tmp_path / "run"
    done = rftfem_run(scene, ref, sets, mpirun, np_)
    assert done.returncode == 0, done.stderr[-2000:]
    k = interrupt_at_random_step(scene, run, sets, n_steps, mpirun, np_, case)
    summary = json.loads((run / "summary.json").read_text())
    stopped = summary["interrupt"]["step"]
    assert stopped >= k
    done = rftfem_run(scene, run, sets, mpirun, np_, restart=True)
    assert done.returncode == 0, done.stderr[-2000:]
    s = json.loads((run / "summary.json").read_text())
    every = checkpoint_every(sets)
    assert s["restarts"][0]["step"] == stopped - stopped % every, (k, stopped, s["restarts"])
    assert_same_run(ref, run)


_KILLED_WRITING = """
import os, sys
from rftfem.outputs import checkpoint
from rftfem import cli
real = checkpoint.os.replace
def replace(src, dst):
    if str(src).endswith("step-00000012.tmp"):
        os._exit(9)  # the process dies inside the third checkpoint, before its rename
    return real(src, dst)
checkpoint.os.replace = replace
sys.exit(cli.main(sys.argv[1:]))
"""


def test_checkpoint_killed_while_written_is_not_read(tmp_path):
    """The sheet's process dies while it writes its third checkpoint (step 12: the
    arrays and meta.json are in step-00000012.tmp, the rename is not done); a
    stray step-00000016 without meta.json is there too.  The restart goes on from
    step 8 and reproduces the reference."""
    scene, _, sets = CASES["sheet"]
    ref, run = tmp_path / "reference", tmp_path / "run"
    assert rftfem_run(scene, ref, sets).returncode == 0
    cmd = [
        sys.executable,
        "-c",
        _KILLED_WRITING,
        "run",
        str(scene),
        "--out",
        str(run),
        "--quiet",
        *[a for s in sets for a in ("--set", s)],
    ]
    done = run_command(cmd, cwd=ROOT, timeout=600)
    assert done.returncode == 9, done.stderr[-2000:]
    saved = run / "checkpoint"
    assert sorted(p.name for p in saved.iterdir()) == [
        "step-00000004",
        "step-00000008",
        "step-00000012.tmp",
    ]
    assert (saved / "step-00000012.tmp" / "meta.json").exists()
    (saved / "step-00000016").mkdir()
    done = rftfem_run(scene, run, sets, restart=True)
    assert done.returncode == 0, done.stderr[-2000:]
    s = json.loads((run / "summary.json").read_text())
    assert s["restarts"] == [{"time": 8 * SHEET_DT, "step": 8, "checkpoint": "step-00000008"}]
    assert_same_run(ref, run)


_SIGNAL_AFTER_CHECKPOINT = """
import os, signal, sys
from rftfem.outputs import checkpoint
from rftfem import cli
real = checkpoint.write
def write(out_dir, step, *args):
    done = real(out_dir, step, *args)
    if step == 8:
        os.kill(os.getpid(), signal.SIGTERM)  # stop after the step of this checkpoint
    return done
checkpoint.write = write
sys.exit(cli.main(sys.argv[1:]))
"""


def test_interrupt_right_after_a_checkpoint(tmp_path):
    """SIGTERM arrives as the checkpoint of step 8 is written, a step without an
    output row (rows every 3): the interrupt's last row is at the checkpoint's
    time, and the restart must drop it (the uninterrupted run has none there)."""
    scene, _, sets = CASES["sheet"]
    ref, run = tmp_path / "reference", tmp_path / "run"
    assert rftfem_run(scene, ref, sets).returncode == 0
    cmd = [
        sys.executable,
        "-c",
        _SIGNAL_AFTER_CHECKPOINT,
        "run",
        str(scene),
        "--out",
        str(run),
        "--quiet",
        *[a for s in sets for a in ("--set", s)],
    ]
    done = run_command(cmd, cwd=ROOT, timeout=600)
    assert done.returncode == 143, done.stderr[-2000:]
    times = tables(run)[0][:, 0]
    assert times[-1] == 8 * SHEET_DT and times[-2] == 6 * SHEET_DT, times
    done = rftfem_run(scene, run, sets, restart=True)
    assert done.returncode == 0, done.stderr[-2000:]
    assert_same_run(ref, run)


def test_finished_run_goes_on_to_a_later_end(tmp_path):
    """A run to 24 steps, restarted with time.end at 51 steps' worth, equals the run
    made to that end at once (its last checkpoint is its last step)."""
    scene, _, sets = CASES["sheet"]
    ref, run = tmp_path / "reference", tmp_path / "run"
    assert rftfem_run(scene, ref, sets).returncode == 0
    short = [*sets, f"time.end={24 * SHEET_DT!r}"]
    assert rftfem_run(scene, run, short).returncode == 0
    again = rftfem_run(scene, run, short, restart=True)
    assert again.returncode == 2 and "raise time.end" in again.stderr, again.stderr
    assert rftfem_run(scene, run, sets, restart=True).returncode == 0
    assert_same_run(ref, run)


def one_line(done, launcher: bool = False) -> str:
    """Exit 2 and rftfem's one line (under mpirun, the first: Open MPI adds its own
    report of the exit status after it)."""
    assert done.returncode == 2, (done.returncode, done.stderr[-2000:])
    lines = done.stderr.strip().splitlines()
    assert "Traceback" not in done.stderr, done.stderr
    assert len(lines) == 1 or (launcher and lines[0].startswith("rftfem: error:")), done.stderr
    return lines[0]


@pytest.mark.mpi
def test_restart_refusals(tmp_path, mpirun):
    """Exit 2 with one line: another physics (names the key and both values),
    another number of processes, --out elsewhere, a folder without checkpoints, a
    checkpoint of another format (an older rftfem's unknowns were numbered apart)."""
    scene, _, sets = CASES["sheet"]
    run = tmp_path / "run"
    assert rftfem_run(scene, run, [*sets, "time.end=0.02"]).returncode == 0
    line = one_line(rftfem_run(scene, run, [*sets, "shell.E=2.0"], restart=True))
    assert "shell.E" in line and "checkpoint:" in line and "2.0" in line, line
    line = one_line(rftfem_run(scene, run, sets, mpirun, 2, restart=True), launcher=True)
    assert "one process" in line and "without mpirun" in line, line
    other = run_command(
        [
            sys.executable,
            "-m",
            "rftfem",
            "run",
            str(scene),
            "--restart",
            str(run),
            "--out",
            str(tmp_path / "elsewhere"),
        ],
        cwd=ROOT,
    )
    assert "--out" in one_line(other)
    (tmp_path / "empty").mkdir()
    line = one_line(rftfem_run(scene, tmp_path / "empty", sets, restart=True))
    assert "no complete checkpoint" in line, line
    for meta in (run / "checkpoint").glob("step-*/meta.json"):
        meta.write_text(meta.read_text().replace('"format": 2', '"format": 1'))
    line = one_line(rftfem_run(scene, run, sets, restart=True))
    assert "checkpoint format 1" in line and "reads 2" in line, line
