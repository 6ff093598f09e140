"""``rftfem optimize --vary-field`` (rftfem/studies/optimize_fields.py): a thickness
distribution of fixed volume that makes a cantilever stiffest, against the beam's
optimum over the same design space, and the options it refuses.

The cantilever of demos/end_shear.toml, one linear load step (P = 0.004, 8 × 1
cells, ν = 0).  The variables are the thickness at the strip's 9 × 2 node lines,
linear between them, within [0.05, 0.2], the volume that of t = 0.1.  Beam theory
over the same space: δ(t) = ∫ P (L − x)² / (E w t(x)³/12) dx, t piecewise linear
between 9 values along X, minimised by SLSQP at ∫ t dx = 0.1 L (the continuous
optimum, t ∝ √(L − x), is not in that space).
"""

from __future__ import annotations

import csv
import sys

import numpy as np
import pytest
from conftest import ROOT, run_command
from scipy import integrate, optimize

P, L, E, W, T0, LO, HI = 0.004, 10.0, 1.2e6, 1.0, 0.1, 0.05, 0.2
NODES = np.linspace(0.0, L, 9)
SCENE = ROOT / "demos" / "end_shear.toml"
SETS = ["--set", f"load.0.value=[0,0,{P}]", "--set", "time.dt=1", "--set", "mesh.divisions=[8,1]"]


def field_optimize(out, *args):
    return run_command(
        [
            sys.executable,
            "-m",
            "rftfem",
            "optimize",
            str(SCENE),
            "--out",
            str(out),
            *SETS,
            *map(str, args),
        ],
        cwd=ROOT,
        timeout=600,
    )


def beam_deflection(values) -> float:
    def integrand(x):
        t = np.interp(x, NODES, values)
        return P * (L - x) ** 2 / (E * W * t**3 / 12)

    return sum(
        integrate.quad(integrand, a, b, epsabs=0, epsrel=1e-12)[0]
        for a, b in zip(NODES[:-1], NODES[1:])
    )


def beam_optimum() -> tuple[float, np.ndarray]:
    h = NODES[1] - NODES[0]
    weights = np.full(len(NODES), h)
    weights[[0, -1]] = h / 2  # ∫ t dx of a piecewise-linear t
    res = optimize.minimize(
        lambda v: beam_deflection(v) / beam_deflection(np.full(9, T0)),
        np.full(9, T0),
        method="SLSQP",
        bounds=[(LO, HI)] * 9,
        constraints=[{"type": "eq", "fun": lambda v: weights @ v - T0 * L}],
        options={"ftol": 1e-12, "maxiter": 200},
    )
    return beam_deflection(res.x), res.x


