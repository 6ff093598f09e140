"""``rftfem optimize`` (issue 35): closed-form optima found, constraints met, failed runs
recorded and penalised, an interrupted optimisation resumed, bad options refused.

The problem with an optimum in closed form: a cantilever strip (length L, width b,
thickness t, modulus E) under a small tip force P, linear range, whose design cost
is its tip deflection plus λ per unit thickness,

    f(t) = w(t) + λ t,   w(t) = 4 P L³ / (E b t³)   (Euler–Bernoulli; shear is 6e-5 of w)

is least at t* = (12 P L³ / (E b λ))^{1/4}.  With the numbers below, t* = 0.1.
With the constraint w ≤ w_max the optimum moves to the constraint's edge,
t_c = (4 P L³ / (E b w_max))^{1/3}.
"""

from __future__ import annotations

import csv
import math
import sys
import tomllib

import pytest

from conftest import ROOT, run_command

P, L, B, E, LAMBDA = 0.004, 10.0, 1.0, 1.2e6, 0.4
T_STAR = (12 * P * L**3 / (E * B * LAMBDA)) ** 0.25
W_MAX = 0.005
T_CONSTRAINED = (4 * P * L**3 / (E * B * W_MAX)) ** (1 / 3)
SCENE = ROOT / "demos" / "end_shear.toml"
#: one linear load step of the cantilever demo, 8 cells; the search starts at t = 0.16
CANTILEVER = ["--set", f"load.0.value=[0,0,{P}]", "--set", "time.dt=1",
              "--set", "mesh.divisions=[8,1]", "--set", "shell.thickness=0.16"]
TRADE_OFF = ["--vary", "shell.thickness=0.05:0.2",
             "--objective", f"tip_uz@end + {LAMBDA}*scene(shell.thickness)"]


def optimize(out, *args):
    return run_command([sys.executable, "-m", "rftfem", "optimize", str(SCENE), "--out",
                        str(out), *map(str, args)], cwd=ROOT, timeout=600)


def rows(out):
    with open(out / "optimize.csv", newline="") as f:
        return list(csv.DictReader(f))


def best_thickness(out) -> float:
    with open(out / "best.toml", "rb") as f:
        return tomllib.load(f)["shell"]["thickness"]


def test_the_reference_optimum():
    assert T_STAR == pytest.approx(0.1, rel=1e-12)
    assert T_CONSTRAINED == pytest.approx(0.13867, rel=1e-4)


@pytest.mark.parametrize("method, scale", [("nelder-mead", ""), ("cobyla", ""),
                                           ("nelder-mead", ":log")])
def test_finds_the_closed_form_optimum(tmp_path, method, scale):
    """Both methods reach t* to 1e-3 (they reach 6e-4 and 6.6e-4), also searching on a
    log scale; best.toml is the best row's scene and runs."""
    out = tmp_path / "opt"
    vary = ["--vary", f"shell.thickness=0.05:0.2{scale}", *TRADE_OFF[2:]]
    done = optimize(out, *vary, *CANTILEVER, "--method", method, "--budget", 40)
    assert done.returncode == 0, done.stderr
    table = rows(out)
    assert all(r["status"] == "ok" for r in table)
    assert float(table[0]["shell.thickness"]) == 0.16          # the scene's own value first
    best = min(table, key=lambda r: float(r["objective"]))
    assert float(best["shell.thickness"]) == pytest.approx(T_STAR, rel=1e-3)
    assert best_thickness(out) == float(best["shell.thickness"])
    assert (out / "optimize.png").stat().st_size > 1000
    assert (out / best["folder"] / "summary.json").is_file()    # an ordinary run folder
    rerun = run_command([sys.executable, "-m", "rftfem", "run", str(out / "best.toml"),
                         "--out", str(tmp_path / "best"), "--quiet"], cwd=ROOT, timeout=300)
    assert rerun.returncode == 0, rerun.stderr


