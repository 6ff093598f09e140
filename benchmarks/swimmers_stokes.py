"""How wrong is RFT for the paper's three swimmers: RFT against Stokes flow.

Each of the paper's systems (the swimming sheet, the three-link swimmer, the
bidirectional magnetic strip; README.md) is run as shipped in ``demos/`` with
three liquids, everything else unchanged:

* ``rft-paper``: resistive-force theory with the demo's own coefficients
  (``[fluid] drag``), the paper's model;
* ``rft-mu``: resistive-force theory with the slender-body coefficients of a
  viscosity μ (``[fluid] viscosity``, docs/stokes.md §RFT from the viscosity);
* ``stokes``: the Stokes flow of the same μ, the single layer integrated over
  the shell's elements (``[fluid] model = "stokes"``, its default method), on
  three meshes to show its convergence.

μ is water's, 1.0e-9 N·s/mm², for the sheet and the three-link swimmer (their
drag coefficients are the paper's and name no liquid; the swimming speed of a
prescribed stroke hardly depends on μ, only through the body's inertia); for
the strip it is the liquid its scene was made for, 1.26e-8 N·s/mm² (≈ 13 mPa·s):
its C₃ = 1.89e-8 is the slender-body C₃ = 1.5 μ of a 10 × 2 ribbon.

What is measured:

* sheet, cases I–V (demos/swimming_sheet.py's table: amplitude b, wave speed
  V_w, the paper's mesh for RFT): the steady swimming speed, summary.json's
  ``steady.values.front_ux_rate`` (``time.until = "periodic"``), beside the
  exact RFT speed of each set of coefficients. Cases I, II and III are the same
  sheet and wave on the paper's three meshes: the Stokes runs of case I stand
  for all three. Case I's Stokes speed is taken on two families of meshes
  (cells of 2:1 as the demo's 20×4, and square cells), each extrapolated to
  zero cell size from three meshes, on meshes refined along X only or across
  only, at 16 and 64 steps a period (the time step's share) and with a tighter
  steady tolerance (the extrapolated speed's share). The other cases' limits are
  their 20×4 speeds times case I's factor;
* three-link swimmer, case I (nine stroke cycles, as shipped): the reference
  corner's and the middle link's displacement along Y after nine cycles and over
  the ninth alone, the middle link's sinking and turning, the centroid along Y;
* bidirectional strip (+X protocol): the steady speed along the rotation axis at
  the shipped 4 Hz (100 steps a period, as demos/strip_sweep.sh), and a scan of
  frequencies for the step-out, 24 field periods each: the turns the magnetic
  moment loses behind the field after the ramp (stepped out from one turn on:
  above step-out the strip slips in bursts, so a mean slip over a window is no
  criterion; benchmarks/strip_step_out.py has the lags period by period).

Outputs in ``--out`` (default results/swimmers_stokes): ``table.csv`` (one row
per run and quantity), ``table.md`` (the headline tables), and ``runs/NAME/``
(each run's outputs, its scene ``scene.toml`` and log ``run.log``).

    .venv/bin/python benchmarks/swimmers_stokes.py            # everything, one run at a time
    .venv/bin/python benchmarks/swimmers_stokes.py --quick    # the coarse meshes only
    .venv/bin/python benchmarks/swimmers_stokes.py --only 'sheet-I-*'   # some runs
    .venv/bin/python benchmarks/swimmers_stokes.py --reuse    # the tables again, no run
    .venv/bin/python benchmarks/swimmers_stokes.py --list     # the runs, not run

A run whose folder already holds a finished run of the same scene is kept;
``--reuse`` runs nothing and tables what is there. The runs are serial, each on
one thread (OMP_NUM_THREADS=1 unless set). The whole set takes about 100 minutes
on one core of this project's machine; most of it is the Stokes runs on the
finer meshes (a dense Stokes step costs 0.3 s at 369 nodes, 2 s at 793, 7 s at
1377; docs/stokes.md §Cost and scale).
"""

from __future__ import annotations

