"""Designing the magnetic sheet robot's profile and field with ``rftfem optimize``.

    python3 demos/magnetic_design.py [--out results/magnetic_design] [--method cobyla]
                                     [--budget 40] [--grid-wavelength 13]
                                     [--grid-frequency 5] [--grid-phase 5]
                                     [--no-film] [--reuse]

The scene ``demos/magnetic_design.toml`` is the sheet robot of
``demos/sheet_robot.toml`` with its magnetization profile
``q₀ = (cos(2πX/λ + φ), 0, sin(2πX/λ + φ))`` and the frequency f of its
swinging field written as ``[parameters]`` (wavelength, phase, frequency).  Its
field rests along Z between two bursts of the swing (one period, then two), so
that the difference of the two bursts' advances, read at rest, is one period's
advance; times f it is the speed along X (mm/s).  This script asks which
profile and frequency swim fastest:

1. ``rftfem optimize`` (``--method``, rftfem's default cobyla) over λ in
   3.6–5.6 mm, φ in ±π and f in 2–8 Hz (log scale), from the scene as shipped
   (λ = L = 3.7 mm, φ = 0, 4 Hz: the baseline, the first evaluation), with the
   constraint that the sheet rests in the same shape before, between and after
   the bursts (its magnetic moment within 0.01 A·mm²; docs/magnetic_design.md:
   below λ ≈ 3.55 mm the sheet has other shapes a swing may throw it into);
2. brute-force grids (``rftfem optimize --method grid``) along each parameter
   in turn over its whole interval, the other two at the optimum's values;
3. the optimum again at dt halved (is the gain the model's or the time
   step's?), with fields, and its film ``OUT/optimum.mp4`` (``rftfem render``).

Besides the objective, each run's sideways (Z) speed, so the swim's direction
in the XZ plane, and the magnetic moment of the sheet at rest (the shape it
rests in: the curled C or the flatter one) are read off its folder.  Each
evaluation is an ordinary run folder under ``OUT/optimize``,
``OUT/grid-<parameter>`` or ``OUT/optimum-dt2``.  Prints the table (baseline,
optimum, gain, the grids' bests, the dt-halved run, runs and wall times) and
the grids, and writes them to ``OUT/magnetic.md``.  Exit status 1 if the
optimum is slower than the baseline.  With ``--reuse`` finished runs are read,
not repeated.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import subprocess
import sys
import time
import tomllib
from pathlib import Path

# the repository's .venv when this python3 lacks rftfem (scripts/repository_python.py)
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))
import repository_python  # noqa: E402

repository_python.ensure()

HERE = Path(__file__).resolve().parent
SCENE = HERE / "magnetic_design.toml"
#: the design: each parameter (parameters.NAME) and its interval LO:HI[:log]
DESIGN = {
    "wavelength": "3.6:5.6",  # mm
    "phase": f"{-math.pi:.6f}:{math.pi:.6f}",  # rad
    "frequency": "2:8:log",  # Hz
}
#: one period's advance along X (the second burst's less the first's, read at rest), times f
OBJECTIVE = "(centroid_x@end - 2*centroid_x@1.25 + centroid_x@0.5)*scene(parameters.frequency)"
SIDEWAYS = OBJECTIVE.replace("centroid_x", "centroid_z")
#: the sheet's magnetic moment at rest before the bursts (A·mm²): its shape
REST_MOMENT = "moment_z@0.5"
#: the sheet rests in the same shape before, between and after the bursts (A·mm²)
SAME_SHAPE = "abs(moment_z@1.25 - moment_z@0.5) + abs(moment_z@end - moment_z@0.5) <= 0.01"
DT = 0.001953125  # the scene's time.dt


def key(name: str) -> str:
    return f"parameters.{name}"


def rftfem(*args: str) -> None:
    subprocess.run([sys.executable, "-m", "rftfem", *args], check=True)


def optimize(
    out: Path, names: list[str], method: str, budget: int, sets: dict, reuse: bool
) -> tuple[dict, list[dict], float, int]:
    """Run ``rftfem optimize`` over ``names`` with ``sets`` fixed; its best row, its
    finished rows (ok or infeasible, each with ``folder`` made a path), its wall time
    and its number of runs."""
    cmd = ["optimize", str(SCENE)]
    for n in names:
        cmd += ["--vary", f"{key(n)}={DESIGN[n]}"]
    for n, v in sets.items():
        cmd += ["--set", f"{key(n)}={v!r}"]
    cmd += [
        "--objective",
        OBJECTIVE,
        "--constraint",
        SAME_SHAPE,
        "--maximize",
        "--method",
        method,
        "--budget",
        str(budget),
        "--out",
        str(out),
        *(["--reuse"] if reuse else []),
    ]
    t0 = time.perf_counter()
    rftfem(*cmd)
    wall = time.perf_counter() - t0
    with open(out / "optimize.csv", newline="") as f:
        every = list(csv.DictReader(f))
    rows = [r for r in every if r["status"] in ("ok", "infeasible")]
    ok = [r for r in rows if r["status"] == "ok"]
    if not ok:
        sys.exit(f"magnetic_design.py: no run of {out} succeeded (optimize.csv)")
    for r in rows:
        r["folder"] = out / r["folder"]
        for n in DESIGN:
            r[n] = float(r.get(key(n)) or sets[n])
    return max(ok, key=lambda r: float(r["objective"])), rows, wall, len(every)


def measure(row: dict) -> dict:
    """The run's speed along X, along Z, its size and direction, and its rest moment."""
    import rftfem

    result = rftfem.Result(row["folder"])  # its formulas are rftfem optimize's
    ux, uz, q = (result.quantity(f) for f in (OBJECTIVE, SIDEWAYS, REST_MOMENT))
    return {
        **row,
        "U": ux,
        "Uz": uz,
        "size": math.hypot(ux, uz),
        "direction": math.degrees(math.atan2(uz, ux)),
        "Q": q,
    }


