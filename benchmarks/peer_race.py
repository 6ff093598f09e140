"""The peer race (issue 34): rftfem against PyElastica, each at its cheapest setting for a given
accuracy.

The race: a slender magnetic swimmer in resistive-force drag, ten periods of a
field that drives it at one end (the "filament driven at one end" of the issue,
planar, so that a Cosserat rod and a shell describe the same body).  The body and
the physics, identical in both codes (units mm, s, N):

- strip L = 10, width w = 2, thickness t = 0.1; E = 5 MPa, nu = 0 (plate and beam
  bending stiffness agree: EI = E w t^3 / 12), density 1600 kg/m^3 (1.6e-9 t/mm^3);
- drag [C1, C2, C3] = [1e-8, 1e-8, 1.89e-8] N s/mm^3 along the axis, across it in
  the surface and along the normal (rftfem: per unit area; PyElastica: times w
  per unit length, in the rod's director frame, lumped at the nodes);
- the first millimetre magnetized along the axis, 62.9 A/mm (moment 12.58 A mm^2);
  uniform field B = 1e-5 (1, 0, sin 2 pi f t) N/(A mm) (10 mT along x, an
  oscillating 10 mT along z), f = 4 Hz: the head pitches by +-45 degrees, the tail
  undulates in the x-z plane and the strip swims along -x;
- from rest, straight, t = 0 to 10 periods (2.5 s); the swim speed is the
  centroid's mean x velocity over periods 5-10 (same window for both codes).

rftfem: shell of nx x 1 elements (demos/bidirectional_strip.toml's strip with
nu = 0 and the field above), generalized-alpha rho_inf = 0.9, fixed nominal dt =
T / steps (rftfem halves a step that turns a director by more than 0.2 rad).
PyElastica 1.0.0: Cosserat rod of n elements with the rectangle's section
constants, position Verlet at 0.75 of the explicit stability limit (the shear-
rotation oscillation of one element, which the thin section's small rotary
inertia sets); benchmarks/peer_race_elastica/run.py, run by .venv-elastica's python.

Each code's error is against its own converged value (its finest run).  For 1 %
and 0.1 % the cheapest setting within it (by measured wall time) is reported with
the ratio of wall times PyElastica / rftfem.  Times are each process's wall time
from start to exit, caches warm (one warm-up run first); the cold start (an
empty form cache for rftfem, an empty numba cache for PyElastica) is timed once.

The small problems: a cantilever 10 x 1 x 0.1, E = 1.2e6, nu = 0 (EI = 100):
the static elastica under a dead tip load P L^2 / EI = 2 (tip w / L against the
exact 0.49346, Mattiasson 1981; PyElastica relaxes to rest with a damper) and the
first bending frequency (rho = 1e-9) against Euler-Bernoulli
1.87510407^2 sqrt(EI / (rho A)) / L^2 / (2 pi), at 0.5 % and 0.1 %.  Against the
exact values, not each code's own converged one.

    python3 benchmarks/peer_race.py            (the race, about 20 minutes here)
    python3 benchmarks/peer_race.py --quick    (two periods, short ladders: about 2 minutes)
    ./dev.sh race                              (creates .venv-elastica if missing)
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

# the repository's .venv when this python3 lacks rftfem (scripts/repository_python.py)
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))
import repository_python  # noqa: E402

repository_python.ensure()

ROOT = Path(__file__).resolve().parents[1]
HERE = Path(__file__).resolve().parent

FREQ = 4.0
PERIOD = 1.0 / FREQ

SWIM_SCENE = """title = "peer race: magnetic strip driven at one end"
[mesh]
kind = "strip"
length = 10.0
width = 2.0
divisions = [{nx}, 1]
[[mesh.regions]]
name = "head"
x = [0.0, 1.0]
[shell]
thickness = 0.1
E = 5.0
nu = 0.0
density = 1.6e-9
[fluid]
drag = [1.0e-8, 1.0e-8, 1.89e-8]
[time]
scheme = "generalized-alpha"
rho_inf = 0.9
end = {end}
dt = {dt}
output_every = {every}       # a row a period, as the PyElastica side records
[magnetic]
[[magnetic.parts]]
region = "head"
magnetization = 62.9
direction = [1.0, 0.0, 0.0]
[magnetic.field]
kind = "expression"
B = ["1.0e-5", "0.0", "1.0e-5*sin(2*pi*{freq}*t)"]
[output]
fields = false
"""

CANTILEVER = """title = "peer race: cantilever"
[mesh]
kind = "strip"
length = 10.0
width = 1.0
divisions = [{nx}, 1]
[shell]
thickness = 0.1
E = 1.2e6
nu = 0.0
density = 1e-9
[time]
scheme = "{scheme}"
{time}
[[boundary]]
where = "x=0"
fix = ["clamped"]
[[load]]
kind = "edge-force"
where = "x=L"
value = [0.0, 0.0, {force}]
ramp = "{ramp}"
{table}
[[output.probes]]
name = "tip"
at = [10.0, 0.5, 0.0]
[output]
fields = false
"""

EI = 1.2e6 * 1.0 * 0.1**3 / 12
ELASTICA_EXACT = 0.49346  # w/L at P L^2/EI = 2 (Mattiasson 1981; docs/verification.md C)
FREQ_EXACT = 1.87510407**2 * math.sqrt(EI / (1e-9 * 1.0 * 0.1 * 10.0**4)) / (2 * math.pi)


def parse(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument(
        "--quick",
        action="store_true",
        help="a reduced race: 2 periods (window 1-2), short ladders, no cantilevers, no cold start",
    )
    p.add_argument("--only", choices=["swim", "cantilever"], default=None, help="run one part only")
    p.add_argument(
        "--rftfem-venv",
        default=str(ROOT / ".venv"),
        help="the venv whose python runs rftfem (default .venv; try .venv-current)",
    )
    p.add_argument(
        "--elastica-venv",
        default=str(ROOT / ".venv-elastica"),
        help="the venv with pyelastica (./dev.sh race creates it)",
    )
    p.add_argument("--no-cold", action="store_true", help="skip the cold-start timings")
    p.add_argument(
        "--lu",
        choices=list(LU),
        default="petsc",
        help="rftfem's LU: PETSc's own (default, the cheaper at these sizes) or "
        "MUMPS (rftfem's default)",
    )
    p.add_argument("--csv", default=str(ROOT / "results" / "benchmarks" / "peer_race.csv"))
    return p.parse_args(argv)


def timed(cmd, env=None):
    t0 = time.perf_counter()
    r = subprocess.run(cmd, capture_output=True, text=True, env=env)
    return r, time.perf_counter() - t0


def read_csv(path):
    with open(path) as f:
        rows = list(csv.reader(f))
    head = rows[0]
    return head, [[float(x) for x in r] for r in rows[1:] if r]


#: rftfem's linear solver in the race: PETSc's own LU (serial).  At these sizes (315
#: unknowns) MUMPS's numerical factorisation costs 1.4 ms of fixed overhead, PETSc's
#: 0.05 ms: a third of a step.  ``--lu mumps`` races rftfem's default.
LU = {"petsc": ["-pc_factor_mat_solver_type", "petsc"], "mumps": []}


class Rftfem:
    def __init__(self, venv, tmp, lu="petsc"):
        self.python = str(Path(venv) / "bin" / "python")
        self.tmp = Path(tmp)
        self.k = 0
        self.solver_args = LU[lu]

    def run(self, scene_text, env=None):
        self.k += 1
        d = self.tmp / f"r{self.k}"
        d.mkdir()
        (d / "scene.toml").write_text(scene_text)
        r, wall = timed(
            [
                self.python,
                "-m",
                "rftfem",
                "run",
                str(d / "scene.toml"),
                "--out",
                str(d / "out"),
                "--quiet",
                *self.solver_args,
            ],
            env=env,
        )
        if r.returncode != 0:
            return None, wall, {"error": (r.stderr or r.stdout)[-300:]}
        summary = json.loads((d / "out" / "summary.json").read_text())
        return d / "out", wall, summary

    def swim(self, nx, steps, periods, window, env=None):
        dt = PERIOD / steps
        out, wall, summary = self.run(
            SWIM_SCENE.format(nx=nx, end=periods * PERIOD, dt=dt, freq=FREQ, every=steps), env
        )
        if out is None:
            return None, wall, summary
        head, rows = read_csv(out / "body.csv")
        ix = head.index("centroid_x")

        def at(t):
            return min(rows, key=lambda r: abs(r[0] - t))[ix]

        speed = (at(periods * PERIOD) - at(window * PERIOD)) / ((periods - window) * PERIOD)
        return speed, wall, summary

    def elastica(self, nx, dt):
        text = CANTILEVER.format(
            nx=nx,
            scheme="static",
            time=f"end = 1.0\ndt = {dt}",
            force=2.0 * EI / 100.0,
            ramp="linear",
            table="",
        )
        out, wall, summary = self.run(text)
        if out is None:
            return None, wall, summary
        head, rows = read_csv(out / "probes.csv")
        return rows[-1][head.index("tip_uz")] / 10.0, wall, summary

    def frequency(self, nx, steps):
        T = 1.0 / FREQ_EXACT
        text = CANTILEVER.format(
            nx=nx,
            scheme="generalized-alpha",
            time=f"rho_inf = 1.0\nend = {3.2 * T}\ndt = {T / steps}",
            force=1e-3 * 3 * EI / 100.0,
            ramp="table",
            table="table = [[0.0, 1.0], [1e-12, 0.0]]",
        )
        out, wall, summary = self.run(text)
        if out is None:
            return None, wall, summary
        head, rows = read_csv(out / "probes.csv")
        iz = head.index("tip_uz")
        return 1.0 / crossing_period([r[0] for r in rows], [r[iz] for r in rows]), wall, summary


def crossing_period(t, w):
    """The period from the zero crossings of w(t) (linear between rows), as the test does."""
    tc = []
    for i in range(len(w) - 1):
        if w[i] * w[i + 1] < 0:
            tc.append(t[i] - w[i] * (t[i + 1] - t[i]) / (w[i + 1] - w[i]))
    return 2 * (tc[-1] - tc[0]) / (len(tc) - 1)


class Elastica:
    def __init__(self, venv):
        self.python = str(Path(venv) / "bin" / "python")
        self.script = str(HERE / "peer_race_elastica" / "run.py")

    def run(self, *args, env=None):
        r, wall = timed([self.python, self.script, *map(str, args)], env=env)
        if r.returncode != 0 or not r.stdout.strip():
            return None, wall, {"error": (r.stderr or r.stdout)[-300:]}
        out = json.loads(r.stdout.strip().splitlines()[-1])
        return (out.get("value") if out.get("ok") else None), wall, out


def fmt_setting(code, problem, s):
    if code == "rftfem":
        if problem == "elastica":
            return f"{s[0]}x1, {round(1 / s[1])} load step(s)"
        return f"{s[0]}x1, dt=T/{s[1]}"
    return f"{s[0]} el, dt={s[1]:.2e}"


def cheapest(results, ref, tol):
    """The cheapest (by wall) result within tol of ref; results: dicts with value, wall."""
    ok = [r for r in results if r["value"] is not None and abs(r["value"] / ref - 1) <= tol]
    return min(ok, key=lambda r: r["wall"]) if ok else None


def main(argv=None):
    args = parse(argv)
    if not Path(args.rftfem_venv, "bin", "python").exists():
        print(f"peer_race.py: no {args.rftfem_venv}: run ./dev.sh setup", file=sys.stderr)
        return 2
    if not Path(args.elastica_venv, "bin", "python").exists():
        # skipped, not failed: ./dev.sh bench runs every benchmark and goes on
        print(
            f"peer_race.py: skipped: no {args.elastica_venv} (./dev.sh race creates it "
            "and runs the race)"
        )
        return 0
    load = os.getloadavg()
    print(
        f"peer race; load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} "
        f"({os.cpu_count()} cores); rftfem from {args.rftfem_venv}"
    )
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        rf, el = Rftfem(args.rftfem_venv, tmp, args.lu), Elastica(args.elastica_venv)
        if args.only in (None, "swim"):
            rows += race_swim(args, rf, el, tmp)
        if args.only in (None, "cantilever") and not args.quick:
            rows += race_cantilever(args, rf, el)
    load = os.getloadavg()
    print(f"load average after: {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}")
    path = Path(args.csv)
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(
            f,
            fieldnames=[
                "problem",
                "code",
                "kind",
                "tolerance",
                "setting",
                "wall_s",
                "value",
                "reference",
                "error",
                "ratio_elastica_over_rftfem",
                "detail",
            ],
        )
        w.writeheader()
        for r in rows:
            w.writerow(r)
    print(f"written {path}")
    return 0


def ladder_run(label, runs):
    """Run (code, setting, thunk) in order; print and return result dicts."""
    out = []
    for code, setting, thunk in runs:
        value, wall, info = thunk()
        if code.startswith("pyelastica") and "dt" in info:
            setting = (setting[0], info["dt"])
        detail = ""
        if code == "rftfem" and "wall_s" in info:
            ws = info["wall_s"]
            detail = (
                f"compile {ws['compile']:.2f} assembly {ws['assembly']:.2f} "
                f"solve {ws['solve']:.2f} total {ws['total']:.2f}; "
                f"steps {info.get('counts', {}).get('steps', '')} "
                f"newton {info.get('counts', {}).get('newton_iterations', '')}"
            )
        elif code.startswith("pyelastica") and "wall_loop" in info:
            detail = (
                f"import+setup {info['wall_import_setup']:.2f} first step (JIT) "
                f"{info['wall_first_step']:.2f} loop {info['wall_loop']:.2f}; "
                f"{info['steps']} steps"
            )
        elif "error" in info:
            detail = "FAILED: " + info["error"].replace("\n", " ")[-200:]
        v = "failed" if value is None else f"{value:.7g}"
        print(
            f"  {label:<9} {code:<10} {fmt_setting(code, label, setting):<28} "
            f"wall {wall:7.2f} s  value {v}   [{detail}]",
            flush=True,
        )
        out.append(
            {"code": code, "setting": setting, "value": value, "wall": wall, "detail": detail}
        )
    return out


def report(problem, results, refs, tols, kind):
    """Print the table of cheapest settings and return CSV rows.  refs: code -> its
    converged value; every code other than rftfem gets a ratio of its wall to rftfem's."""
    rows = []
    codes = [c for c in refs if c != "rftfem"] + ["rftfem"]
    print(f"\n{problem}: cheapest setting per tolerance (error against {kind})")
    print(
        f"{'code':<16} {'tol':>6} {'setting':<28} {'wall s':>8} {'error':>9} "
        f"{'PyElastica/rftfem':>18}"
    )
    for tol in tols:
        best = {c: cheapest([r for r in results if r["code"] == c], refs[c], tol) for c in codes}
        for c in codes:
            b = best[c]
            if b is None:
                print(f"{c:<16} {tol:>6.1%} {'none in the ladder':<28}")
                rows.append(
                    {
                        "problem": problem,
                        "code": c,
                        "kind": kind,
                        "tolerance": tol,
                        "setting": "none",
                        "reference": refs[c],
                    }
                )
                continue
            ratio = b["wall"] / best["rftfem"]["wall"] if c != "rftfem" and best["rftfem"] else None
            err = b["value"] / refs[c] - 1
            r = f"{ratio:.2f}x" if ratio else ""
            print(
                f"{c:<16} {tol:>6.1%} {fmt_setting(c, problem, b['setting']):<28} "
                f"{b['wall']:>8.2f} {err:>+9.4%} {r:>18}"
            )
            rows.append(
                {
                    "problem": problem,
                    "code": c,
                    "kind": kind,
                    "tolerance": tol,
                    "setting": fmt_setting(c, problem, b["setting"]),
                    "wall_s": f"{b['wall']:.3f}",
                    "value": f"{b['value']:.8g}",
                    "reference": f"{refs[c]:.8g}",
                    "error": f"{err:.3e}",
                    "ratio_elastica_over_rftfem": f"{ratio:.3f}" if ratio else "",
                    "detail": b["detail"],
                }
            )
    print("ratio: that code's wall / rftfem's wall at the same tolerance (> 1: rftfem faster)")
    return rows