import argparse
import csv
import fnmatch
import json
import math
import os
import subprocess
import sys
import time
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
# the repository's .venv when this python3 lacks rftfem (scripts/repository_python.py)
sys.path.insert(0, str(ROOT / "scripts"))
import repository_python  # noqa: E402

repository_python.ensure()

import numpy as np  # noqa: E402

from rftfem.model.effects.fluid import slender_body_drag  # noqa: E402
from rftfem.scene.toml_writer import document  # noqa: E402

sys.path.insert(0, str(ROOT / "demos"))
from bidirectional_strip import sweep_row  # noqa: E402
from swimming_sheet import exact_speed  # noqa: E402

sys.path.insert(0, str(ROOT / "benchmarks"))
from strip_step_out import lags  # noqa: E402

DEMOS = ROOT / "demos"

#: the liquids (N·s/mm²): water for the sheet and the three-link swimmer; for the
#: strip the viscosity its drag was made from (C₃ = 1.89e-8 = 1.5 μ, a 10 × 2 ribbon)
WATER = 1.0e-9
STRIP_MU = 1.26e-8

# --- the runs ----------------------------------------------------------------------


@dataclass
class Run:
    name: str  # its folder under runs/
    system: str  # "sheet", "three-link", "strip"
    case: str  # the sheet's case, "I" for the three-link swimmer, "f=4" for the strip
    model: str  # "rft-paper", "rft-mu", "stokes"
    demo: str  # the scene under demos/
    settings: dict  # scene keys (dotted) set on top of the demo
    quick: bool = True  # in the --quick set
    info: dict = field(default_factory=dict)  # what the table needs to know (mesh, dt, ...)

    def scene(self) -> dict:
        """The demo's scene with this run's liquid and settings."""
        scene = tomllib.loads((DEMOS / self.demo).read_text())
        paper = scene["fluid"]["drag"]
        mu = self.info["mu"]
        scene["fluid"] = {
            "rft-paper": {"drag": paper},
            "rft-mu": {"viscosity": mu},
            "stokes": {"model": "stokes", "viscosity": mu},
        }[self.model]
        scene["title"] = f"{scene['title']} [{self.name}]"
        for key, setting in self.settings.items():
            table = scene
            *path, last = key.split(".")
            for part in path:
                table = table[int(part)] if isinstance(table, list) else table.setdefault(part, {})
            table[last] = setting
        return scene


def fluid_label(model: str, mu: float) -> str:
    return {
        "rft-paper": "RFT, the paper's C",
        "rft-mu": f"RFT from μ = {mu:g}",
        "stokes": f"Stokes, μ = {mu:g}",
    }[model]


#: the sheet's cases (demos/swimming_sheet.py): RFT mesh (elements along X), b, V_w
SHEET_CASES = {
    "I": (20, 0.15, 200.0),
    "II": (50, 0.15, 200.0),
    "III": (100, 0.15, 200.0),
    "IV": (50, 0.15, 400.0),
    "V": (50, 0.075, 400.0),
}
SHEET_K = 0.5
#: Stokes meshes of the sheet per physical case (I stands for II and III), and whether
#: each is in the --quick set
SHEET_STOKES = {
    "I": [([5, 1], True), ([10, 2], True), ([20, 4], False)],
    "IV": [([10, 2], True), ([20, 4], False)],
    "V": [([10, 2], True), ([20, 4], False)],
}
SHEET_STEPS = 32  # steps a wave period (the scene's)
SHEET_DT_CHECK = [16, 64]  # case I, Stokes on 10×2: the time step's share
#: case I, Stokes on 10×2, again with a tighter steady tolerance (the scene's is 1e-3): the
#: extrapolated speed's share
SHEET_TIGHT = 1e-4
SHEET_END = 4.0  # s: the latest a sheet run may stop (the Stokes start-up is ~2 s)


