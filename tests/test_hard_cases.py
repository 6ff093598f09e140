"""Hard cases: the stability suite of issue 17.

Each case runs a scene through the command line (`rftfem run`, a subprocess with
a timeout) where the solver is pushed: very thin bodies, huge load increments,
long runs, large time steps, stiff contrasts, a change of units, and problems
that have no answer.  Each asserts something that can fail (an exact solution
with a stated tolerance, finite and bounded values, a clear exit status and
reason), and each prints its cost: steps, Newton iterations (also per step),
dt cuts and the wall time of the process (start-up and form compilation
included).  The module prints these rows as a table at its end and writes them
to results/hard_cases.csv.

Newton iteration counts are printed, never asserted: they belong to the solver,
not to the cases.

    ./dev.sh test tests/test_hard_cases.py -s         # the default cases
    ./dev.sh test-full tests/test_hard_cases.py -s    # with the long (slow) variants

(A `-m` on the command line replaces pyproject's `-m 'not slow'`: select the
default cases alone with `-m "hard and not slow"`.)
"""

from __future__ import annotations

import csv
import json
import math
import re
import subprocess
import sys
import time
import tomllib
from pathlib import Path

import numpy as np
import pytest
from conftest import DEMOS, ROOT, fields_at, run_command, write_scene

from rftfem.outputs.quantities import evaluate, read_csv

pytestmark = pytest.mark.hard

#: one row per run: case, what it shows, steps, Newton its, mean, cuts, wall (s)
ROWS: list[dict] = []
TABLE = ROOT / "results" / "hard_cases.csv"
HEADER = ["case", "shows", "steps", "newton", "mean_newton", "cuts", "wall_s"]


@pytest.fixture(scope="module", autouse=True)
def cost_table(request):
    """After the module: the cost rows as a markdown table (printed past pytest's
    capture) and as results/hard_cases.csv."""
    yield
    if not ROWS:
        return
    lines = [
        "",
        "| case | shows | steps | Newton its | mean | dt cuts | wall (s) |",
        "| --- | --- | --- | --- | --- | --- | --- |",
    ]
    for r in ROWS:
        lines.append(
            f"| {r['case']} | {r['shows']} | {r['steps']} | {r['newton']} | "
            f"{r['mean_newton']} | {r['cuts']} | {r['wall_s']} |"
        )
    total = sum(float(r["wall_s"]) for r in ROWS)
    lines.append(f"\n{len(ROWS)} runs, {total:.1f} s of wall time in rftfem processes")
    capture = request.config.pluginmanager.getplugin("capturemanager")
    if capture is not None:
        with capture.global_and_fixture_disabled():
            print("\n".join(lines))
    else:
        print("\n".join(lines))
    TABLE.parent.mkdir(parents=True, exist_ok=True)
    with open(TABLE, "w", newline="", encoding="utf-8") as f:
        writer = csv.DictWriter(f, fieldnames=HEADER)
        writer.writeheader()
        writer.writerows(ROWS)


# --- running a case -------------------------------------------------------------------


class Run:
    """A finished `rftfem run`: exit status, stderr, summary.json and the tables."""

    def __init__(self, out: Path, done, wall: float):
        self.out, self.returncode, self.wall = out, done.returncode, wall
        self.stdout, self.stderr = done.stdout, done.stderr
        path = out / "summary.json"
        self.summary = json.loads(path.read_text()) if path.exists() else {}

    @property
    def status(self) -> str | None:
        return self.summary.get("status")

    @property
    def reason(self) -> str:
        return (self.summary.get("failure") or {}).get("reason", "")

    def table(self, name: str) -> tuple[list[str], np.ndarray]:
        path = self.out / name
        if not path.exists():
            return [], np.zeros((0, 0))
        return read_csv(path)

    def column(self, name: str, file: str = "probes.csv") -> tuple[np.ndarray, np.ndarray]:
        header, data = self.table(file)
        return data[:, 0], data[:, header.index(name)]

    def at(self, name: str, t: float) -> float:
        """A column's value at an output time (rows are written at the nominal steps)."""
        times, values = self.column(
            name, "body.csv" if name.startswith("centroid") else "probes.csv"
        )
        i = int(np.argmin(np.abs(times - t)))
        assert abs(times[i] - t) < 1e-9 * max(1.0, abs(t)), f"no output row at t = {t}"
        return float(values[i])

    def assert_ok(self):
        assert self.returncode == 0 and self.status == "ok", (
            self.returncode,
            self.status,
            self.reason,
            self.stderr[-2000:],
        )


def run_case(case: str, shows: str, scene, out: Path, sets=(), timeout: float = 900) -> Run:
    """`rftfem run SCENE --out OUT --quiet --set ...` in a subprocess; prints and
    records the cost line of the run."""
    cmd = [sys.executable, "-m", "rftfem", "run", str(scene), "--out", str(out), "--quiet"]
    cmd += [arg for s in sets for arg in ("--set", s)]
    start = time.perf_counter()
    try:
        done = run_command(cmd, cwd=ROOT, timeout=timeout)
    except subprocess.TimeoutExpired:
        wall = time.perf_counter() - start
        ROWS.append(
            dict(
                case=case,
                shows=shows,
                steps="",
                newton="",
                mean_newton="",
                cuts="",
                wall_s=f"{wall:.1f}",
            )
        )
        pytest.fail(f"{case}: rftfem run did not end within {timeout:g} s")
    run = Run(Path(out), done, time.perf_counter() - start)
    counts = run.summary.get("counts", {})
    steps, newton = counts.get("steps", 0), counts.get("newton_iterations", 0)
    cuts = counts.get("dt_cuts", 0)
    mean = newton / steps if steps else float("nan")
    compile_s = run.summary.get("wall_s", {}).get("compile", float("nan"))
    print(
        f"[hard] {case}: {steps} steps, {newton} Newton its ({mean:.2f} per step), "
        f"{cuts} dt cuts, {run.wall:.1f} s wall ({compile_s:.1f} s compiling); "
        f"exit {run.returncode}, {run.status}" + (f" ({run.reason})" if run.reason else "")
    )
    ROWS.append(
        dict(
            case=case,
            shows=shows,
            steps=steps,
            newton=newton,
            mean_newton=f"{mean:.2f}",
            cuts=cuts,
            wall_s=f"{run.wall:.1f}",
        )
    )
    return run