@pytest.mark.parametrize("method", ["nelder-mead", "cobyla"])
def test_a_constraint_moves_the_optimum_to_its_edge(tmp_path, method):
    """w ≤ w_max: cobyla as a constraint, nelder-mead by the penalty; t_c to 1e-2
    (reached: 2e-5 and 1.7e-3), and the best row meets the constraint."""
    out = tmp_path / "opt"
    done = optimize(out, *TRADE_OFF, *CANTILEVER, "--constraint", f"tip_uz@end<={W_MAX}",
                    "--method", method, "--budget", 40)
    assert done.returncode == 0, done.stderr
    table = rows(out)
    feasible = [r for r in table if r["status"] == "ok"]
    assert any(r["status"] == "infeasible" for r in table)     # the start violates it
    best = min(feasible, key=lambda r: float(r["objective"]))
    assert float(best[f"tip_uz@end<={W_MAX}"]) <= W_MAX
    assert float(best["shell.thickness"]) == pytest.approx(T_CONSTRAINED, rel=1e-2)
    assert best_thickness(out) == float(best["shell.thickness"])


def test_failed_runs_are_recorded_and_penalised(tmp_path):
    """The largest tip deflection over a load interval whose upper part does not converge
    in 6 Newton iterations: failed rows with their reason, the search goes on and ends
    at the largest load that converges (a vector component varied: load.0.value.2)."""
    out = tmp_path / "opt"
    done = optimize(out, "--vary", "load.0.value.2=0.1:10", "--objective", "tip_uz@end",
                    "--maximize", "--set", "time.dt=1", "--set", "time.max_cuts=0",
                    "--set", "mesh.divisions=[8,1]", "--set", "solver.snes_max_it=6",
                    "--set", "load.0.value=[0,0,1]", "--budget", 20)
    assert done.returncode == 0, done.stderr
    table = rows(out)
    failed = [r for r in table if r["status"] == "failed"]
    ok = [r for r in table if r["status"] == "ok"]
    assert failed and ok
    assert all("not resolved" in r["failure"] and r["objective"] == "" for r in failed)
    largest_ok = max(float(r["load.0.value.2"]) for r in ok)
    smallest_failed = min(float(r["load.0.value.2"]) for r in failed)
    assert largest_ok < smallest_failed
    # it closed in on the edge (0.7 % apart) and kept away from the failures (4 of 17);
    # with failures scored as good it ends 11 % apart with 14 of 17 failed
    assert smallest_failed / largest_ok - 1 < 0.03
    assert len(failed) < len(ok)
    with open(out / "best.toml", "rb") as f:
        assert tomllib.load(f)["load"][0]["value"] == [0, 0, largest_ok]


def test_an_interrupted_optimisation_resumes(tmp_path):
    """A budget spent after 5 runs, then --reuse with the full budget: the 5 are read,
    not run again, and the result is that of one uninterrupted optimisation."""
    out, whole = tmp_path / "opt", tmp_path / "whole"
    first = optimize(out, *TRADE_OFF, *CANTILEVER, "--budget", 5)
    assert first.returncode == 0 and "budget of 5 runs was spent" in first.stdout
    again = optimize(out, *TRADE_OFF, *CANTILEVER, "--budget", 40, "--reuse")
    assert again.returncode == 0, again.stderr
    resumed = rows(out)
    assert [r["reused"] for r in resumed[:5]] == ["1"] * 5
    assert all(r["reused"] == "0" for r in resumed[5:])
    assert optimize(whole, *TRADE_OFF, *CANTILEVER, "--budget", 40).returncode == 0
    fresh = rows(whole)
    assert [r["shell.thickness"] for r in fresh] == [r["shell.thickness"] for r in resumed]


