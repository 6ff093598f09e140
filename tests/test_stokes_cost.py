"""What a Stokes scene costs, said before it runs and refused when out of reach
(rftfem.model.stokes_report.admit; docs/stokes.md §Cost)."""

from __future__ import annotations

import sys

import pytest

from conftest import DEMOS, ROOT, run_command
from rftfem.errors import SceneError
from rftfem.model import stokes_report

STOKES = ["--unset", "fluid.drag", "--set", 'fluid.model="stokes"', "--set",
          "fluid.viscosity=1e-9"]


def test_a_sheet_too_large_for_the_machine_is_refused():
    """The issue's 200 × 40 sheet (32 481 nodes, 152 GB of dense operator): ``rftfem
    check`` exits 2 with one line giving the memory, the machine's and what to change
    (before: it passed check, then ran 10 minutes and 5 GB without a step).  Broke:
    the memory test left out (refused for its 19 h step instead, no GB said)."""
    cmd = [sys.executable, "-m", "rftfem", "check", str(DEMOS / "swimming_sheet.toml"),
           *STOKES, "--set", "mesh.divisions=[200,40]"]
    done = run_command(cmd, cwd=ROOT, timeout=600)
    assert done.returncode == 2, done.stdout[-1000:] + done.stderr[-2000:]
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1, done.stderr
    for words in ("32481 nodes", "152 GB", "this machine's", "coarser mesh", '"fmm"'):
        assert words in lines[0], (words, lines[0])


def test_a_step_over_an_hour_is_refused(monkeypatch):
    """With this machine's rates set (an LU at 10 GFlop/s, 40 ns a kernel pair) and
    room enough: 12 000 grid nodes (a factorisation of 3.1e3 s an update) are refused
    with the hours and the split; 3000 nodes (49 s) pass, 1900 are not even timed.
    Broke: the factorisation's flops taken for 3N instead of (3N)³ (not refused)."""
    monkeypatch.setattr(stokes_report, "_MEASURED", (1e10, 4e-8))
    monkeypatch.setattr(stokes_report, "machine_memory", lambda: 10 ** 13)
    with pytest.raises(SceneError, match=r"would take about 1\.7\d h .* factorisation of "
                                         r"3\.1\de\+03 s"):
        stokes_report.admit(12000, 5000, 1)
    memory, step = stokes_report.admit(3000, 5000, 1)
    assert memory == pytest.approx(8 * 9000 ** 2 * 2) and step == pytest.approx(
        2 * ((2 / 3) * 9000 ** 3 / 1e10 + 2.5 * 3000 * 5000 * 4e-8))
    assert stokes_report.admit(1900, 5000, 1)[1] is None