def assert_finite_and_bounded(run: Run, length: float):
    """Every probe and centroid value written is finite, and no displacement
    exceeds ten times the body's length (a run that failed at t = 0 wrote none)."""
    for name in ("probes.csv", "body.csv"):
        header, data = run.table(name)
        if not data.size:
            assert run.status == "failed", f"{run.out / name}: no rows"
            continue
        assert np.all(np.isfinite(data)), f"{name}: a value that is not finite"
        if name == "probes.csv":
            assert np.abs(data[:, 1:]).max() < 10 * length, np.abs(data[:, 1:]).max()


def toml_value(x) -> str:
    """A number or a list of numbers as a TOML value for --set."""
    if isinstance(x, (list, tuple)):
        return "[" + ", ".join(toml_value(v) for v in x) + "]"
    if isinstance(x, bool) or not isinstance(x, (int, float)):
        raise TypeError(x)
    return repr(x) if isinstance(x, int) else repr(float(x))


def demo(name: str) -> dict:
    return tomllib.loads((DEMOS / name).read_text(encoding="utf-8"))


# --- the exact roll-up ------------------------------------------------------------------

ROLLUP = DEMOS / "rollup.toml"
ROLLUP_L = 12.0
#: tip displacement tolerance, relative to L, for the roll-up and its variants: ten
#: times what the shipped mesh (16 × 1) reaches at the shipped thickness (t = 0.1):
#: 0.15 % at load parameter 1 (tip_ux = −12.018), 0.75 % at 2 (−12.090)
ROLLUP_TOL = 0.015


def arc_tip(segments) -> tuple[float, float]:
    """End point (x, z) of a clamped strip along +X bent down in the XZ plane by a
    moment about +Y, made of segments (length, curvature) of constant curvature."""
    x = z = phi = 0.0
    for length, kappa in segments:
        if kappa == 0.0:
            x, z = x + length * math.cos(phi), z - length * math.sin(phi)
        else:
            end = phi + kappa * length
            x += (math.sin(end) - math.sin(phi)) / kappa
            z += (math.cos(end) - math.cos(phi)) / kappa
            phi = end
    return x, z


def rollup_tip(lam: float) -> tuple[float, float]:
    """Exact tip displacement (ux, uz) of the roll-up at load parameter λ = M/Mmax
    (curvature 2πλ/L: one closed circle at λ = 1, two turns at λ = 2)."""
    x, z = arc_tip([(ROLLUP_L, 2 * math.pi * lam / ROLLUP_L)])
    return x - ROLLUP_L, z


def assert_rollup_exact(run: Run, times, tol: float = ROLLUP_TOL):
    """tip_ux and tip_uz at each time within ``tol`` L of the exact roll-up."""
    for t in times:
        ux, uz = run.at("tip_ux", t), run.at("tip_uz", t)
        ex, ez = rollup_tip(t)
        print(
            f"  t = {t:g}: tip (ux, uz) = ({ux:.5f}, {uz:.5f}), exact ({ex:.5f}, {ez:.5f}), "
            f"error {max(abs(ux - ex), abs(uz - ez)) / ROLLUP_L:.2e} L"
        )
        assert abs(ux - ex) < tol * ROLLUP_L and abs(uz - ez) < tol * ROLLUP_L, (t, ux, uz)


# --- 1. very thin ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    "thickness",
    [
        pytest.param(0.012, id="L_t_1e3"),
        pytest.param(0.0012, id="L_t_1e4"),
        pytest.param(0.00012, id="L_t_1e5"),
    ],
)
def test_very_thin_rollup(tmp_path, thickness):
    """The roll-up at L/t = 10³, 10⁴, 10⁵ with the bending stiffness E t³ of the
    shipped scene (E = 1.2e6 (0.1/t)³): the membrane stiffness E t grows as 1/t², so
    against bending it is 70 (L/t = 10³) to 7e5 (10⁵) times what it is at the shipped
    t = 0.1 (L/t = 120).  The strip closes into one circle at load
    parameter 1 (tip_ux = −L, tip_uz = 0) and winds twice at 2; the tip stays within
    1.5 % of L of the exact values (ROLLUP_TOL) at both."""
    E = 1.2e6 * (0.1 / thickness) ** 3
    run = run_case(
        f"very-thin L/t={ROLLUP_L / thickness:.0e}",
        "ok, tip exact to 1.5 % L",
        ROLLUP,
        tmp_path / "out",
        [f"shell.thickness={thickness!r}", f"shell.E={E!r}", "output.fields=false"],
    )
    run.assert_ok()
    assert_finite_and_bounded(run, ROLLUP_L)
    assert_rollup_exact(run, [1.0, 2.0])
    # closed circle: the tip is back on the clamp's line (the default thickness gives 7e-6 L)
    assert abs(run.at("tip_uz", 1.0)) < 1e-3 * ROLLUP_L