def sheet_runs() -> list[Run]:
    runs = []

    def add(case, model, mesh, steps, quick, tolerance=None):
        _, b, vw = SHEET_CASES[case]
        omega = SHEET_K * vw
        period = 2 * math.pi / omega
        suffix = "" if steps == SHEET_STEPS else f"-dt{steps}"
        extra = {}
        if tolerance is not None:
            suffix += f"-tol{tolerance:g}"
            extra["time.steady_tolerance"] = tolerance
        runs.append(
            Run(
                name=f"sheet-{case}-{model}-{mesh[0]}x{mesh[1]}{suffix}",
                system="sheet",
                case=case,
                model=model,
                demo="swimming_sheet.toml",
                quick=quick,
                settings={
                    "mesh.divisions": mesh,
                    "motion.0.amplitude": b,
                    "motion.0.angular_frequency": omega,
                    "time.dt": period / steps,
                    "time.end": math.ceil(SHEET_END / period) * period,
                    "time.until": "periodic",
                    "time.output_every": 1,
                    "output.fields": False,
                    **extra,
                },
                info={
                    "mu": WATER,
                    "mesh": mesh,
                    "steps_per_period": steps,
                    "b": b,
                    "omega": omega,
                    "tolerance": tolerance,
                },
            )
        )

    for case, (nx, _, _) in SHEET_CASES.items():
        quick = case in ("I", "IV", "V")
        add(case, "rft-paper", [nx, 4], SHEET_STEPS, quick)
        add(case, "rft-mu", [nx, 4], SHEET_STEPS, quick)
    for case, meshes in SHEET_STOKES.items():
        for mesh, quick in meshes:
            add(case, "stokes", mesh, SHEET_STEPS, quick)
    for steps in SHEET_DT_CHECK:
        add("I", "stokes", [10, 2], steps, False)
    add("I", "stokes", [10, 2], SHEET_STEPS, False, tolerance=SHEET_TIGHT)
    return runs


#: the three-link swimmer: meshes (along X, across each link) per model
THREE_LINK = [
    ("rft-paper", [10, 2], True),
    ("rft-mu", [10, 2], True),
    ("stokes", [5, 1], True),
    ("stokes", [10, 2], True),
    ("stokes", [15, 3], False),
]
CYCLE = 0.4  # s, the stroke's cycle
CYCLES = 9


def three_link_runs() -> list[Run]:
    return [
        Run(
            name=f"three-link-{model}-{mesh[0]}x{mesh[1]}",
            system="three-link",
            case="I",
            model=model,
            demo="three_link.toml",
            quick=quick,
            settings={"mesh.divisions": mesh, "output.fields": False, "time.output_every": 1},
            info={"mu": WATER, "mesh": mesh, "steps_per_period": round(CYCLE / 0.005)},
        )
        for model, mesh, quick in THREE_LINK
    ]


#: the strip: the shipped frequency on these meshes per model, then the step-out scan
STRIP_SHIPPED = 4.0
STRIP_AT_SHIPPED = [
    ("rft-paper", [20, 4], True),
    ("rft-paper", [10, 2], True),
    ("rft-mu", [20, 4], True),
    ("rft-mu", [10, 2], True),
    ("stokes", [5, 1], True),
    ("stokes", [10, 2], True),
    ("stokes", [20, 4], False),
]
STRIP_SCAN = [80.0, 84.0, 88.0, 96.0, 104.0, 112.0]
STRIP_SCAN_MODELS = [("rft-mu", [10, 2], True), ("stokes", [10, 2], True)]
STRIP_STEPS = 100  # steps a field period, the ramp included (demos/strip_sweep.sh)
STRIP_RAMP = 0.1  # s, phase 1 (the scene's magnetic.field.ramp_time)
STRIP_PERIODS = 24  # the most field periods a run may take (at least 0.2 s)
STRIP_SCAN_PERIODS = 24  # the same for the scan above the shipped frequency