def race_swim(args, rf, el, tmp):
    periods, window = (2, 1) if args.quick else (10, 5)
    if args.quick:
        rf_ladder = [(10, 32), (10, 64), (10, 96)]
        rf_ref = (20, 192)
        el_ladder = [10, 20]
        el_ref = 40
        ri_ladder = [10, 20, 40]
    else:
        rf_ladder = [
            (10, 16),
            (10, 32),
            (10, 48),
            (10, 64),
            (10, 80),
            (10, 96),
            (10, 128),
            (20, 64),
            (20, 128),
            (40, 128),
        ]
        rf_ref = (40, 256)
        el_ladder = [10, 20, 40]
        el_ref = 80
        ri_ladder = [10, 20, 40]
    cfl = 0.75
    print(f"\nswim: {periods} periods of {PERIOD} s, speed over periods {window}-{periods}")
    # warm-up (fills the form and numba caches), then the cold starts
    rf.swim(10, 16, 1, 0)
    el.run("swim", "--elements", 10, "--periods", 1, "--window", 0, "--cfl", cfl)
    extra = []
    if not (args.no_cold or args.quick):
        with tempfile.TemporaryDirectory() as cold:
            env = {**os.environ, "HOME": cold}
            _, wall_cold, s_cold = rf.swim(10, 16, 1, 0, env=env)
            _, wall_warm, s_warm = rf.swim(10, 16, 1, 0)
            env = {**os.environ, "NUMBA_CACHE_DIR": cold + "/numba"}
            _, ewall_cold, e_cold = el.run(
                "swim", "--elements", 10, "--periods", 1, "--window", 0, "--cfl", cfl, env=env
            )
            _, ewall_warm, e_warm = el.run(
                "swim", "--elements", 10, "--periods", 1, "--window", 0, "--cfl", cfl
            )
        cc = s_cold.get("wall_s", {}).get("compile", float("nan"))
        cw = s_warm.get("wall_s", {}).get("compile", float("nan"))
        print(
            f"cold start (one period, coarsest): rftfem {wall_cold:.2f} s cold / "
            f"{wall_warm:.2f} s warm (form compile {cc:.2f} / {cw:.2f} s); PyElastica "
            f"{ewall_cold:.2f} s cold / {ewall_warm:.2f} s warm (first step, numba JIT: "
            f"{e_cold.get('wall_first_step', float('nan')):.2f} / "
            f"{e_warm.get('wall_first_step', float('nan')):.2f} s)"
        )
        for code, c, w in (
            ("rftfem", wall_cold, wall_warm),
            ("pyelastica", ewall_cold, ewall_warm),
        ):
            extra.append(
                {
                    "problem": "swim",
                    "code": code,
                    "kind": "cold start, 1 period",
                    "setting": "coarsest",
                    "wall_s": f"{c:.3f}",
                    "detail": f"warm {w:.3f}",
                }
            )
    runs = [
        ("rftfem", s, (lambda s=s: rf.swim(s[0], s[1], periods, window)))
        for s in rf_ladder + [rf_ref]
    ]
    runs += [
        (
            "pyelastica",
            (n, None),
            (
                lambda n=n: el.run(
                    "swim", "--elements", n, "--periods", periods, "--window", window, "--cfl", cfl
                )
            ),
        )
        for n in el_ladder + [el_ref]
    ]
    # PyElastica with the rotary inertia scaled up to the axial step (not the physics,
    # a trick an expert user may take): against PyElastica's converged value
    runs += [
        (
            "pyelastica-ri",
            (n, None),
            (
                lambda n=n: el.run(
                    "swim",
                    "--elements",
                    n,
                    "--periods",
                    periods,
                    "--window",
                    window,
                    "--cfl",
                    cfl,
                    "--rotary-inertia",
                    "match-axial",
                )
            ),
        )
        for n in ri_ladder
    ]
    results = ladder_run("swim", runs)
    el_ref_value = [r for r in results if r["code"] == "pyelastica"][-1]["value"]
    refs = {
        "pyelastica": el_ref_value,
        "pyelastica-ri": el_ref_value,
        "rftfem": results[len(rf_ladder)]["value"],
    }
    print(
        f"\nconverged swim speed: rftfem {refs['rftfem']:.6g} mm/s, PyElastica "
        f"{refs['pyelastica']:.6g} mm/s (differ by {refs['rftfem'] / refs['pyelastica'] - 1:+.2%})"
    )
    ladder = [
        r
        for r in results
        if not (r["code"] == "rftfem" and r["setting"] == rf_ref)
        and not (r["code"] == "pyelastica" and r["setting"][0] == el_ref)
    ]
    rows = report("swim", ladder, refs, [1e-2, 1e-3], "each code's finest run")
    return (
        extra
        + rows
        + [
            {
                "problem": "swim",
                "code": r["code"],
                "kind": "run",
                "setting": fmt_setting(r["code"], "swim", r["setting"]),
                "wall_s": f"{r['wall']:.3f}",
                "value": r["value"],
                "detail": r["detail"],
            }
            for r in results
        ]
    )