def test_thinnest_rollup_in_small_load_steps(tmp_path):
    """The roll-up at L/t = 10⁵ in 160 load steps (a quarter of the shipped one):
    ends ok with the tip exact to 1.5 % of L at loads 1 and 2.  Smaller steps are
    not always easier: started from the last state (as static steps were), this
    run reached a tangent near load 1.74 whose LU factorisation outgrew the
    workspace MUMPS had estimated (INFOG(1) = −9; a stiffness ratio of 1e10), and
    the step failed at every size down to 8 halvings.  Such a solve is now
    repeated with more workspace (tests/test_petsc_options.py), and the predicted
    static steps no longer reach that tangent."""
    t = 0.00012
    run = run_case(
        "very-thin L/t=1e+05, 160 load steps",
        "ok, tip exact to 1.5 % L",
        ROLLUP,
        tmp_path / "out",
        [
            f"shell.thickness={t!r}",
            f"shell.E={1.2e6 * (0.1 / t) ** 3!r}",
            "time.dt=0.0125",
            "output.fields=false",
        ],
    )
    run.assert_ok()
    assert_finite_and_bounded(run, ROLLUP_L)
    assert_rollup_exact(run, [1.0, 2.0])


# --- 2. huge increments -------------------------------------------------------------------


@pytest.mark.parametrize("steps", [2, 4, 8])
def test_rollup_in_few_load_steps(tmp_path, steps):
    """The roll-up to two turns in 2, 4 or 8 load steps (a turn, half a turn or a
    quarter turn of the tip per step): ends ok, and the tip at every output is the
    exact one within the tolerance of the thin cases (1.5 % of L).  Steps that Newton
    cannot take whole are halved (counted as cuts)."""
    run = run_case(
        f"huge-steps rollup dt={2.0 / steps:g}",
        "ok, tip exact to 1.5 % L",
        ROLLUP,
        tmp_path / "out",
        [f"time.dt={2.0 / steps!r}", "output.fields=false"],
    )
    run.assert_ok()
    assert_finite_and_bounded(run, ROLLUP_L)
    assert_rollup_exact(run, [k * 2.0 / steps for k in range(1, steps + 1)])


TWIST = DEMOS / "twist.toml"


@pytest.fixture(scope="module")
def twist_reference(tmp_path_factory):
    """The twist demo as shipped (50 load steps): the reference end state."""
    run = run_case(
        "huge-steps twist reference dt=0.02",
        "reference for the one-step twist",
        TWIST,
        tmp_path_factory.mktemp("twist") / "out",
        ["output.fields=false"],
    )
    run.assert_ok()
    return run


def end_rotation(run: Run, t: float) -> float:
    """The angle (rad, in (−π, π]) of the free end's line corner0 → corner1 about X."""
    dy = 1.0 + run.at("corner1_uy", t) - run.at("corner0_uy", t)
    dz = run.at("corner1_uz", t) - run.at("corner0_uz", t)
    return math.atan2(dz, dy)


@pytest.mark.parametrize(
    "dt",
    [pytest.param(1.0, id="one_step"), pytest.param(0.5, id="two_steps", marks=pytest.mark.slow)],
)
def test_twist_in_one_or_two_load_steps(tmp_path, twist_reference, dt):
    """The twist demo (an end torque that turns the free end by about 430° at t = 1)
    in one load step (more than a full turn in a step) or two: ends ok, in the same
    state as the 50-step demo: the same end angle (mod 2π) within 2° and the same
    axial shortening of the corners within 2 %.  A solve that lands on another
    winding (430° − 360° = 70°) shortens the strip far less and fails the second
    check.  (The shortening and the angle change by O(dt) with the load step: 0.3 %
    and 0.4° between 50 steps and 1.)"""
    run = run_case(
        f"huge-steps twist dt={dt:g}",
        "ok, end state of the 50-step twist",
        TWIST,
        tmp_path / "out",
        [f"time.dt={dt!r}", "output.fields=false"],
    )
    run.assert_ok()
    assert_finite_and_bounded(run, 10.0)
    ref = twist_reference
    winding = evaluate("spin(corner0, corner1, x, 0, 1)", ref.out) * 1.0  # rate × 1 s
    angle, angle_ref = end_rotation(run, 1.0), end_rotation(ref, 1.0)
    diff = (angle - angle_ref + math.pi) % (2 * math.pi) - math.pi
    ux, ux_ref = run.at("corner0_ux", 1.0), ref.at("corner0_ux", 1.0)
    print(
        f"  end rotation {math.degrees(angle):.2f}° (mod 360) vs "
        f"{math.degrees(angle_ref):.2f}° in 50 steps (winding {math.degrees(winding):.1f}°); "
        f"corner ux {ux:.5f} vs {ux_ref:.5f}"
    )
    assert math.degrees(winding) > 360.0
    assert abs(math.degrees(diff)) < 2.0
    assert abs(ux / ux_ref - 1) < 0.02


# --- 3. a long run: the rigid magnetic plate, 50 turns ------------------------------------

from test_magnetic import AXES, MB, PLATE, PLATE_L, PLATE_T, PLATE_W  # noqa: E402

PLATE_PROBES = (
    PLATE
    + f"""
[[output.probes]]
name = "a"
at = [0.0, {PLATE_W / 2}, 0.0]
[[output.probes]]
name = "b"
at = [{PLATE_L}, {PLATE_W / 2}, 0.0]
"""
)
_AXIS, _ZETA = AXES["in-plane"]
#: the in-plane axis's critical rate m B t A / ζ (rad/s), 7.85 rad/s
PLATE_OMEGA_C = MB * PLATE_T * PLATE_L * PLATE_W / _ZETA