@pytest.mark.parametrize("args, message", [
    ([], "--vary: give at least one"),
    (["--vary", "shell.thickness=0.2:0.1"], "expected finite LO < HI"),
    (["--vary", "shell.thicknes=0.1:0.2"], "unknown key 'shell.thicknes'"),
    (["--vary", "shell.thickness=-0.1:0.2"], "thickness"),
    (["--vary", "shell.E=0:1e6:log"], "log scale needs LO > 0"),
    (["--vary", "title=0:1"], "expected a key with a number value"),
    (["--vary", "shell.E=1e5:1e7", "--method", "newton"], "unknown method 'newton'"),
    (["--vary", "shell.E=1e5:1e7", "--budget", "0"], "--budget"),
    (["--vary", "shell.E=1e5:1e7", "--objective", "1+2"], "no quantity"),
    (["--vary", "shell.E=1e5:1e7", "--objective", "tip_uz@end", "--constraint", "tip_uz@end"],
     "expected EXPR<=V"),
    (["--vary", "shell.E=1e5:1e7", "--jobs", "2", "--np", "2"], "give one of them"),
    (["--vary", "shell.E=1e5:1e7", "--method", "l-bfgs-b", "--constraint", "tip_uz@end<=1"],
     "use --method cobyla"),
    (["--vary", "shell.E=1e5:1e7", "--objective", "tip_ux@end + nope_uz@end"],
     "unknown column 'nope_uz'"),
])
def test_bad_options_are_one_line_exit_2(tmp_path, args, message):
    if "--objective" not in args:
        args = [*args, "--objective", "tip_uz@end"]
    if "--budget" not in args:
        args = [*args, "--budget", "3"]
    done = optimize(tmp_path / "opt", *args, "--set", "time.dt=1", "--set",
                    "mesh.divisions=[2,1]")
    assert done.returncode == 2, (done.stdout, done.stderr)
    err = done.stderr.strip().splitlines()
    assert len(err) == 1 and message in err[0] and "Traceback" not in done.stderr, err


def test_objective_formulas():
    """Quantities found inside a formula, max/min of the formula told from the quantity
    functions, scene() values read from a run's summary."""
    from rftfem import objective

    ob = objective.parse("rate(centroid_x, 1, 2) / mean(drag_power, 1, 2) - 0.5")
    assert [q.text for q in ob.quantities] == ["rate(centroid_x, 1, 2)", "mean(drag_power, 1, 2)"]
    assert ob.formula.numbers({"q0": 3.0, "q1": 2.0}) == 1.0
    assert [q.text for q in objective.parse("max(rate(x, 1, 2), 0)").quantities] == ["rate(x, 1, 2)"]
    assert [q.text for q in objective.parse("max(elastic_energy)").quantities] == [
        "max(elastic_energy)"]
    c = objective.parse_constraint("tip_uz@end + scene(shell.thickness) >= 2")
    assert (c.sense, c.bound, c.violation(1.5), c.violation(3.0)) == (">=", 2.0, 0.5, 0.0)
    assert math.isclose(objective.parse("-tip_uz@0.5*2").formula.numbers({"q0": 1.0}), -2.0)


@pytest.mark.parametrize("jobs", [1, 2])
def test_a_grid_on_a_log_scale_is_geometric(tmp_path, jobs):
    """--method grid with LO:HI:log: the budget's points equally spaced in log E, the
    tip deflection ∝ 1/E (linear range); with --jobs 2 as child runs side by side."""
    out = tmp_path / "opt"
    done = optimize(out, "--vary", "shell.E=1e5:1e7:log", "--objective", "tip_uz@end",
                    "--method", "grid", "--budget", 3, "--jobs", jobs, *CANTILEVER)
    assert done.returncode == 0, done.stderr
    table = rows(out)
    assert [float(r["shell.E"]) for r in table] == pytest.approx([1e5, 1e6, 1e7], rel=1e-12)
    tips = [float(r["objective"]) for r in table]
    assert tips[0] / tips[1] == pytest.approx(10, rel=1e-3)
    assert tips[1] / tips[2] == pytest.approx(10, rel=1e-4)
