"""How a run ends early, end to end through ``rftfem run`` (docs/scenes.md,
"Interrupts" and "Exit status").

Interrupts: each test starts a real run of the swimming sheet, waits until steps
are done, signals it and checks the exit status (128 + the signal), the
summary's ``"interrupted"`` with the time and step reached, ``probes.csv`` and
``body.csv`` parseable with one row per output time and (unless a second signal
stopped it inside a step) a last one at the time reached, and ``fields.h5``
readable with h5py (in a child process: h5py and dolfinx may carry different
HDF5 libraries) at the same times.

Failures: the roll-up whose load jumps ten-fold (or to 1e300, a NaN) within its
11th load step, with one halving allowed: exit 3, one line saying where and why,
and every row up to the last good step kept, with one at that step.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import DEMOS, ROOT, run_command
from running import fields_times, finish, rank_pids, start_run, tables, wait_for_steps

SHEET = DEMOS / "swimming_sheet.toml"
EVERY = 7  # output every 7 steps (t = 0 and ...); the signal comes after step 4 or later
SETS = [f"time.output_every={EVERY}", "time.until=end"]
STEPS_BEFORE_SIGNAL = 4


def _check_outputs(out: Path, immediate: bool):
    """The summary says interrupted; CSV and HDF5 are whole up to the time reached."""
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "interrupted", summary["status"]
    stop = summary["interrupt"]
    assert stop["immediate"] is immediate
    assert stop["time"] == summary["time_reached"]
    end = summary["scene"]["time"]["end"]
    dt = summary["scene"]["time"]["dt"]
    assert 0 < stop["time"] < end
    assert stop["step"] == round(stop["time"] / dt)
    probes, _ = tables(out)
    # a row at every output time from t = 0 on, none twice, and (unless stopped
    # inside a step) one at the time reached
    every = EVERY * dt * np.arange(stop["step"] // EVERY + 1)
    expected = every if immediate or stop["step"] % EVERY == 0 else [*every, stop["time"]]
    np.testing.assert_allclose(probes[:, 0], expected, rtol=0, atol=1e-12)
    for name, times in fields_times(out).items():
        np.testing.assert_allclose(times, probes[:, 0], rtol=0, atol=1e-12, err_msg=name)
    return summary


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT], ids=["SIGTERM", "SIGINT"])
def test_signal_stops_after_the_step(tmp_path, sig):
    out = tmp_path / "run"
    proc = start_run(SHEET, out, SETS)
    wait_for_steps(proc, out, STEPS_BEFORE_SIGNAL)
    proc.send_signal(sig)
    status, stderr = finish(proc)
    assert status == 128 + sig, stderr
    assert "Traceback" not in stderr
    lines = stderr.strip().splitlines()
    assert len(lines) == 1 and f"interrupted by {sig.name}" in lines[0], stderr
    summary = _check_outputs(out, immediate=False)
    assert summary["interrupt"]["signal"] == sig.name


def test_second_signal_stops_at_once(tmp_path):
    """SIGINT and SIGTERM sent together: the first is a request, the second stops
    inside the step (CPython runs pending handlers by signal number: SIGINT first)."""
    out = tmp_path / "run"
    proc = start_run(SHEET, out, SETS)
    wait_for_steps(proc, out, STEPS_BEFORE_SIGNAL)
    proc.send_signal(signal.SIGINT)
    proc.send_signal(signal.SIGTERM)
    status, stderr = finish(proc)
    assert status == 130, stderr
    summary = _check_outputs(out, immediate=True)
    assert summary["interrupt"]["signal"] == "SIGINT"


_SIGNALS_AFTER_A_STEP_MOVED = """
import os, signal, sys
from rftfem import cli
from rftfem.outputs.progress import Progress
real = Progress.update
def update(self, t, step, *args):
    if step == 5:  # step 5 has moved the time; it counts as done after this call
        os.kill(os.getpid(), signal.SIGINT)
        os.kill(os.getpid(), signal.SIGTERM)
    return real(self, t, step, *args)