def double_precision(out: Path) -> Path:
    """The run folder, its fields.xdmf told that the float data are 8-byte: dolfinx
    writes them as float64 but leaves out the Precision attribute, and VTK's XDMF
    reader then reads them as float32 (| |d| − 1 | ~ 3e-8 from rounding alone)."""
    path = out / "fields.xdmf"
    text = re.sub(
        r'<DataItem (?![^>]*(?:NumberType|Precision))([^>]*Format="HDF")',
        r'<DataItem NumberType="Float" Precision="8" \1',
        path.read_text(),
    )
    path.write_text(text)
    return out


def test_plate_follows_field_for_50_turns(tmp_path):
    """The rigid magnetic plate of docs/verification.md case G turning about its
    in-plane axis (Y) behind a field at half its critical rate, for 50 turns in 800
    backward-Euler steps of 1/16 turn (time.max_rotation raised to 0.5 rad to allow
    them).  The plate follows: its mean rate over the last 40 turns equals the
    field's within 2 %; its lag at the end is backward Euler's for a rigid rotor
    within 0.5 % (the chord velocity of a step of ωh turns the drag moment down by
    sin(ωh)/(ωh), so sin α_h = (ω/ω_c) sin(ωh)/(ωh): 29.2° here against Adler's 30°);
    the directors stay unit vectors, | |d| − 1 | < 1e-10 at every quarter turn
    (fields.xdmf, written four times a turn so that the turning is resolved, read in
    double precision) and at the end (summary.json)."""
    ratio, turns, per_turn = 0.5, 50, 16
    omega = ratio * PLATE_OMEGA_C
    period = 2 * math.pi / omega
    end = turns * period
    run = run_case(
        "long-run plate 50 turns",
        "follows, rate 2 %, lag 0.5 %, unit directors",
        write_scene(tmp_path, PLATE_PROBES),
        tmp_path / "out",
        [
            f"magnetic.field.frequency={1 / period!r}",
            f"magnetic.field.rotation_axis={toml_value(_AXIS)}",
            f"time.end={end!r}",
            f"time.dt={period / per_turn!r}",
            "time.max_rotation=0.5",
            f"time.output_every={per_turn // 4}",
        ],
    )
    run.assert_ok()
    assert_finite_and_bounded(run, PLATE_L)
    rate = evaluate(f"spin(a, b, y, {10 * period!r}, {end!r})", run.out)
    # at the end the field is back along +X: the plate's line a -> b lags by α about Y
    dx = PLATE_L + run.at("b_ux", end) - run.at("a_ux", end)
    dz = run.at("b_uz", end) - run.at("a_uz", end)
    lag = math.atan2(dz, dx)
    wh = omega * period / per_turn
    lag_be = math.asin(ratio * math.sin(wh) / wh)
    adler = math.asin(ratio)
    print(
        f"  mean rate {rate:.6f} rad/s vs field {omega:.6f}; lag {math.degrees(lag):.3f}° vs "
        f"backward Euler {math.degrees(lag_be):.3f}° (Adler {math.degrees(adler):.3f}°)"
    )
    assert abs(rate / omega - 1) < 0.02
    assert abs(lag / lag_be - 1) < 0.005
    assert run.summary["director_unit_error"] < 1e-10
    distance, rows = fields_at(double_precision(run.out), [0.0, PLATE_W / 2, 0.0])
    assert distance < 1e-9 and len(rows) == 4 * turns + 1
    print(f"  largest | |d| - 1 | over {len(rows)} written frames: {rows[:, 4].max():.2e}")
    assert rows[:, 4].max() < 1e-10


@pytest.mark.slow
def test_plate_slips_for_50_turns(tmp_path):
    """The same plate behind a field at 1.2 times its critical rate: it slips, and
    over whole slip cycles (about 62, for at least 50 turns of the plate, 100 steps
    a field period) its mean rate is Adler's, ω − √(ω² − ω_c²), within 2 %; the
    directors stay unit vectors (< 1e-10) at the end."""
    ratio = 1.2
    omega = ratio * PLATE_OMEGA_C
    big = math.sqrt(omega**2 - PLATE_OMEGA_C**2)
    exact = omega - big
    slip = 2 * math.pi / big
    end = slip * math.ceil(50 * 2 * math.pi / exact / slip)
    dt = min(2 * math.pi / omega, slip) / 100
    run = run_case(
        "long-run plate slipping 50 turns",
        "Adler rate 2 %, unit directors",
        write_scene(tmp_path, PLATE_PROBES),
        tmp_path / "out",
        [
            f"magnetic.field.frequency={omega / (2 * math.pi)!r}",
            f"magnetic.field.rotation_axis={toml_value(_AXIS)}",
            f"time.end={end!r}",
            f"time.dt={dt!r}",
            "time.output_every=25",
            "output.fields=false",
        ],
        timeout=3600,
    )
    run.assert_ok()
    assert_finite_and_bounded(run, PLATE_L)
    rate = evaluate("spin(a, b, y)", run.out)
    print(
        f"  mean rate {rate:.5f} rad/s vs Adler {exact:.5f} ({100 * (rate / exact - 1):+.2f} %), "
        f"{rate * end / (2 * math.pi):.1f} turns"
    )
    assert rate * end >= 50 * 2 * math.pi * 0.999
    assert abs(rate / exact - 1) < 0.02
    assert run.summary["director_unit_error"] < 1e-10


# --- 4. large time steps ----------------------------------------------------------------------