def strip_runs() -> list[Run]:
    runs = []

    def add(model, mesh, frequency, quick, periods):
        runs.append(
            Run(
                name=f"strip-f{frequency:g}-{model}-{mesh[0]}x{mesh[1]}",
                system="strip",
                case=f"f={frequency:g}",
                model=model,
                demo="bidirectional_strip.toml",
                quick=quick,
                settings={
                    "mesh.divisions": mesh,
                    "magnetic.field.frequency": frequency,
                    "time.dt": 1.0 / (frequency * STRIP_STEPS),
                    "time.end": STRIP_RAMP + max(periods / frequency, 0.2),
                    "time.until": "periodic",
                    "time.output_every": 1,
                    "output.fields": False,
                },
                info={
                    "mu": STRIP_MU,
                    "mesh": mesh,
                    "steps_per_period": STRIP_STEPS,
                    "frequency": frequency,
                },
            )
        )

    for model, mesh, quick in STRIP_AT_SHIPPED:
        add(model, mesh, STRIP_SHIPPED, quick, STRIP_PERIODS)
    for frequency in STRIP_SCAN:
        for model, mesh, quick in STRIP_SCAN_MODELS:
            add(model, mesh, frequency, quick, STRIP_SCAN_PERIODS)
    return runs


def all_runs() -> list[Run]:
    return sheet_runs() + three_link_runs() + strip_runs()


# --- running -----------------------------------------------------------------------


def finished(folder: Path, text: str) -> bool:
    """A run in ``folder`` of exactly this scene that ended without a numerical failure."""
    try:
        summary = json.loads((folder / "summary.json").read_text())
        return (folder / "scene.toml").read_text() == text and summary["status"] == "ok"
    except (OSError, ValueError, KeyError):
        return False


def run(r: Run, out: Path, reuse: bool) -> None:
    folder = out / "runs" / r.name
    text = document(r.scene(), header=f"benchmarks/swimmers_stokes.py: {r.name}")
    if finished(folder, text) or reuse:
        return
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "scene.toml").write_text(text)
    cmd = [
        sys.executable,
        "-m",
        "rftfem",
        "run",
        str(folder / "scene.toml"),
        "--out",
        str(folder),
        "--quiet",
    ]
    env = dict(os.environ)
    env.setdefault("OMP_NUM_THREADS", "1")
    env.setdefault("OPENBLAS_NUM_THREADS", "1")
    print(f"{r.name}: running", flush=True)
    start = time.perf_counter()
    with open(folder / "run.log", "w") as log:
        status = subprocess.call(cmd, stdout=log, stderr=subprocess.STDOUT, env=env)
    wall = time.perf_counter() - start
    print(f"{r.name}: exit {status} after {wall:.0f} s", flush=True)


# --- measuring ---------------------------------------------------------------------


def nodes(mesh: list[int], system: str) -> int:
    """The displacement (P2) nodes: the Stokeslets."""
    nx, ny = mesh
    across = 3 * ny if system == "three-link" else ny
    return (2 * nx + 1) * (2 * across + 1)


def columns(path: Path) -> dict[str, np.ndarray]:
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    return {k: np.array([float(row[k]) for row in rows]) for k in rows[0]}


def measure(r: Run, out: Path) -> list[dict]:
    """The table's rows of one run: one per quantity."""
    folder = out / "runs" / r.name
    try:
        summary = json.loads((folder / "summary.json").read_text())
    except (OSError, ValueError):
        return [base_row(r, None) | {"quantity": "-", "status": "not run"}]
    row = base_row(r, summary)
    steady = summary.get("steady") or {}
    quantities = []
    if r.system == "sheet":
        error = (steady.get("estimated_errors") or {}).get("front_ux_rate")
        quantities.append(("U (mm/s)", (steady.get("values") or {}).get("front_ux_rate"), error))
    elif r.system == "three-link":
        quantities += three_link_quantities(folder)
    elif r.system == "strip":
        sweep = sweep_row(folder)  # the steady speed if reached, else the window's mean
        quantities.append(
            (
                "speed along Z (mm/s)",
                sweep["speed"],
                (steady.get("estimated_errors") or {}).get("centroid_z_rate"),
            )
        )
        lag = lags(folder, sweep["frequency"])
        quantities.append(
            ("turns lost", float(round(lag.max() - lag[0])) if len(lag) else None, None)
        )
    return [row | {"quantity": q, "value": v, "estimated_error": e} for q, v, e in quantities]