Progress.update = update
sys.exit(cli.main(sys.argv[1:]))
"""


def test_second_signal_after_a_step_moved_the_time(tmp_path):
    """The two signals land between a step's end and its count (the race the test
    above can meet): the interrupt reports the last step counted and its time."""
    out = tmp_path / "run"
    cmd = [sys.executable, "-c", _SIGNALS_AFTER_A_STEP_MOVED, "run", str(SHEET)]
    cmd += ["--out", str(out), "--quiet", *[a for s in SETS for a in ("--set", s)]]
    done = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert done.returncode == 130, done.stderr[-2000:]
    summary = _check_outputs(out, immediate=True)
    assert summary["interrupt"]["step"] == 4, summary["interrupt"]


@pytest.mark.mpi
def test_signal_to_one_rank_stops_all(tmp_path, mpirun):
    """Under mpirun -n 2, SIGTERM to one rank only (the others never see it): every
    rank stops at the same step (else a collective call would hang) and mpirun
    exits 143."""
    out = tmp_path / "run"
    proc = start_run(SHEET, out, SETS, mpirun, np_=2)
    ranks = rank_pids(proc, 2)
    wait_for_steps(proc, out, STEPS_BEFORE_SIGNAL)
    os.kill(ranks[-1], signal.SIGTERM)
    status, stderr = finish(proc)
    assert status == 143, stderr[-2000:]
    summary = _check_outputs(out, immediate=False)
    assert summary["mpi_size"] == 2


# ------------------------------------------------------------------- failures

ROLLUP = DEMOS / "rollup.toml"


@pytest.mark.parametrize(
    "peak, words",
    [
        ("2.5", ["step not resolved", "time.max_cuts"]),
        ("1e300", ["the residual is not finite", "too large for double precision"]),
    ],
    ids=["max-cuts", "nan"],
)
def test_failed_run_keeps_its_rows(tmp_path, peak, words):
    """The roll-up (load steps of 0.05, outputs every 3) under a table ramp that
    follows the demo to t = 0.5 (step 10) and then jumps to ``peak`` × the full
    moment at 0.55; one halving allowed.  Exit 3 with one line naming step 11, its
    time and the cause; summary "failed" with the same; rows at 0, 0.15, 0.3,
    0.45 and at the last good step, 0.5, in both tables and in fields.h5."""
    out = tmp_path / "run"
    sets = [
        'load.0.ramp="table"',
        f"load.0.table=[[0, 0], [0.5, 0.25], [0.55, {peak}]]",
        "time.max_cuts=1",
        "time.output_every=3",
    ]
    cmd = [sys.executable, "-m", "rftfem", "run", str(ROLLUP), "--out", str(out), "--quiet"]
    done = run_command(cmd + [a for s in sets for a in ("--set", s)], cwd=ROOT, timeout=600)
    assert done.returncode == 3, done.stderr[-2000:]
    assert "Traceback" not in done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1, done.stderr
    assert "at t = 0.525 (step 11)" in lines[0] and str(out) in lines[0], lines[0]
    for word in words:
        assert word in lines[0], (word, lines[0])
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "failed"
    failure = summary["failure"]
    assert (failure["time"], failure["step"]) == (0.525, 11)
    assert failure["reason"] in lines[0]
    assert summary["time_reached"] == 0.5 and summary["counts"]["steps"] == 10
    probes, _ = tables(out)
    np.testing.assert_allclose(probes[:, 0], [0, 0.15, 0.3, 0.45, 0.5], rtol=0, atol=1e-12)
    # the last good state: a quarter of the demo's moment bends the strip into half a
    # circle, whose tip is back over the clamp, 2 L / pi below it (the 16x1 mesh
    # within 1 % of L)
    length = 12.0
    np.testing.assert_allclose(
        probes[-1, [1, 3]], [-length, -2 * length / np.pi], rtol=0, atol=0.01 * length
    )
    steps = np.loadtxt(out / "steps.csv", delimiter=",", skiprows=1, ndmin=2)
    np.testing.assert_allclose(steps[:, 0], 0.05 * np.arange(1, 11), rtol=0, atol=1e-12)
    for name, times in fields_times(out).items():
        np.testing.assert_allclose(times, probes[:, 0], rtol=0, atol=1e-12, err_msg=name)


_API_RUN = """
import sys
import rftfem
from rftfem.errors import RunInterrupted
scene = rftfem.load_scene(sys.argv[1], {"time.output_every": 7, "time.until": "end"})
try:
    rftfem.run(scene, out=sys.argv[2])
except RunInterrupted as exc:
    print(f"interrupted: {exc.folder}")
    sys.exit(exc.exit_status)