def test_stiffest_taper_at_fixed_volume(tmp_path):
    """The shell's optimum tip deflection within 0.3 % of the beam's over the same
    design space (reached −0.035 %, 10 runs; the start, uniform, is 0.013 % from beam
    theory), its values on both node lines (Y = 0 and W) the beam's optimal ones
    within 1e-3 (reached 9.0e-5, at X = 7.5, on both stacks; 0.5 % of the values'
    range 0.05-0.147), at the start's volume to 1e-6, every value within its bounds,
    and best.toml reads best-thickness.csv and reproduces the optimum.  Broke: the
    search's stopping tolerance (optimize_fields.F_TOLERANCE) 1e-7 made 1e-3 → 4 runs,
    the deflection still within 0.3 % (+0.165 %), the values 7.6e-3 off at X = 0."""
    out = tmp_path / "opt"
    done = field_optimize(
        out,
        "--vary-field",
        f"shell.thickness={LO}:{HI}",
        "--objective",
        "tip_uz@end",
        "--constraint",
        "volume=start",
        "--budget",
        "40",
    )
    assert done.returncode == 0, done.stderr
    with open(out / "optimize.csv", newline="") as f:
        rows = [r for r in csv.DictReader(f) if r["status"] == "ok"]
    start = float(rows[0]["objective"])
    best = min(
        (r for r in rows if abs(float(r["volume"]) / float(rows[0]["volume"]) - 1) < 1e-6),
        key=lambda r: float(r["objective"]),
    )
    ours = float(best["objective"])
    exact, values = beam_optimum()
    profile = np.loadtxt(out / "best-thickness.csv", delimiter=",", skiprows=1)
    print(
        f"start {start:.6e} (beam {beam_deflection(np.full(9, T0)):.6e}); optimum "
        f"{ours:.6e}, beam's {exact:.6e}: {ours / exact - 1:+.2e}, {len(rows)} runs"
    )
    lines = [profile[profile[:, 1] == y] for y in (0.0, W)]
    assert all(np.allclose(line[:, 0], NODES, rtol=0, atol=1e-12) for line in lines)
    off = np.array([line[:, 3] - values for line in lines])
    worst = np.abs(off).max(axis=0)
    print(
        "thickness along X:",
        np.round(lines[0][:, 3], 6),
        "beam's",
        np.round(values, 6),
        f"largest difference {worst.max():.2e} at X = {NODES[worst.argmax()]}; across Y "
        f"{np.abs(lines[0][:, 3] - lines[1][:, 3]).max():.1e}",
    )
    assert abs(start / beam_deflection(np.full(9, T0)) - 1) < 1e-3
    assert abs(ours / exact - 1) < 3e-3
    assert worst.max() < 1e-3
    assert ours < 0.8 * start
    assert np.all((profile[:, 3] >= LO - 1e-12) & (profile[:, 3] <= HI + 1e-12))
    rerun = run_command(
        [
            sys.executable,
            "-m",
            "rftfem",
            "run",
            str(out / "best.toml"),
            "--out",
            str(tmp_path / "again"),
            "--quiet",
        ],
        cwd=ROOT,
        timeout=600,
    )
    assert rerun.returncode == 0, rerun.stderr
    tip = np.loadtxt(tmp_path / "again" / "probes.csv", delimiter=",", skiprows=1, ndmin=2)
    assert abs(tip[-1, 3] / ours - 1) < 1e-9


@pytest.mark.parametrize(
    "args, message",
    [
        (["--vary-field", "shell.thickness=0.05:0.2", "--vary", "shell.E=1:2"], "not with --vary"),
        (["--vary-field", "shell.thicknes=0.05:0.2"], "expected one of shell.thickness"),
        (["--vary-field", "shell.thickness=0.2:0.05"], "expected finite LO < HI"),
        (
            ["--vary-field", "shell.thickness=0.05:0.2", "--constraint", "mass=start"],
            "density is 0",
        ),
        (
            ["--vary-field", "shell.thickness=0.05:0.2", "--constraint", "weight<=1"],
            "expected mass or volume",
        ),
        (
            [
                "--vary-field",
                "shell.thickness=0.05:0.2",
                "--method",
                "l-bfgs-b",
                "--constraint",
                "volume=start",
            ],
            "l-bfgs-b takes bounds only",
        ),
        (
            ["--vary-field", "shell.thickness=0.05:0.2", "--method", "cobyla"],
            "searches with l-bfgs-b",
        ),
        (["--vary-field", "shell.thickness=0.05:0.2", "--reuse"], "not with --vary-field"),
        (
            ["--vary-field", "shell.thickness=0.05:0.2", "--objective", "rate(tip_uz, 0, 1)"],
            "quantities the adjoint differentiates",
        ),
        (
            [
                "--vary-field",
                "shell.thickness=0.05:0.2",
                "--set",
                'time.scheme="backward-euler"',
                "--set",
                "fluid.drag=[1,1,1]",
            ],
            "static scenes",
        ),
    ],
)
def test_bad_field_options_are_one_line_exit_2(tmp_path, args, message):
    if "--objective" not in args:
        args = [*args, "--objective", "tip_uz@end"]
    done = field_optimize(tmp_path / "opt", *args, "--budget", "3")
    assert done.returncode == 2, (done.stdout, done.stderr)
    err = done.stderr.strip().splitlines()
    assert len(err) == 1 and message in err[0] and "Traceback" not in done.stderr, err