def base_row(r: Run, summary: dict | None) -> dict:
    row = {
        "system": r.system,
        "case": r.case,
        "model": r.model,
        "fluid": fluid_label(r.model, r.info["mu"]),
        "mesh": f"{r.info['mesh'][0]}x{r.info['mesh'][1]}",
        "nodes": nodes(r.info["mesh"], r.system),
        "steps_per_period": r.info["steps_per_period"],
        "steady_tolerance": r.info.get("tolerance") or "",
        "run": r.name,
    }
    if summary is None:
        return row
    steady = summary.get("steady") or {}
    return row | {
        "status": summary["status"],
        "dofs": summary["dofs"],
        "steps": summary["counts"]["steps"],
        "newton_iterations": summary["counts"]["newton_iterations"],
        "t_end": summary.get("time_reached"),
        "steady": steady.get("reached", ""),
        "periods": steady.get("periods", ""),
        "wall_s": round(summary["wall_s"]["total"], 1),
    }


def three_link_quantities(folder: Path) -> list[tuple]:
    """After nine cycles (and over the ninth): corner and middle-link Y, the middle
    link's Z and angle (from the two hinges at mid-length), the centroid's Y."""
    p, b = columns(folder / "probes.csv"), columns(folder / "body.csv")
    t_end, t_last = CYCLES * CYCLE, (CYCLES - 1) * CYCLE

    def at(data, key, t):
        return float(np.interp(t, data["time"], data[key]))

    def angle(t):  # the middle link's angle about X: hinge_right − hinge_left, from 0.5 apart in Y
        dy = 0.5 + at(p, "hinge_right_uy", t) - at(p, "hinge_left_uy", t)
        dz = at(p, "hinge_right_uz", t) - at(p, "hinge_left_uz", t)
        return math.atan2(dz, dy)

    if p["time"][-1] < t_end - 1e-9:
        return [("corner Y after 9 cycles (mm)", None, None)]
    centroid0 = b["centroid_y"][0]
    return [
        ("corner Y after 9 cycles (mm)", at(p, "corner_uy", t_end), None),
        (
            "corner Y over cycle 9 (mm)",
            at(p, "corner_uy", t_end) - at(p, "corner_uy", t_last),
            None,
        ),
        ("middle link Y after 9 cycles (mm)", at(p, "centre_uy", t_end), None),
        (
            "middle link Y over cycle 9 (mm)",
            at(p, "centre_uy", t_end) - at(p, "centre_uy", t_last),
            None,
        ),
        ("middle link Z after 9 cycles (mm)", at(p, "centre_uz", t_end), None),
        ("middle link angle after 9 cycles (rad)", angle(t_end), None),
        ("centroid Y after 9 cycles (mm)", at(b, "centroid_y", t_end) - centroid0, None),
        (
            "centroid Y over cycle 9 (mm)",
            at(b, "centroid_y", t_end) - at(b, "centroid_y", t_last),
            None,
        ),
    ]


# --- the tables --------------------------------------------------------------------


def write_csv(rows: list[dict], path: Path) -> None:
    keys = []
    for row in rows:
        keys += [k for k in row if k not in keys]
    with open(path, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=keys)
        writer.writeheader()
        writer.writerows(rows)


def pick(rows, **match):
    """The rows whose keys have these values."""
    return [r for r in rows if all(r.get(k) == v for k, v in match.items())]


def value(rows, **match):
    found = [r for r in pick(rows, **match) if r.get("value") is not None]
    return found[0]["value"] if found else None


def fmt(v, digits=5):
    if v is None:
        return "—"
    return f"{v:.{digits}g}"


def pct(a, b):
    """a against b, in percent."""
    if a is None or b is None or b == 0:
        return "—"
    return f"{100 * (a / b - 1):+.1f} %"