SHEET = DEMOS / "swimming_sheet.toml"
_SHEET = demo("swimming_sheet.toml")
SHEET_L = _SHEET["mesh"]["length"]
SHEET_PERIOD = 2 * math.pi / _SHEET["motion"][0]["angular_frequency"]
SHEET_EXACT = 0.49763  # docs/verification.md case F, case I
#: docs/figures/accuracy/sheet.md (20 × 4, speed over periods 34-42): 0.50476168 at
#: dt = T/16, 0.49981273 at T/32, 0.49859378 at T/64, observed order 2.02.  The
#: Richardson limit 0.49818746 is 0.11 % off the exact speed (the mesh); the time
#: error at T/16 is 0.00657422 (1.32 %) and grows as dt².
SHEET_LIMIT, SHEET_DT_ERROR_16 = 0.49818746, 0.00657422


def sheet_error_bound(steps_per_period: int) -> float:
    """Relative speed error the study predicts at dt = T/steps_per_period, with a
    factor 2 on the time error: T/8 10.7 %, T/4 42 %."""
    time_error = SHEET_DT_ERROR_16 * (16 / steps_per_period) ** 2
    return (2 * time_error + abs(SHEET_LIMIT - SHEET_EXACT)) / SHEET_EXACT


@pytest.mark.parametrize("steps_per_period", [4, 8])
def test_sheet_large_steps_short(tmp_path, steps_per_period):
    """The swimming sheet in steps of T/4 and T/8 (the demo takes T/32) for 8 wave
    periods: ends ok, every value finite and every displacement under 10 L.  (Its
    speed needs 34 periods to settle: test_sheet_large_steps_speed.)"""
    n = steps_per_period
    run = run_case(
        f"large-dt sheet T/{n} 8 periods",
        "ok, finite, bounded",
        SHEET,
        tmp_path / "out",
        [
            f"time.dt={SHEET_PERIOD / n!r}",
            f"time.end={8 * SHEET_PERIOD!r}",
            "time.output_every=1",
            "time.until=end",
            "output.fields=false",
        ],
    )
    run.assert_ok()
    assert_finite_and_bounded(run, SHEET_L)
    speed = evaluate(f"rate(centroid_x, {6 * SHEET_PERIOD!r}, {8 * SHEET_PERIOD!r})", run.out)
    print(f"  centroid speed over periods 6-8 (still settling): {speed:.4f} mm/s")


@pytest.mark.slow
@pytest.mark.parametrize("steps_per_period", [4, 8])
def test_sheet_large_steps_speed(tmp_path, steps_per_period):
    """The swimming sheet in steps of T/4 and T/8 over 42 periods: its speed over
    periods 34-42 is within the error the accuracy study predicts, extrapolated as
    dt² from T/16 with a factor 2 (sheet_error_bound: 42 % at T/4, 10.7 % at T/8;
    reached 28 % and 5.7 %)."""
    n = steps_per_period
    end = 42 * SHEET_PERIOD
    run = run_case(
        f"large-dt sheet T/{n} 42 periods",
        "speed within the dt² bound",
        SHEET,
        tmp_path / "out",
        [
            f"time.dt={SHEET_PERIOD / n!r}",
            f"time.end={end!r}",
            "time.output_every=1",
            "output.fields=false",
            "time.until=end",
        ],
        timeout=1800,
    )
    run.assert_ok()
    assert_finite_and_bounded(run, SHEET_L)
    speed = evaluate(f"rate(front_ux, {34 * SHEET_PERIOD!r}, {end!r})", run.out)
    error, bound = abs(speed / SHEET_EXACT - 1), sheet_error_bound(n)
    print(
        f"  speed {speed:.5f} vs exact {SHEET_EXACT}: error {100 * error:.2f} %, "
        f"bound {100 * bound:.1f} %"
    )
    assert error < bound


STRIP = DEMOS / "bidirectional_strip.toml"
_STRIP = demo("bidirectional_strip.toml")
STRIP_L = _STRIP["mesh"]["length"]
STRIP_PERIOD = 1 / _STRIP["magnetic"]["field"]["frequency"]
#: centroid_z of the strip with steps of T/100 (dt = 0.0025, no cuts): printed beside
#: the T/10 run's, not asserted (the code's own run, no independent answer)
STRIP_FINE = {0.2: 0.70729, 0.6: -2.65275}


@pytest.mark.parametrize(
    "end",
    [pytest.param(0.2, id="flip"), pytest.param(0.6, id="two_periods", marks=pytest.mark.slow)],
)
def test_strip_ten_steps_a_period_ends_ok_with_cut_steps(tmp_path, end):
    """The bidirectional strip with a nominal 10 steps a field period (the demo takes
    125), through the flip of phase 1 (to t = 0.2) or two periods of swimming (to 0.6).
    Checks only that the run gets through: it ends ok, every value finite and
    bounded, and its counts add up: steps.csv has one row per step of
    summary.json, the steps are no longer than T/10 and tile [0, end] without a gap
    (to round-off, 1e-12 s), and some were cut (steps of T/10 do not resolve the
    flip: reached 6 cuts and 39 steps to 0.2, against 8 nominal steps).  Its accuracy is
    not checked: there is no independent answer for this strip; the centroid height
    is printed beside that of the code's own run with steps of T/100."""
    dt = STRIP_PERIOD / 10
    run = run_case(
        f"large-dt strip T/10 to {end:g}",
        "ok, finite, counts add up",
        STRIP,
        tmp_path / "out",
        [f"time.dt={dt!r}", f"time.end={end!r}", "output.fields=false"],
    )
    run.assert_ok()
    assert_finite_and_bounded(run, STRIP_L)
    header, steps = run.table("steps.csv")
    counts = run.summary["counts"]
    t, h = steps[:, header.index("time")], steps[:, header.index("dt")]
    z = run.at("centroid_z", end)
    print(
        f"  {counts['steps']} steps, {counts['dt_cuts']} dt cuts; centroid_z({end:g}) = "
        f"{z:.5f}, {STRIP_FINE[end]} with T/100 ({abs(z - STRIP_FINE[end]) / STRIP_L:.2e} L; "
        "not asserted)"
    )
    assert len(t) == counts["steps"]
    assert h.max() <= dt * (1 + 1e-12)
    assert np.abs(np.cumsum(h) - t).max() < 1e-12 and abs(t[-1] - end) < 1e-12
    assert counts["dt_cuts"] >= 1


