"""The swimming sheet of the paper's section 4.1, cases I–V, against exact RFT.

A sheet whose transverse displacement is a travelling wave swims because the
drag across it (C₃) is larger than along it (C₁).  This script runs the paper's
five cases with ``rftfem run`` on ``demos/swimming_sheet.toml`` and compares
their swimming speed with the exact RFT speed.

Each run stops once its speed is steady (``time.until = "periodic"``, the
scene's setting: the period means are watched and their limit extrapolated,
docs/model.md §6.13), and its speed is summary.json's steady value of the front
corner — a few periods instead of the 34 that the start-up transient (time
constant τ = ρ t / C₁ ≈ 0.33 s) would take to die out.  With ``--run-out`` the
runs go the old way instead, to past 2 s and 10 τ, and the speed is measured
two ways on the front corner's X displacement:

* the paper's window, t = 1.5 to 2.0 s; it still carries the start-up
  transient, which alone biases it by about −0.66 %;
* the transient-free window: ``--periods`` whole wave periods after 10 τ.

Outputs in ``--out`` (default ``results/swimming_sheet``): ``table.csv``,
``table.md`` and ``front_corner.png`` (X displacement of the front corner
against time, with the exact-RFT slope), and one run folder per case.

    python3 demos/swimming_sheet.py                 # all cases, one run at a time
    python3 demos/swimming_sheet.py --jobs 2        # two runs at once
    python3 demos/swimming_sheet.py --cases I,II --steps-per-period 32
    python3 demos/swimming_sheet.py --run-out       # the transient run out, both windows
    python3 demos/swimming_sheet.py --reuse         # table and plot again, no rerun

Exit status 1 when a speed is off its exact value by more than 0.5 % on any
mesh (docs/verification.md case F asks for it on 4×50 or coarser; finer meshes
must do no worse), or a ratio IV/II or V/IV by more than 0.5 %, or a run did
not become steady before its time.end.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

# the repository's .venv when this python3 lacks rftfem (scripts/repository_python.py)
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))
import repository_python  # noqa: E402

repository_python.ensure()

import numpy as np

HERE = Path(__file__).resolve().parent
SCENE = HERE / "swimming_sheet.toml"

# --- the physics: sheet data and the exact RFT speed ------------------------------

THICKNESS, DENSITY = 0.1, 1.0e-8  # mm, t/mm³
C1, C3 = 3.0e-9, 5.67e-9  # N·s/mm³ (C₂ = C₁)
K = 0.5  # wavenumber, 1/mm
TAU = DENSITY * THICKNESS / C1  # start-up time constant, s

#: case -> (elements along X, amplitude b, wave speed V_w, the paper's FEM speed)
CASES = {
    "I": (20, 0.15, 200.0, 0.4780),
    "II": (50, 0.15, 200.0, 0.4951),
    "III": (100, 0.15, 200.0, 0.4975),
    "IV": (50, 0.15, 400.0, 0.9885),
    "V": (50, 0.075, 400.0, 0.2479),
}


def exact_speed(b: float, k: float, omega: float, c1: float = C1, c3: float = C3) -> float:
    """Exact RFT speed of a sheet with transverse wave ``b sin(kX + ωt)``
    (docs/verification.md case F):

        U = (C₃ − C₁) k ω b² ⟨cos²φ / √(1+s²)⟩ / ⟨(C₁ + C₃ s²) / √(1+s²)⟩,  s = k b cos φ

    The phase averages are periodic integrals: the trapezoidal rule on 4096
    points is exact to round-off.
    """
    phi = np.linspace(0.0, 2 * np.pi, 4096, endpoint=False)
    s = k * b * np.cos(phi)
    root = np.sqrt(1 + s**2)
    return (
        (c3 - c1)
        * k
        * omega
        * b**2
        * np.mean(np.cos(phi) ** 2 / root)
        / np.mean((c1 + c3 * s**2) / root)
    )


# --- running one case --------------------------------------------------------------


def case_settings(case: str, steps_per_period: int, periods: int, run_out: bool) -> dict:
    """The wave and time steps of a case; ``end`` is where a run-out run stops and
    the latest a steady run may."""
    nx, b, vw, _ = CASES[case]
    omega = K * vw
    period = 2 * np.pi / omega
    start = math.ceil(10 * TAU / period)  # first whole period after 10 τ
    end_periods = max(start + periods, math.ceil(2.0 / period))
    return {
        "nx": nx,
        "b": b,
        "omega": omega,
        "period": period,
        "dt": period / steps_per_period,
        "t0": start * period,
        "t1": (start + periods) * period,
        "end": end_periods * period,
        "until": "end" if run_out else "periodic",
    }


def finished(folder: Path, settings: dict) -> bool:
    """A run folder from an earlier call with the same mesh, wave and time steps."""
    try:
        summary = json.loads((folder / "summary.json").read_text())
    except (OSError, ValueError):
        return False
    scene = summary["scene"]
    return (
        summary["status"] == "ok"
        and scene["mesh"]["divisions"][0] == settings["nx"]
        and scene["motion"][0]["amplitude"] == settings["b"]
        and scene["motion"][0]["angular_frequency"] == settings["omega"]
        and scene["time"]["dt"] == settings["dt"]
        and scene["time"]["end"] == settings["end"]
        and scene["time"].get("until", "end") == settings["until"]
    )


def run_case(case: str, settings: dict, out: Path, launcher: list[str], reuse: bool) -> Path:
    folder = out / f"case_{case}"
    if reuse and finished(folder, settings):
        print(f"case {case}: reusing {folder}", flush=True)
        return folder
    cmd = [
        *launcher,
        sys.executable,
        "-m",
        "rftfem",
        "run",
        str(SCENE),
        "--out",
        str(folder),
        "--quiet",
        "--set",
        f'title="Swimming sheet, case {case}"',
        "--set",
        f"mesh.divisions=[{settings['nx']},4]",
        "--set",
        f"motion.0.amplitude={settings['b']!r}",
        "--set",
        f"motion.0.angular_frequency={settings['omega']!r}",
        "--set",
        f"time.dt={settings['dt']!r}",
        "--set",
        f"time.end={settings['end']!r}",
        "--set",
        f"time.until={settings['until']}",
        "--set",
        "time.output_every=1",
    ]
    print(f"case {case}: {' '.join(cmd[len(launcher) :])}", flush=True)
    log = out / f"case_{case}.log"
    with open(log, "w") as stream:
        status = subprocess.call(cmd, stdout=stream, stderr=subprocess.STDOUT)
    if status != 0:
        raise SystemExit(f"case {case} failed (exit {status}); see {log}")
    return folder


def front_corner(folder: Path) -> tuple[np.ndarray, np.ndarray]:
    data = np.loadtxt(folder / "probes.csv", delimiter=",", skiprows=1, ndmin=2)
    return data[:, 0], data[:, 1]  # time, front_ux


def speed(t: np.ndarray, x: np.ndarray, t0: float, t1: float) -> float:
    """Mean X velocity between t0 and t1 (rows interpolated linearly in time)."""
    return (np.interp(t1, t, x) - np.interp(t0, t, x)) / (t1 - t0)


# --- the table ---------------------------------------------------------------------


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cases", default=",".join(CASES), help="comma-separated, e.g. I,II")
    parser.add_argument("--steps-per-period", type=int, default=48)
    parser.add_argument(
        "--periods",
        type=int,
        default=8,
        help="with --run-out: periods in the transient-free window",
    )
    parser.add_argument(
        "--run-out",
        action="store_true",
        help="run each case to past 2 s and 10 τ and measure its speed in "
        "windows, instead of stopping once it is steady",
    )
    parser.add_argument("--jobs", type=int, default=1, help="runs at once")
    parser.add_argument("--np", type=int, default=1, help="MPI processes per run")
    parser.add_argument("--out", type=Path, default=Path("results/swimming_sheet"))
    parser.add_argument(
        "--reuse",
        action="store_true",
        help="keep runs already finished in --out with the same settings",
    )
    args = parser.parse_args(argv)
    cases = [c.strip() for c in args.cases.split(",") if c.strip()]
    unknown = [c for c in cases if c not in CASES]
    if unknown:
        parser.error(f"--cases: unknown case {unknown[0]!r}; expected some of {', '.join(CASES)}")
    args.out.mkdir(parents=True, exist_ok=True)
    launcher = ["mpirun", "-n", str(args.np)] if args.np > 1 else []

    settings = {
        c: case_settings(c, args.steps_per_period, args.periods, args.run_out) for c in cases
    }
    with ThreadPoolExecutor(max_workers=max(1, args.jobs)) as pool:
        folders = dict(
            zip(
                cases,
                pool.map(lambda c: run_case(c, settings[c], args.out, launcher, args.reuse), cases),
            )
        )

    rows, curves = [], {}
    for c in cases:
        s, folder = settings[c], folders[c]
        summary = json.loads((folder / "summary.json").read_text())
        t, x = front_corner(folder)
        exact = exact_speed(s["b"], K, s["omega"])
        row = {"case": c, "mesh": f"4x{s['nx']}", "dofs": summary["dofs"], "dt": s["dt"]}
        if args.run_out:
            paper_window, periods = speed(t, x, 1.5, 2.0), speed(t, x, s["t0"], s["t1"])
            row.update(
                {
                    "U_paper_window": paper_window,
                    "err_paper_window_pct": 100 * (paper_window / exact - 1),
                    "U": periods,
                    "how": f"periods [{s['t0']:.3f}, {s['t1']:.3f}] s",
                }
            )
            curves[c] = (t, x, exact, s["t0"])
        else:
            steady = summary["steady"]
            row.update(
                {
                    "U": steady["values"]["front_ux_rate"],
                    "how": f"steady after {steady['periods']} periods"
                    + ("" if steady["reached"] else " (NOT reached)"),
                    "estimated_error": steady["estimated_errors"]["front_ux_rate"],
                    "reached": steady["reached"],
                }
            )
            curves[c] = (t, x, exact, t[-1])
        row.update(
            {
                "err_pct": 100 * (row["U"] / exact - 1),
                "U_exact": exact,
                "U_paper_fem": CASES[c][3],
                "newton_its": summary["counts"]["newton_iterations"],
                "wall_s": summary["wall_s"]["total"],
            }
        )
        rows.append(row)

    write_tables(rows, args.out)
    ok = check(rows)
    plot(curves, args.out / "front_corner.png")
    # a picture and a film of the first case: the wave, seen from a camera that
    # follows the sheet, with the centroid's path
    draw_picture_and_film(folders[cases[0]], "sheet", view="follow")
    return 0 if ok else 1


def draw_picture_and_film(folder: Path, stem: str, **options) -> None:
    """``STEM.png`` (the last frame) and ``STEM.mp4`` (the whole run) in ``folder``, by
    ``rftfem.Result.render`` (``options``: render's, e.g. ``view="follow"``). A failure
    is reported, not raised: the numbers of a demo matter more than its pictures."""
    import rftfem

    for suffix in (".png", ".mp4"):
        out = folder / f"{stem}{suffix}"
        try:
            rftfem.Result(folder).render(out, **options)
            print(f"drew {out}")
        except Exception as exc:  # noqa: BLE001 (whatever stopped the drawing, say it)
            print(f"could not draw {out}: {exc}")


def write_tables(rows: list[dict], out: Path):
    with open(out / "table.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    run_out = "U_paper_window" in rows[0]
    head = "| case | mesh | dofs | dt (s) | "
    head += (
        "U, paper window | error | U, periods after 10τ | "
        if run_out
        else "U, steady | estimated error | periods | "
    )
    lines = [
        head + "error | exact RFT | paper FEM | wall (s) |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        middle = (
            f"{r['U_paper_window']:.5f} | {r['err_paper_window_pct']:+.2f} % | {r['U']:.5f} | "
            if run_out
            else f"{r['U']:.5f} | {r['estimated_error']:.1e} | {r['how'].split()[2]} | "
        )
        lines.append(
            f"| {r['case']} | {r['mesh']} | {r['dofs']} | {r['dt']:.3e} | {middle}"
            f"{r['err_pct']:+.2f} % | {r['U_exact']:.5f} | "
            f"{r['U_paper_fem']:.4f} | {r['wall_s']:.0f} |"
        )
    by_case = {r["case"]: r for r in rows}
    for a, b in (("IV", "II"), ("V", "IV")):
        if a in by_case and b in by_case:
            ours = by_case[a]["U"] / by_case[b]["U"]
            exact = by_case[a]["U_exact"] / by_case[b]["U_exact"]
            lines.append(
                f"\nRatio {a}/{b}: {ours:.5f} (exact {exact:.5f}, "
                f"{100 * (ours / exact - 1):+.2f} %)"
            )
    text = "\n".join(lines) + "\n"
    (out / "table.md").write_text(text)
    print(text)


def check(rows: list[dict], tol_pct: float = 0.5) -> bool:
    """docs/verification.md case F: ≤ 0.5 % on every mesh (4×50 or coarser, and finer ones must do
    no worse), ratios IV/II and V/IV within 0.5 %; a steady run must have become steady."""
    ok = True
    by_case = {r["case"]: r for r in rows}
    for r in rows:
        if abs(r["err_pct"]) > tol_pct:
            print(f"FAIL: case {r['case']} is {r['err_pct']:+.2f} % off the exact speed")
            ok = False
        if r.get("reached") is False:
            print(f"FAIL: case {r['case']} was not steady by its time.end")
            ok = False
    for a, b in (("IV", "II"), ("V", "IV")):
        if a in by_case and b in by_case:
            ours = by_case[a]["U"] / by_case[b]["U"]
            exact = by_case[a]["U_exact"] / by_case[b]["U_exact"]
            if abs(ours / exact - 1) > tol_pct / 100:
                print(f"FAIL: ratio {a}/{b} = {ours:.5f}, exact {exact:.5f}")
                ok = False
    print("all within 0.5 % of exact RFT" if ok else "some results are off (see above)")
    return ok


def plot(curves: dict, path: Path):
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print(f"matplotlib is not installed: no plot ({path.name})")
        return
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for case, (t, x, exact, t0) in curves.items():
        (line,) = ax.plot(t, x, lw=0.8, label=f"case {case}")
        x0 = np.interp(t0, t, x)  # the slope through the window's start or the last row
        ax.plot(t, x0 + exact * (t - t0), "--", color=line.get_color(), lw=0.8)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("front corner X displacement (mm)")
    ax.set_title("Swimming sheet: FEM (solid) and exact RFT slope (dashed)")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    print(f"plot: {path}")


if __name__ == "__main__":
    sys.exit(main())