def run_finished(folder: Path) -> bool:
    try:
        return json.loads((folder / "summary.json").read_text())["status"] == "ok"
    except (OSError, ValueError, KeyError):
        return False


def describe(r: dict) -> str:
    shape = "" if r.get("status", "ok") == "ok" else " (changed: infeasible)"
    return (
        f"| {r['wavelength']:.4f} | {r['phase']:+.4f} | {r['frequency']:.3f} | "
        f"{r['U']:.5f} | {r['size']:.5f} | {r['direction']:+.1f}° | {r['Q']:.2f}{shape} |"
    )


HEAD = (
    "| λ (mm) | φ (rad) | f (Hz) | U along X (mm/s) | \\|U\\| (mm/s) | direction "
    "(from X to Z) | moment at rest (A·mm²) |"
)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--out",
        type=Path,
        default=Path("results/magnetic_design"),
        help="the results folder (default results/magnetic_design)",
    )
    parser.add_argument(
        "--method",
        default="cobyla",
        help="rftfem optimize --method (default cobyla, rftfem's default)",
    )
    parser.add_argument("--budget", type=int, default=40, help="the search's runs at most")
    parser.add_argument(
        "--grid-wavelength",
        type=int,
        default=13,
        metavar="N",
        help="grid points along λ (0: no grid)",
    )
    parser.add_argument(
        "--grid-frequency",
        type=int,
        default=5,
        metavar="N",
        help="grid points along f (0: no grid)",
    )
    parser.add_argument(
        "--grid-phase", type=int, default=5, metavar="N", help="grid points along φ (0: no grid)"
    )
    parser.add_argument(
        "--no-film", action="store_true", help="skip the fields and the film of the optimum"
    )
    parser.add_argument("--reuse", action="store_true", help="read finished runs")
    args = parser.parse_args(argv)
    t_start = time.perf_counter()
    shipped = {
        n: float(v)
        for n, v in tomllib.loads(SCENE.read_text(encoding="utf-8"))["parameters"].items()
        if n in DESIGN
    }

    # 1. the search, from the scene as shipped
    best, rows, search_wall, search_runs = optimize(
        args.out / "optimize", list(DESIGN), args.method, args.budget, {}, args.reuse
    )
    best = measure(best)
    base = [r for r in rows if all(abs(r[n] - shipped[n]) < 1e-9 for n in DESIGN)]
    base_wall = 0.0
    if base:
        base = measure(base[0])
    else:  # a method that does not start from the scene's values
        folder = args.out / "baseline"
        t0 = time.perf_counter()
        if not (args.reuse and run_finished(folder)):
            rftfem("run", str(SCENE), "--out", str(folder), "--quiet")
        base_wall = time.perf_counter() - t0
        base = measure({"folder": folder, **shipped})
    optimum = {n: best[n] for n in DESIGN}

    # 2. brute force along each parameter, the others at the optimum
    grids = {}
    for name, points in (
        ("wavelength", args.grid_wavelength),
        ("frequency", args.grid_frequency),
        ("phase", args.grid_phase),
    ):
        if points < 2:
            continue
        sets = {n: v for n, v in optimum.items() if n != name}
        g_best, g_rows, g_wall, _ = optimize(
            args.out / f"grid-{name}", [name], "grid", points, sets, args.reuse
        )
        grids[name] = (
            measure(g_best),
            sorted((measure(r) for r in g_rows), key=lambda r: r[name]),
            g_wall,
        )

    # 3. the optimum at dt halved, with fields for the film
    fine_dir = args.out / "optimum-dt2"
    t0 = time.perf_counter()
    if not (
        args.reuse
        and run_finished(fine_dir)
        and (args.no_film or (fine_dir / "fields.xdmf").exists())
    ):
        rftfem(
            "run",
            str(SCENE),
            "--out",
            str(fine_dir),
            "--quiet",
            *[f"--set={key(n)}={v!r}" for n, v in optimum.items()],
            f"--set=time.dt={DT / 2!r}",
            "--set=time.output_every=8",
            f"--set=output.fields={'false' if args.no_film else 'true'}",
        )
    fine_wall = time.perf_counter() - t0
    fine = measure({"folder": fine_dir, **optimum})

    # the table
    gain = best["U"] / base["U"]
    lines = [
        "Sheet robot (demos/magnetic_design.toml): λ in "
        f"{DESIGN['wavelength'].replace(':', '–')} mm, φ in ±π rad, f in "
        f"{DESIGN['frequency'].split(':log')[0].replace(':', '–')} Hz (log scale); "
        f"U = {OBJECTIVE} (mm/s), read at rest: one period's advance along X, times f; "
        f"constraint {SAME_SHAPE} (A·mm²: the same shape at rest throughout).",
        "",
        "| design | " + HEAD[2:] + " search | runs | wall (s) |",
        "| --- " * 11 + "|",
        f"| baseline (as shipped) {describe(base)} first evaluation | 1 | "
        f"{float(base.get('wall_s') or base_wall):.0f} |",
        f"| optimum {describe(best)} {args.method} | {search_runs} | {search_wall:.0f} |",
    ]
    for name, (g_best, g_rows, g_wall) in grids.items():
        lines.append(
            f"| grid along {name}: best {describe(g_best)} grid of {len(g_rows)} | "
            f"{len(g_rows)} | {g_wall:.0f} |"
        )
    lines += [
        f"| optimum at dt halved {describe(fine)} {DT / 2:.6g} s | 1 | {fine_wall:.0f} |",
        "",
        f"Gain of the optimum over the baseline: {gain:.3f} × ({100 * (gain - 1):+.1f} %); "
        f"at dt halved the optimum swims {100 * (fine['U'] / best['U'] - 1):+.2f} % "
        "differently.  Best run: " + str(best["folder"]) + ".",
    ]
    for name, (g_best, g_rows, g_wall) in grids.items():
        fixed = ", ".join(f"{n} = {v:.4g}" for n, v in optimum.items() if n != name)
        lines += [
            "",
            f"Grid along {name} ({fixed}):",
            "",
            HEAD,
            "| --- " * 7 + "|",
            *(describe(r) for r in g_rows),
        ]
    lines += [
        "",
        f"Total wall time {time.perf_counter() - t_start:.0f} s"
        + (" (--reuse: finished runs were read)." if args.reuse else "."),
    ]
    text = "\n".join(lines)
    print(text)
    (args.out / "magnetic.md").write_text(text + "\n", encoding="utf-8")
    if not args.no_film:
        film = args.out / "optimum.mp4"
        rftfem("render", str(fine_dir), "--out", str(film), "--view", "xz")
        print(
            f"film of the optimum: {film}; the search's history: "
            f"{args.out / 'optimize' / 'optimize.png'}"
        )
    if best["U"] < base["U"]:
        print("the optimum is slower than the baseline", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