# --- 5. stiff contrasts ---------------------------------------------------------------------


def contrast_scene(tmp_path) -> Path:
    """The roll-up with two halves, "root" (X in [0, 6]) and "outer" ([6, 12])."""
    text = ROLLUP.read_text(encoding="utf-8")
    regions = (
        'cell = "quadrilateral"\n[[mesh.regions]]\nname = "root"\nx = [0.0, 6.0]\n'
        '[[mesh.regions]]\nname = "outer"\nx = [6.0, 12.0]\n'
    )
    part = '[[shell.parts]]\nregion = "root"\nE = 1.2e12\n\n[time]'
    assert text.count('cell = "quadrilateral"\n') == 1 and text.count("\n[time]") == 1
    text = text.replace('cell = "quadrilateral"\n', regions).replace("\n[time]", "\n" + part)
    return write_scene(tmp_path, text, "contrast.toml")


@pytest.mark.parametrize("stiff", ["root", "outer"])
def test_stiffness_contrast_1e6(tmp_path, stiff):
    """The roll-up with one half 10⁶ times stiffer (E = 1.2e12 against 1.2e6): the
    soft half alone bends, with the roll-up's curvature 2πλ/L, and the stiff half
    stays straight.  Exact tips from the two arcs (arc_tip) at λ = 0.5 (a quarter
    circle) and 1 (a half circle): within 1.5 % of L."""
    run = run_case(
        f"contrast E 1e6 stiff {stiff}",
        "ok, two-arc tip 1.5 % L",
        contrast_scene(tmp_path),
        tmp_path / "out",
        [f'shell.parts.0.region="{stiff}"', "output.fields=false"],
    )
    run.assert_ok()
    assert_finite_and_bounded(run, ROLLUP_L)
    for lam in (0.5, 1.0):
        kappa = 2 * math.pi * lam / ROLLUP_L
        arcs = [(6.0, 0.0), (6.0, kappa)] if stiff == "root" else [(6.0, kappa), (6.0, 0.0)]
        x, z = arc_tip(arcs)
        ux, uz = run.at("tip_ux", lam), run.at("tip_uz", lam)
        print(f"  λ = {lam}: tip ({ux:.5f}, {uz:.5f}) vs exact ({x - ROLLUP_L:.5f}, {z:.5f})")
        assert abs(ux - (x - ROLLUP_L)) < ROLLUP_TOL * ROLLUP_L
        assert abs(uz - z) < ROLLUP_TOL * ROLLUP_L


def assert_ok_or_clear_failure(run: Run):
    """Exit 0 and ok, or exit 3 with summary.json "failed", a reason, and one line on
    stderr that gives it."""
    assert "Traceback" not in run.stderr, run.stderr[-2000:]
    if run.returncode == 0:
        assert run.status == "ok"
        return
    assert run.returncode == 3, (run.returncode, run.stderr[-2000:])
    assert run.status == "failed" and run.reason, run.summary
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and run.reason in lines[0], run.stderr


@pytest.mark.parametrize("factor", [1e-6, 1e6])
def test_sheet_drag_contrast(tmp_path, factor):
    """The swimming sheet with every drag coefficient 10⁻⁶ or 10⁶ times the demo's,
    for two periods: ends ok, finite and bounded.

    At 10⁻⁶ the sheet's relaxation time ρ t / C₁ is 3e5 s: it is a body in vacuum,
    whose momentum along X is conserved, so its centroid stays where it is while
    the wave runs (within 1 % of the distance it swims in water).  The t = 0
    equilibrium, whose only hold on the free sheet's rigid motions in X and Y is
    then drag of 1e-15 N s/mm³, stalls at a residual of round-off (1e-14 N, from
    elastic forces of E t W = 20 N): converged once Newton no longer reduces it,
    no longer a failure after 25 Newton updates (as it was on dolfinx 0.5.2).
    At 10⁶ the relaxation time is 0.3 μs, so the sheet swims at the RFT speed
    from the first period on: the second period's speed is the exact one within
    2 % (dt = T/32: 0.3 % reached; the study's time error at T/32 is 0.44 %)."""
    drag = [c * factor for c in _SHEET["fluid"]["drag"]]
    run = run_case(
        f"drag x{factor:g} sheet",
        "ok; x1e-6 centroid still, x1e6 speed 2 %",
        SHEET,
        tmp_path / "out",
        [
            f"fluid.drag={toml_value(drag)}",
            f"time.end={2 * SHEET_PERIOD!r}",
            "time.output_every=1",
            "output.fields=false",
        ],
    )
    run.assert_ok()
    assert_finite_and_bounded(run, SHEET_L)
    if factor > 1:
        speed = evaluate(f"rate(front_ux, {SHEET_PERIOD!r}, {2 * SHEET_PERIOD!r})", run.out)
        print(f"  speed over the second period {speed:.5f} vs exact {SHEET_EXACT}")
        assert abs(speed / SHEET_EXACT - 1) < 0.02
    else:
        times, x = run.column("centroid_x", "body.csv")
        drift, swim = abs(x[-1] - x[0]), SHEET_EXACT * 2 * SHEET_PERIOD
        print(f"  centroid moved {drift:.3e} mm in two periods; in water {swim:.3e} mm")
        assert drift < 0.01 * swim


