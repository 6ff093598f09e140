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


@pytest.mark.parametrize("peak, words", [
    ("2.5", ["step not resolved", "time.max_cuts"]),
    ("1e300", ["the residual is not finite", "too large for double precision"]),
], ids=["max-cuts", "nan"])
def test_failed_run_keeps_its_rows(tmp_path, peak, words):
    """The roll-up (load steps of 0.05, outputs every 3) under a table ramp that
    follows the demo to t = 0.5 (step 10) and then jumps to ``peak`` × the full
    moment at 0.55; one halving allowed.  Exit 3 with one line naming step 11, its
    time and the cause; summary "failed" with the same; rows at 0, 0.15, 0.3,
    0.45 and at the last good step, 0.5, in both tables and in fields.h5."""
    out = tmp_path / "run"
    sets = ['load.0.ramp="table"', f"load.0.table=[[0, 0], [0.5, 0.25], [0.55, {peak}]]",
            "time.max_cuts=1", "time.output_every=3"]
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
    np.testing.assert_allclose(probes[-1, [1, 3]], [-length, -2 * length / np.pi],
                               rtol=0, atol=0.01 * length)
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
    proc = subprocess.Popen([sys.executable, "-c", _API_RUN, str(SHEET), str(out)], cwd=ROOT,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    wait_for_steps(proc, out, STEPS_BEFORE_SIGNAL)
    assert Result(out).status == "running"
    proc.send_signal(signal.SIGTERM)
    status, stderr = finish(proc)
    assert status == 143, stderr[-2000:]
    assert proc.stdout is not None
    _check_outputs(out, immediate=False)
    assert Result(out).status == "interrupted"