def observed_order(n: list[int], u: list[float]) -> tuple[float, float] | None:
    """The order p and the limit of ``u = u∞ + C (1/n)^p`` through three meshes of
    n elements along the sheet (bisection on p in [0.1, 8]); None when the
    differences do not shrink monotonically."""
    d1, d2 = u[1] - u[0], u[2] - u[1]
    if d1 == 0 or d2 / d1 <= 0 or abs(d2) >= abs(d1):
        return None
    h = [1.0 / x for x in n]

    def ratio(p):
        return (h[0] ** p - h[1] ** p) / (h[1] ** p - h[2] ** p) - d1 / d2

    lo, hi = 0.1, 8.0
    if ratio(lo) * ratio(hi) > 0:
        return None
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if ratio(lo) * ratio(mid) > 0 else (lo, mid)
    p = 0.5 * (lo + hi)
    c = d2 / (h[2] ** p - h[1] ** p)
    return p, u[2] - c * h[2] ** p


SHEET_MESHES = ("5x1", "10x2", "20x4")
#: case I's refinement family: cells of 2:1 (the demo's 20×4 and its coarsenings)
SHEET_FAMILIES = (SHEET_MESHES,)


def family_limit(rows, family) -> tuple[float, float] | None:
    u = [sheet_stokes(rows, "I", m) for m in family]
    return None if None in u else observed_order([int(m.split("x")[0]) for m in family], u)


def sheet_stokes(rows, case, mesh):
    return value(
        rows,
        system="sheet",
        case=case,
        model="stokes",
        mesh=mesh,
        steps_per_period=SHEET_STEPS,
        steady_tolerance="",
        quantity="U (mm/s)",
    )


def sheet_limit(rows) -> tuple[float, float] | None:
    """Case I's Stokes speed extrapolated to zero cell size from 5×1, 10×2, 20×4."""
    u = [sheet_stokes(rows, "I", m) for m in SHEET_MESHES]
    return None if None in u else observed_order([5, 10, 20], u)


