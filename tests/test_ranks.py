"""Rank invariance beyond two processes: ``mpirun -n 3`` (three processes on this
two-core machine: oversubscribed) reproduces the serial probe history of the
swimming sheet and of the magnetic strip to 1e-8, relative to each probe's
largest displacement.  Three processes cut the strip's 20 × 4 cells into parts
with more shared edges and vertices than two, so ghosts, the assembly across
them and the parallel LU all differ from the serial run, and the answer may not."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from conftest import DEMOS, ROOT, run_command
from running import vector_scales

CASES = {
    # two wave periods of the swimming sheet (64 steps), a row every second step
    "sheet": (
        DEMOS / "swimming_sheet.toml",
        [
            "time.end=0.12566370614359174",
            "time.until=end",
            "time.output_every=2",
            "output.fields=false",
        ],
    ),
    # the strip's fold (phase 1) and a fifth of a field period at 4 Hz, a row every 5 steps
    "strip": (DEMOS / "bidirectional_strip.toml", ["time.end=0.15", "output.fields=false"]),
}


def launcher_options(exe: str) -> list[str]:
    """Open MPI refuses more processes than cores without --oversubscribe; MPICH's
    mpiexec oversubscribes as it is and does not know the option."""
    done = subprocess.run([exe, "--version"], capture_output=True, text=True)
    return ["--oversubscribe"] if "Open MPI" in done.stdout + done.stderr else []


@pytest.mark.long
@pytest.mark.mpi
@pytest.mark.parametrize("case", list(CASES))
def test_three_ranks_match_serial(tmp_path, mpirun, case):
    scene, sets = CASES[case]
    exe, env = mpirun
    tables = {}
    for n in (1, 3):
        out = tmp_path / f"np{n}"
        cmd = [sys.executable, "-m", "rftfem", "run", str(scene), "--out", str(out), "--quiet"]
        cmd += [a for s in sets for a in ("--set", s)]
        if n > 1:
            cmd = [exe, *launcher_options(exe), "-n", str(n), *cmd]
        done = run_command(cmd, cwd=ROOT, env=env, timeout=1200)
        assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
        tables[n] = np.loadtxt(out / "probes.csv", delimiter=",", skiprows=1, ndmin=2)
    serial, three = tables[1], tables[3]
    assert serial.shape == three.shape and len(serial) > 10
    np.testing.assert_array_equal(three[:, 0], serial[:, 0])
    scale = vector_scales(tmp_path / "np1" / "probes.csv", serial)
    moved = serial[:, 1:].max(axis=0) - serial[:, 1:].min(axis=0)
    assert moved.max() > 0.05, moved  # the probes do move: the comparison means something
    worst = (np.abs(three - serial) / np.maximum(scale, 1e-300)).max()
    print(f"{case}: serial vs mpirun -n 3, largest relative difference {worst:.2e}")
    assert worst < 1e-8
