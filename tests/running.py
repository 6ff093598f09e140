"""Helpers of the tests that run ``rftfem run`` as a child process and signal it,
restart it or read what it wrote (test_run_endings.py, test_restart.py)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from conftest import ROOT

_H5_TIMES = """
import json, sys
import h5py
with h5py.File(sys.argv[1], "r") as f:
    names = {k: sorted(float(t.replace("_", ".")) for t in f["Function"][k]) for k in f["Function"]}
    first = f["Function/displacement"][sorted(f["Function/displacement"])[0]][()]
print(json.dumps({"names": names, "finite": bool((first == first).all())}))
"""


def _children(pid: int) -> list[int]:
    """Every descendant process of ``pid`` (from /proc)."""
    parents = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                stat = (entry / "stat").read_text()
            except OSError:
                continue
            parents[int(entry.name)] = int(stat.rsplit(")", 1)[1].split()[1])
    found, frontier = [], [pid]
    while frontier:
        p = frontier.pop()
        kids = [c for c, parent in parents.items() if parent == p]
        found += kids
        frontier += kids
    return found


def rank_pids(proc, np_: int) -> list[int]:
    """The rftfem processes of ``proc``: itself, or the ranks under its mpirun."""
    if np_ == 1:
        return [proc.pid]
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        ranks = [
            p
            for p in _children(proc.pid)
            if b"rftfem" in Path(f"/proc/{p}/cmdline").read_bytes()
            and b"mpirun" not in Path(f"/proc/{p}/cmdline").read_bytes()
        ]
        if len(ranks) >= np_:
            return ranks
        time.sleep(0.2)
    pytest.fail(f"the {np_} ranks of mpirun were not found")


def start_run(scene: Path, out: Path, sets=(), mpirun=None, np_: int = 1, restart=False, extra=()):
    """``rftfem run SCENE --out OUT --quiet EXTRA --set ...`` (``--restart OUT`` instead
    of ``--out`` with ``restart``) as a child process, under ``mpirun -n np_`` if > 1."""
    where = ["--restart", str(out)] if restart else ["--out", str(out)]
    cmd = [sys.executable, "-m", "rftfem", "run", str(scene), *where, "--quiet", *extra]
    cmd += [a for s in sets for a in ("--set", s)]
    env = dict(os.environ)
    if np_ > 1:
        exe, env = mpirun
        cmd = [exe, "-n", str(np_), *cmd]
    return subprocess.Popen(
        cmd, cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )


def wait_for_steps(proc, out: Path, steps: int, timeout: float = 600):
    """Until ``steps.csv`` has a row for each of ``steps`` steps."""
    path = out / "steps.csv"
    rows = steps + 1
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if path.exists() and len(path.read_text().splitlines()) >= rows:
            return
        if proc.poll() is not None:
            pytest.fail(f"the run ended before it was signalled: {proc.stderr.read()[-2000:]}")
        time.sleep(0.05)
    proc.kill()
    pytest.fail(f"no {rows} rows in {path} within {timeout} s")


def finish(proc, timeout: float = 120):
    """Wait for the run to end; its exit status and stderr."""
    try:
        stdout, stderr = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        pytest.fail(f"the run did not end within {timeout} s")
    return proc.returncode, stderr


def fields_times(out: Path) -> dict:
    """The times of each field in ``fields.h5``, read with h5py in a child process."""
    done = subprocess.run(
        [sys.executable, "-c", _H5_TIMES, str(out / "fields.h5")],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    h5 = json.loads(done.stdout)
    assert h5["finite"]
    return h5["names"]


def tables(out: Path):
    """probes.csv and body.csv, parsed, finite, with the same times."""
    probes = np.loadtxt(out / "probes.csv", delimiter=",", skiprows=1, ndmin=2)
    body = np.loadtxt(out / "body.csv", delimiter=",", skiprows=1, ndmin=2)
    assert np.isfinite(probes).all() and np.isfinite(body).all()
    np.testing.assert_array_equal(body[:, 0], probes[:, 0])
    return probes, body


def vector_scales(path: Path, table: np.ndarray) -> np.ndarray:
    """Per column, what a relative difference is measured against (a component that
    stays ~0 differs by round-off): the largest magnitude of the vector it is a
    component of (a probe's ux, uy, uz; centroid_x, _y, _z; ...) or of the column
    itself.  A resultant's force and moment (``fluid_Fx`` … ``fluid_Mz``, a
    reaction's) share one scale: the net force on a body turning in place is
    round-off, measured against its moment.
    Energies share one scale, the dissipated power's over the run included: the
    elastic energy of a body that turns rigidly is round-off (1e-12 against 1e-2 on
    the plate) and after a restart it differs in its 7th digit while every
    displacement agrees to round-off."""
    header = path.read_text().splitlines()[0].split(",")
    power = ("drag_power", "fluid_power")
    groups = [
        h.rsplit("_", 1)[0]
        if h.rsplit("_", 1)[-1] in ("x", "y", "z", "ux", "uy", "uz")
        else h[:-2]
        if h[-2:] in ("Fx", "Fy", "Fz", "Mx", "My", "Mz")
        else "energy"
        if h.endswith("_energy") or h in power
        else h
        for h in header
    ]
    size = np.abs(table).max(axis=0)
    size = np.where(np.isin(header, power), size * table[-1, 0], size)
    return np.array([max(size[j] for j, g2 in enumerate(groups) if g2 == g) for g in groups])


def assert_tables_agree(
    reference: Path, other: Path, tolerance: float, what: str, names=("body.csv", "probes.csv")
):
    """Every column of each table of run ``other`` within ``tolerance`` of its vector's
    scale (:func:`vector_scales`) of run ``reference``'s; prints the worst."""
    for name in names:
        a = np.loadtxt(reference / name, delimiter=",", skiprows=1)
        b = np.loadtxt(other / name, delimiter=",", skiprows=1)
        scale = np.maximum(vector_scales(reference / name, a), 1e-300)
        worst = (np.abs(a - b) / scale).max()
        print(f"{name}: {what}, {worst:.2e} of the scale")
        assert worst < tolerance, (name, np.abs(a - b).max(axis=0) / scale)