def test_strip_magnetization_x100(tmp_path):
    """The bidirectional strip with 100 times the demo's magnetization (so 100 times
    its couples), the first 0.02 s of the field's ramp (a fifth of it): ok, or exit 3
    with its reason; whatever was written is finite and bounded."""
    sets = [
        f"magnetic.parts.{i}.magnetization={100 * p['magnetization']!r}"
        for i, p in enumerate(_STRIP["magnetic"]["parts"])
    ]
    run = run_case(
        "magnetic couple x100 strip",
        "ok or exit 3 + reason, finite",
        STRIP,
        tmp_path / "out",
        sets + ["time.end=0.02", "output.fields=false"],
    )
    assert_ok_or_clear_failure(run)
    assert_finite_and_bounded(run, STRIP_L)


# --- 6. scale invariance: mm–t–s against m–kg–s ------------------------------------------

#: mm–t–s (force in N) to m–kg–s (force in N: t·mm/s² = 1e3 kg · 1e-3 m/s²), the
#: factor on a value of each dimension
SI = {
    "length": 1e-3,  # mm -> m
    "1/length": 1e3,  # rad/mm -> rad/m
    "force": 1.0,  # N -> N
    "force*length": 1e-3,  # N·mm -> N·m (a moment, a total edge moment)
    "force/length^2": 1e6,  # MPa = N/mm² -> Pa (E, a pressure)
    "mass/length^3": 1e12,  # t/mm³ = 1e3 kg / 1e-9 m³ -> kg/m³
    "force*time/length^3": 1e9,  # N·s/mm³ -> N·s/m³ (drag)
    "current/length": 1e3,  # A/mm -> A/m (magnetization)
    "force/(current*length)": 1e3,  # N/(A·mm) -> N/(A·m) = T (flux density)
    "length/time^2": 1e-3,  # mm/s² -> m/s² (gravity)
}
#: the dimension of each dimensional key a scene may hold (index-free paths)
DIMENSIONS = {
    "mesh.length": "length",
    "mesh.width": "length",
    "mesh.link_width": "length",
    "mesh.regions.x": "length",
    "mesh.regions.y": "length",
    "mesh.hinge_stiffness": "force",
    "hinge.stiffness": "force",
    "shell.thickness": "length",
    "shell.E": "force/length^2",
    "shell.density": "mass/length^3",
    "shell.parts.thickness": "length",
    "shell.parts.E": "force/length^2",
    "shell.parts.density": "mass/length^3",
    "fluid.drag": "force*time/length^3",
    "motion.amplitude": "length",
    "motion.wavenumber": "1/length",
    "motion.origin": "length",
    "magnetic.parts.magnetization": "current/length",
    "magnetic.field.strength": "force/(current*length)",
    "output.probes.at": "length",
    "load.at": "length",
}
LOAD_DIMENSIONS = {
    "edge-moment": "force*length",
    "edge-force": "force",
    "point-force": "force",
    "pressure": "force/length^2",
    "gravity": "length/time^2",
}
#: keys without a length, mass or current in them (times are seconds in both)
DIMENSIONLESS = {
    "title",
    "mesh.kind",
    "mesh.divisions",
    "mesh.cell",
    "mesh.regions.name",
    "shell.nu",
    "shell.axis",
    "shell.parts.region",
    "shell.parts.nu",
    "time.end",
    "time.dt",
    "time.scheme",
    "time.rho_inf",
    "time.alpha",
    "time.output_every",
    "time.max_cuts",
    "time.tolerance",
    "time.dt_min",
    "time.dt_max",
    "time.max_rotation",
    "time.until",
    "time.period",
    "time.steady_tolerance",
    "boundary.where",
    "boundary.fix",
    "boundary.symmetry",
    "load.kind",
    "load.where",
    "load.ramp",
    "load.table",
    "motion.where",
    "motion.component",
    "motion.kind",
    "motion.angular_frequency",
    "motion.phase",
    "motion.ramp_time",
    "magnetic.parts.region",
    "magnetic.parts.direction",
    "magnetic.field.ramp_time",
    "magnetic.field.direction",
    "magnetic.field.frequency",
    "magnetic.field.rotation_axis",
    "output.fields",
    "output.render",
    "output.probes.name",
    "solver.pc_factor_mat_ordering_type",
}


def si_overrides(scene: dict, factor: dict = SI) -> list[str]:
    """--set overrides that restate a mm–t–s scene in m–kg–s: every dimensional
    value times its factor.  A key this table does not know fails the test (it
    may carry a unit that would go unconverted)."""
    sets = []

    def walk(node, path, bare):
        if isinstance(node, dict):
            for key, value in node.items():
                walk(value, f"{path}.{key}" if path else key, f"{bare}.{key}" if bare else key)
            return
        if isinstance(node, list) and node and isinstance(node[0], dict):
            for i, entry in enumerate(node):
                walk(entry, f"{path}.{i}", bare)
            return
        if bare == "load.value":
            kind = scene["load"][int(path.split(".")[1])]["kind"]
            dimension = LOAD_DIMENSIONS[kind]
        elif bare in DIMENSIONS:
            dimension = DIMENSIONS[bare]
        else:
            assert bare in DIMENSIONLESS, f"scale invariance: no unit known for {bare}"
            return
        scale = factor[dimension]
        value = [v * scale for v in node] if isinstance(node, list) else node * scale
        sets.append(f"{path}={toml_value(value)}")

    walk(scene, "", "")
    return sets