def sheet_table(rows: list[dict]) -> list[str]:
    mu = WATER
    limit = sheet_limit(rows)
    lines = [
        "### Swimming sheet (mm/s; steady speed of the front corner)",
        "",
        "| case | b | V_w | exact RFT, paper's C | RFT FEM, paper's C | exact RFT, C(μ) "
        "| RFT FEM, C(μ) | Stokes 5×1 | Stokes 10×2 | Stokes 20×4 | Stokes, h → 0 "
        "| RFT paper's C / Stokes h → 0 | RFT C(μ) / Stokes h → 0 |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for case, (nx, b, vw) in SHEET_CASES.items():
        omega = SHEET_K * vw
        paper = exact_speed(b, SHEET_K, omega)
        c1, _, c3 = slender_body_drag(mu, 20.0, 2.0)
        from_mu = exact_speed(b, SHEET_K, omega, c1, c3)
        physical = "I" if case in ("II", "III") else case
        q = dict(system="sheet", quantity="U (mm/s)", steady_tolerance="")
        fem_paper = value(rows, case=case, model="rft-paper", steps_per_period=SHEET_STEPS, **q)
        fem_mu = value(rows, case=case, model="rft-mu", steps_per_period=SHEET_STEPS, **q)
        stokes = {m: sheet_stokes(rows, physical, m) for m in SHEET_MESHES}
        # the limit: case I's own; the other cases' 20×4 speed times case I's factor
        # from 20×4 to the limit (the same sheet on the same mesh: IV is case I at twice
        # the frequency, V at half the amplitude)
        to_limit, mark = None, ""
        if limit is not None and stokes["20x4"] is not None:
            to_limit = stokes["20x4"] * limit[1] / sheet_stokes(rows, "I", "20x4")
            mark = "" if physical == "I" else " ²"
        same = "" if physical == case else " ¹"
        lines.append(
            f"| {case} | {b} | {vw:g} | {paper:.5f} | {fmt(fem_paper)} | {from_mu:.5f} | "
            f"{fmt(fem_mu)} | "
            + " | ".join(f"{fmt(stokes[m])}{same}" for m in SHEET_MESHES)
            + f" | {fmt(to_limit, 3)}{mark} | {pct(fem_paper, to_limit)} | "
            f"{pct(fem_mu, to_limit)} |"
        )
    lines += [
        "",
        "¹ the same sheet and wave as case I: case I's Stokes runs.",
        "² the case's 20×4 speed times case I's factor from 20×4 to h → 0.",
        "",
    ]

    # case I: the mesh, the blob (the mesh's), the time step and the steady watch
    lines += [
        "Case I, Stokes: mesh convergence (shell and liquid together)",
        "",
        "| mesh | cells (mm) | nodes | U | change from the coarser of its family | wall (s) |",
        "|---|---|---|---|---|---|",
    ]
    for family in SHEET_FAMILIES:
        previous = None
        for mesh in family:
            found = pick(
                rows,
                system="sheet",
                case="I",
                model="stokes",
                mesh=mesh,
                steps_per_period=SHEET_STEPS,
                steady_tolerance="",
                quantity="U (mm/s)",
            )
            if not found or found[0].get("value") is None:
                continue
            u = found[0]["value"]
            nx, ny = (int(v) for v in mesh.split("x"))
            change = "—" if previous is None else f"{u - previous:+.5f} ({pct(u, previous)})"
            lines.append(
                f"| {mesh} | {20 / nx:.3g} × {2 / ny:.3g} | {found[0]['nodes']} | "
                f"{u:.5f} | {change} | {found[0].get('wall_s', '—')} |"
            )
            previous = u
        limit_f = family_limit(rows, family)
        if limit_f is not None:
            lines.append(
                f"| h → 0, {' '.join(family)} | observed order {limit_f[0]:.2f} | | "
                f"{limit_f[1]:.4f} | | |"
            )
    across = pick(rows, system="sheet", case="I", model="stokes", mesh="20x8", quantity="U (mm/s)")
    if across and across[0].get("value") is not None:
        u = across[0]["value"]
        lines.append(
            f"| 20x8 | 1 × 0.25 | {across[0]['nodes']} | {u:.5f} | "
            f"{pct(u, sheet_stokes(rows, 'I', '20x4'))} from 20x4 (across only) | "
            f"{across[0].get('wall_s', '—')} |"
        )
    lines.append("")
    q = dict(system="sheet", case="I", model="stokes", mesh="10x2", quantity="U (mm/s)")
    dts = [
        (s, value(rows, steps_per_period=s, steady_tolerance="", **q))
        for s in sorted({SHEET_STEPS, *SHEET_DT_CHECK})
    ]
    dts = [(s, v) for s, v in dts if v is not None]
    if len(dts) > 1:
        lines.append(
            "Case I, Stokes on 10×2, steps a period: "
            + ", ".join(f"{s}: {v:.5f}" for s, v in dts)
            + "."
        )
    tight = value(rows, steps_per_period=SHEET_STEPS, steady_tolerance=SHEET_TIGHT, **q)
    if tight is not None:
        lines.append(f"Case I, Stokes on 10×2, steady tolerance {SHEET_TIGHT:g}: {tight:.5f}.")
    for case in ("IV", "V"):
        u = [sheet_stokes(rows, case, m) for m in ("10x2", "20x4")]
        ref = [sheet_stokes(rows, "I", m) for m in ("10x2", "20x4")]
        if None not in u and None not in ref:
            lines.append(
                f"Case {case}, Stokes, 20×4 against 10×2: {pct(u[1], u[0])} "
                f"(case I: {pct(ref[1], ref[0])})."
            )
    lines.append("")
    return lines


def three_link_table(rows: list[dict]) -> list[str]:
    runs = [
        ("rft-paper", "10x2"),
        ("rft-mu", "10x2"),
        ("stokes", "5x1"),
        ("stokes", "10x2"),
        ("stokes", "15x3"),
    ]
    head = [
        "RFT, paper's C (10×2)",
        f"RFT, C(μ = {WATER:g}) (10×2)",
        "Stokes 5×1",
        "Stokes 10×2",
        "Stokes 15×3",
    ]
    lines = [
        "### Three-link swimmer, case I (nine cycles of the shipped stroke)",
        "",
        "| quantity | " + " | ".join(head) + " |",
        "|---" * (len(head) + 1) + "|",
    ]
    quantities = [r["quantity"] for r in pick(rows, system="three-link", model="rft-paper")]
    for quantity in quantities:
        cells = [
            fmt(value(rows, system="three-link", model=m, mesh=mesh, quantity=quantity))
            for m, mesh in runs
        ]
        lines.append(f"| {quantity} | " + " | ".join(cells) + " |")
    return lines + [""]


def strip_table(rows: list[dict]) -> list[str]:
    lines = [
        f"### Bidirectional strip, +X protocol (μ = {STRIP_MU:g})",
        "",
        "| frequency (Hz) | model | mesh | speed along Z (mm/s) | steady (periods) "
        "| turns lost | stepped out | wall (s) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for frequency in [STRIP_SHIPPED, *STRIP_SCAN]:
        for r in pick(
            rows, system="strip", case=f"f={frequency:g}", quantity="speed along Z (mm/s)"
        ):
            slip = value(rows, run=r["run"], quantity="turns lost")
            out = "—" if slip is None else ("yes" if slip >= 1 else "no")
            steady = f"{r['steady']} ({r['periods']})" if r.get("steady") != "" else "—"
            lines.append(
                f"| {frequency:g} | {r['fluid']} | {r['mesh']} | {fmt(r.get('value'))} "
                f"| {steady} | {'—' if slip is None else f'{slip:.0f}'} | {out} "
                f"| {r.get('wall_s', '—')} |"
            )
    # the Stokes speed at the shipped frequency, extrapolated to zero cell size
    meshes = [m for model, m, _ in STRIP_AT_SHIPPED if model == "stokes"]
    u = [
        value(
            rows,
            system="strip",
            case=f"f={STRIP_SHIPPED:g}",
            model="stokes",
            mesh=f"{m[0]}x{m[1]}",
            quantity="speed along Z (mm/s)",
        )
        for m in meshes
    ]
    if len(u) == 3 and None not in u:
        limit = observed_order([m[0] for m in meshes], u)
        if limit is not None:
            lines += [
                "",
                f"Stokes at {STRIP_SHIPPED:g} Hz, h → 0: {limit[1]:.3f} mm/s "
                f"(observed order {limit[0]:.2f}).",
            ]
    return lines + [""]


def runs_table(rows: list[dict]) -> list[str]:
    lines = [
        "### The runs",
        "",
        "| run | nodes | dofs | steps | Newton | steady (periods) | status | wall (s) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    seen = set()
    for r in rows:
        if r["run"] in seen:
            continue
        seen.add(r["run"])
        steady = f"{r.get('steady', '')} ({r.get('periods', '')})" if r.get("steady") != "" else "—"
        lines.append(
            f"| {r['run']} | {r['nodes']} | {r.get('dofs', '—')} | "
            f"{r.get('steps', '—')} | {r.get('newton_iterations', '—')} | {steady} | "
            f"{r.get('status', 'not run')} | {r.get('wall_s', '—')} |"
        )
    return lines + [""]


# --- main --------------------------------------------------------------------------


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=ROOT / "results" / "swimmers_stokes")
    parser.add_argument("--quick", action="store_true", help="the coarse meshes only")
    parser.add_argument(
        "--only",
        action="append",
        default=[],
        metavar="PATTERN",
        help="the runs whose name matches (shell pattern); repeatable",
    )
    parser.add_argument(
        "--reuse",
        action="store_true",
        help="run nothing: the tables from the runs already in --out",
    )
    parser.add_argument("--list", action="store_true", help="list the runs and stop")
    args = parser.parse_args(argv)

    runs = [r for r in all_runs() if r.quick or not args.quick]
    if args.only:
        runs = [r for r in runs if any(fnmatch.fnmatch(r.name, p) for p in args.only)]
    if args.list:
        for r in runs:
            print(r.name)
        return 0
    args.out.mkdir(parents=True, exist_ok=True)
    for r in runs:
        run(r, args.out, args.reuse)

    # the tables cover every run of the full set that is there
    rows = [row for r in all_runs() for row in measure(r, args.out)]
    write_csv(rows, args.out / "table.csv")
    text = "\n".join(
        sheet_table(rows) + three_link_table(rows) + strip_table(rows) + runs_table(rows)
    )
    (args.out / "table.md").write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