"""


def test_the_python_api_stops_on_sigterm_and_result_reads_a_running_folder(tmp_path):
    """`rftfem.run` under SIGTERM stops after its step as the command line does: the
    summary says "interrupted" (it died with exit 143 and no summary before) and the
    RunInterrupted it raises names the folder.  While the run goes on, its folder's
    summary says "running" and `Result(folder).status` reads it (it raised
    "summary.json: missing")."""
    import subprocess

    from rftfem import Result

    out = tmp_path / "api-run"
    proc = subprocess.Popen(
        [sys.executable, "-c", _API_RUN, str(SHEET), str(out)],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    wait_for_steps(proc, out, STEPS_BEFORE_SIGNAL)
    assert Result(out).status == "running"
    proc.send_signal(signal.SIGTERM)
    status, stderr = finish(proc)
    assert status == 143, stderr[-2000:]
    assert proc.stdout is not None
    _check_outputs(out, immediate=False)
    assert Result(out).status == "interrupted"


# ------------------------------------------------------------- a slow step

STOKES_SHEET = ['fluid.model="stokes"', "fluid.viscosity=1e-9", "mesh.divisions=[10,2]"]


def _signal_inside_a_step(out: Path, sets) -> tuple[int, str]:
    """Start the Stokes sheet (not quiet, every step slow, a line at every check) and
    SIGTERM it once it prints a Krylov iteration of step 5: inside the step, with at
    least its Newton test still to come.  Returns (exit status, stderr)."""
    env = dict(os.environ, RFTFEM_SLOW_STEP="0", RFTFEM_LOG_INTERVAL="0")
    cmd = [
        sys.executable,
        "-m",
        "rftfem",
        "run",
        str(SHEET),
        "--out",
        str(out),
        "--unset",
        "fluid.drag",
        *[a for s in sets for a in ("--set", s)],
    ]
    proc = subprocess.Popen(
        cmd, cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    for line in proc.stdout:
        if line.startswith("  step 5 towards") and "Krylov iteration" in line:
            proc.send_signal(signal.SIGTERM)
            break
    proc.stdout.read()
    return proc.wait(timeout=600), proc.stderr.read()


def test_signal_in_a_slow_step_drops_it(tmp_path):
    """The sheet in Stokes flow with every step counted as slow (RFTFEM_SLOW_STEP=0):
    SIGTERM in step 5's Krylov iterations drops the step (exit 143, one line saying
    so), the last row is step 4's (as a run to step 4 has it), the summary says
    ``dropped_step``, and the run restarts from its checkpoint to its end.  Broke:
    the model's restore after a dropped step left out (the last row is the dropped
    iterate's)."""
    sets = [*SETS, *STOKES_SHEET, "output.checkpoint_every=2", "time.end=0.05"]
    out = tmp_path / "run"
    status, stderr = _signal_inside_a_step(out, sets)
    assert status == 143, stderr[-2000:]
    lines = stderr.strip().splitlines()
    assert len(lines) == 1 and "inside a slow step, which was dropped" in lines[0], stderr
    summary = _check_outputs(out, immediate=False)
    assert summary["interrupt"]["dropped_step"] is True and summary["interrupt"]["step"] == 4
    # the last row is step 4's state, as a run that ends there has it
    dt = summary["scene"]["time"]["dt"]
    ref = tmp_path / "step4"
    status, stderr = finish(
        start_run(SHEET, ref, [*sets, f"time.end={4 * dt!r}"], extra=["--unset", "fluid.drag"])
    )
    assert status == 0, stderr[-2000:]
    last, expected = (np.loadtxt(d / "body.csv", delimiter=",", skiprows=1)[-1] for d in (out, ref))
    np.testing.assert_allclose(last, expected, rtol=1e-9, atol=1e-12 * np.abs(expected).max())
    proc = start_run(SHEET, out, sets, restart=True, extra=["--unset", "fluid.drag"])
    status, stderr = finish(proc)
    assert status == 0, stderr[-2000:]
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "ok" and summary["time_reached"] == pytest.approx(0.05)


def test_a_slow_step_reports_its_iterations(tmp_path):
    """A step slower than RFTFEM_SLOW_STEP prints where it is: its Newton update and
    Krylov iteration with their residuals; the run opens with the liquid's lines of
    ``rftfem check`` (nodes, operator, memory, time an update, estimated error)."""
    env = dict(os.environ, RFTFEM_SLOW_STEP="0", RFTFEM_LOG_INTERVAL="0")
    cmd = [
        sys.executable,
        "-m",
        "rftfem",
        "run",
        str(SHEET),
        "--out",
        str(tmp_path / "run"),
        "--unset",
        "fluid.drag",
        "--set",
        "time.end=0.002",
    ]
    cmd += [a for s in STOKES_SHEET for a in ("--set", s)]
    done = run_command(cmd, cwd=ROOT, timeout=600, env=env)
    assert done.returncode == 0, done.stderr[-2000:]
    # the run's first lines say the liquid's discretisation and its cost
    assert "fluid: integrated layer, 105 shell nodes" in done.stdout, done.stdout[:2000]
    assert "s of liquid a Newton update" in done.stdout, done.stdout[:2000]
    assert "step 1 towards t = 0.0019635" in done.stdout, done.stdout[-2000:]
    assert "Krylov iteration 1 (residual" in done.stdout, done.stdout[-2000:]