def race_cantilever(args, rf, el):
    rows = []
    print("\ncantilever, static elastica P L^2/EI = 2 (exact w/L = 0.49346)")
    runs = [("rftfem", (nx, 1.0), (lambda nx=nx: rf.elastica(nx, 1.0))) for nx in (4, 8, 16, 32)]
    runs += [
        ("pyelastica", (n, float("nan")), (lambda n=n: el.run("elastica", "--elements", n)))
        for n in (4, 8, 16, 32)
    ]
    runs += [
        (
            "pyelastica-ri",
            (n, float("nan")),
            (lambda n=n: el.run("elastica", "--elements", n, "--rotary-inertia", "match-axial")),
        )
        for n in (8, 16, 32)
    ]
    res = ladder_run("elastica", runs)
    rows += report(
        "elastica",
        res,
        {"pyelastica": ELASTICA_EXACT, "pyelastica-ri": ELASTICA_EXACT, "rftfem": ELASTICA_EXACT},
        [5e-3, 1e-3],
        "the exact elastica",
    )
    print(f"\ncantilever, first bending frequency (exact Euler-Bernoulli {FREQ_EXACT:.6g} Hz)")
    runs = [
        ("rftfem", (nx, k), (lambda nx=nx, k=k: rf.frequency(nx, k)))
        for nx, k in ((4, 20), (4, 40), (4, 80), (8, 40), (8, 80), (16, 80))
    ]
    runs += [
        ("pyelastica", (n, float("nan")), (lambda n=n: el.run("frequency", "--elements", n)))
        for n in (4, 8, 16, 32)
    ]
    runs += [
        (
            "pyelastica-ri",
            (n, float("nan")),
            (lambda n=n: el.run("frequency", "--elements", n, "--rotary-inertia", "match-axial")),
        )
        for n in (8, 16, 32)
    ]
    res = ladder_run("frequency", runs)
    rows += report(
        "frequency",
        res,
        {"pyelastica": FREQ_EXACT, "pyelastica-ri": FREQ_EXACT, "rftfem": FREQ_EXACT},
        [5e-3, 1e-3],
        "exact Euler-Bernoulli",
    )
    return rows


if __name__ == "__main__":
    sys.exit(main())