#: scene, the short run, the length to compare by (mm)
SCALE_CASES = {
    "rollup": (ROLLUP, [], ROLLUP_L),
    "sheet": (
        SHEET,
        [f"time.end={SHEET_PERIOD!r}", "time.output_every=1", "time.until=end"],
        SHEET_L,
    ),
    "strip": (STRIP, ["time.end=0.1", "time.output_every=5"], STRIP_L),
}


def scaled_tables(run: Run, to_mm: float) -> dict[str, np.ndarray]:
    """probes.csv and the centroid columns of body.csv, lengths back in mm."""
    header, probes = run.table("probes.csv")
    body_header, body = run.table("body.csv")
    centroid = body[:, [body_header.index(f"centroid_{c}") for c in "xyz"]]
    displacement = [i for i, c in enumerate(header) if c.endswith(("_ux", "_uy", "_uz"))]
    return {
        "time": probes[:, 0],
        "probes": probes[:, displacement] * to_mm,
        "centroid": centroid * to_mm,
    }


@pytest.mark.parametrize("name", list(SCALE_CASES))
def test_scale_invariance(tmp_path, name):
    """The roll-up, the swimming sheet and the bidirectional strip as shipped (mm,
    t, s) and restated in m, kg, s (lengths ×1e-3, E ×1e6, density ×1e12, drag ×1e9,
    magnetization and flux density ×1e3, moments ×1e-3; forces are newtons in both)
    give the same motion: at every output time, in mm, the probe displacements agree
    to 5e-12 of the largest one and the centroids to 5e-12 of the body's length
    (reached: 5.5e-13 on either stack).  A tolerance or a default set in absolute
    units breaks this: `--set solver.snes_atol=1e-9` on the m–kg–s run alone moves
    the sheet's probes by 1.8e-10 (which the old tolerance, 1e-8, let pass) and the
    strip's by 2.2e-7 (the roll-up's by 1.8e-12); 1e-6 moves the sheet's by 4e-6 and
    the strip's by 4e-3."""
    scene, sets, length = SCALE_CASES[name]
    common = [*sets, "output.fields=false"]
    mm = run_case(
        f"scale {name} mm-t-s", "same motion in both unit systems", scene, tmp_path / "mm", common
    )
    si = run_case(
        f"scale {name} m-kg-s",
        "same motion in both unit systems",
        scene,
        tmp_path / "m",
        si_overrides(tomllib.loads(scene.read_text())) + common,
    )
    mm.assert_ok()
    si.assert_ok()
    a, b = scaled_tables(mm, 1.0), scaled_tables(si, 1e3)
    assert np.array_equal(a["time"], b["time"]), "output times differ"
    for key in ("probes", "centroid"):
        scale = np.abs(a[key]).max() if key == "probes" else length
        diff = np.abs(a[key] - b[key]).max() / scale
        print(f"  {key}: largest difference {diff:.2e} of {scale:.4g} mm")
        assert diff < 5e-12, (key, diff)


# --- 7. ill-posed on purpose ----------------------------------------------------------------


def free_rollup(tmp_path) -> Path:
    """The roll-up strip with its clamp taken away: no support, no fluid."""
    text = ROLLUP.read_text(encoding="utf-8")
    clamp = '[[boundary]]\nwhere = "x=0"\nfix = ["clamped"]\n'
    assert text.count(clamp) == 1
    return write_scene(tmp_path, text.replace(clamp, ""), "free.toml")


def assert_clear_failure(run: Run, *words):
    """Exit 3 in seconds, no traceback, stderr one line that names the cause (each
    of ``words``), summary.json "failed" with that reason."""
    assert run.returncode == 3, (run.returncode, run.stderr[-2000:])
    assert "Traceback" not in run.stderr
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1, run.stderr
    assert run.status == "failed" and run.reason and run.reason in lines[0], run.summary
    for word in words:
        assert word in lines[0], (word, lines[0])
    assert run.wall < 60


def test_free_body_constant_load(tmp_path):
    """The roll-up's end moment at full value from t = 0 on a strip that nothing
    holds (no [[boundary]], no [fluid]): no static equilibrium exists.  Exit 3 at
    t = 0 within a minute, one line saying that nothing holds the body."""
    run = run_case(
        "ill-posed free body, constant load",
        "exit 3, names the cause",
        free_rollup(tmp_path),
        tmp_path / "out",
        ['load.0.ramp="constant"', "output.fields=false"],
        timeout=60,
    )
    assert_clear_failure(run, "nothing holds this body")


def test_free_body_ramped_load(tmp_path):
    """The same free strip under the shipped linear ramp of the end moment: the
    stiffness is singular from the first step on, which passes t = 0 (zero load) and
    fails as an unresolved step.  Exit 3 within a minute, one line saying that
    nothing holds the body (it once said only "step not resolved")."""
    run = run_case(
        "ill-posed free body, ramped load",
        "exit 3, names the cause",
        free_rollup(tmp_path),
        tmp_path / "out",
        ["output.fields=false"],
        timeout=60,
    )
    assert_clear_failure(run, "nothing holds this body")


def test_load_too_big_for_one_step(tmp_path):
    """The clamped roll-up's moment ×10 (twenty turns) in a single load step with
    time.max_cuts = 0: Newton cannot take it and may not cut it.  Exit 3 within a
    minute, one line naming the unresolved step and time.max_cuts."""
    run = run_case(
        "ill-posed one step x10 load, no cuts",
        "exit 3, names the cause",
        ROLLUP,
        tmp_path / "out",
        [
            "time.dt=2.0",
            "time.max_cuts=0",
            f"load.0.value=[0.0, {10 * 104.71975511965977!r}, 0.0]",
            "output.fields=false",
        ],
        timeout=60,
    )
    assert_clear_failure(run, "step not resolved", "time.max_cuts")
