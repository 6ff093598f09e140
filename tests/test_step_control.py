"""Step control (docs/model.md §6.8): a solve that diverges stops early, a step too
long is shortened as far as its attempt shows at once, and the shorter sub-step
carries over to the next nominal step.

The roll-up demo in two load steps (time.dt = 1, the tip turning 2π a step) is
the case: Newton cannot take such a step (past π the director map folds back).
"""

from __future__ import annotations

import json
import sys

import numpy as np
import pytest
from conftest import DEMOS, ROOT, run_command


def _rollup(tmp_path, *sets):
    out = tmp_path / "out"
    cmd = [
        sys.executable,
        "-m",
        "rftfem",
        "run",
        str(DEMOS / "rollup.toml"),
        "--out",
        str(out),
        "--quiet",
        "--set",
        "output.fields=false",
        "--set",
        "time.dt=1.0",
        *[a for s in sets for a in ("--set", s)],
    ]
    done = run_command(cmd, cwd=ROOT, timeout=600)
    summary = json.loads((out / "summary.json").read_text())
    return done, summary, out


def test_diverging_solve_stops_early(tmp_path):
    """With no halving allowed the first load step fails, and it fails as soon as an
    iterate's rotation increment reaches π, not after snes_max_it = 25 updates: at
    most 5 Newton updates, and the reason says so (exit 3, one line)."""
    done, summary, _ = _rollup(tmp_path, "time.max_cuts=0")
    print(done.stderr.strip())
    assert done.returncode == 3
    reason = summary["failure"]["reason"]
    assert "rotation increment reached" in reason and ">= pi" in reason, reason
    assert summary["counts"]["newton_iterations"] <= 5, summary["counts"]
    assert len(done.stderr.strip().splitlines()) == 1


def test_cut_as_deep_as_the_overreach_and_carried_over(tmp_path):
    """The first attempt's linearized update turns the tip by about 2π, 12 times the
    static turn limit of 0.5 rad: the step is halved three times at once (one cut,
    dt 1/8); that sub-step turns the tip by 0.79 rad > 0.5, so the next ones are
    halved once more without a failure (1/16), and every later nominal step starts
    at 1/16 instead of trying dt = 1 again: 31 sub-steps and one cut in all
    (before: 13 cuts, each a solve of 25 updates thrown away)."""
    done, summary, out = _rollup(tmp_path)
    assert done.returncode == 0, done.stderr[-2000:]
    steps = np.loadtxt(out / "steps.csv", delimiter=",", skiprows=1)
    sizes = steps[:, 1]
    print(f"counts {summary['counts']}; sub-steps {sorted(set(np.round(sizes, 12)))}")
    assert summary["counts"]["dt_cuts"] == 1
    assert sizes[0] == pytest.approx(1 / 8, rel=1e-12)
    assert np.allclose(sizes[1:], 1 / 16, rtol=1e-9)
    assert len(sizes) == 31
