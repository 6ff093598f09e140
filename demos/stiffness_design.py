"""Designing the stiffness along a flexible swimmer with ``rftfem optimize``.

    python3 demos/stiffness_design.py [--out results/stiffness_design] [--grid 11]
                                      [--refine 8] [--budget 40] [--no-film] [--reuse]

The scene ``demos/stiffness_design.toml`` heaves one end of a thin elastic strip
in RFT drag (no inertia); the bending wave the drag makes of the heave carries
the strip along −X.  How fast depends on the strip's stiffness, through the
elasto-viscous (sperm) number ``Sp = L (C₃ ω / D)^¼``.  This script asks for
the fastest strip at that heave, twice:

1. uniform: ``rftfem optimize --method grid`` over ``shell.E`` (the three parts
   inherit it), ``--grid`` values on a log scale across the design interval,
   then the grid's best refined between its neighbours (``--refine`` runs of
   Nelder–Mead);
2. designed: ``rftfem optimize`` (Nelder–Mead) over the E of the three thirds
   (``shell.parts.0.E``, ``.1.E``, ``.2.E``, log scales), from the uniform optimum.

The objective is the mean speed over the third period, ``−rate(centroid_x, 2, 3)``
(mm/s).  Beside each optimum the script prints the linearised beam theory's
speed of the same stiffnesses (a small-amplitude Euler–Bernoulli filament in
the same drag, solved exactly segment by segment): the independent answer.
Each evaluation is an ordinary run folder under ``OUT/uniform``,
``OUT/uniform-refine`` or ``OUT/design``.  Prints the table (the optima, the
runs each search needed, their wall time, the design's gain), writes
``OUT/stiffness.md`` and renders the best design's film ``OUT/optimum.mp4``.
Exit status 1 if the designed swimmer is slower than the uniform optimum.
With ``--reuse`` finished runs are read, not repeated.
"""

from __future__ import annotations

import argparse
import cmath
import csv
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
SCENE = HERE / "stiffness_design.toml"
E_LO, E_HI = 0.25, 25.0  # MPa: the stiffness any part may take
OBJECTIVE = "-rate(centroid_x, 2, 3)"  # mm/s along −X, the third period
PARTS = ("head", "middle", "tail")


class Strip:
    """The scene's numbers that set the physics (read from the TOML file)."""

    def __init__(self, path: Path):
        s = tomllib.loads(path.read_text(encoding="utf-8"))
        self.L = float(s["mesh"]["length"])
        self.t = float(s["shell"]["thickness"])
        self.nu = float(s["shell"].get("nu", 0.0))
        self.c_along, _, self.c_normal = (float(c) for c in s["fluid"]["drag"])
        self.A = float(s["motion"][0]["amplitude"])
        self.omega = float(s["motion"][0]["angular_frequency"])

    def bending(self, E: float) -> float:
        """D = E t³ / (12 (1 − ν²)), the bending stiffness per unit width."""
        return E * self.t**3 / (12.0 * (1.0 - self.nu**2))

    def sp(self, E: float) -> float:
        """The sperm number L (C₃ ω / D)^¼ of a uniform strip of modulus E."""
        return self.L * (self.c_normal * self.omega / self.bending(E)) ** 0.25

    def linear_speed(self, moduli, samples: int = 400) -> float:
        """The swimming speed (along −X) of the linearised problem: a beam
        C₃ ∂w/∂t = −∂²(D ∂²w/∂x²)/∂x² in equal segments of the given moduli, w = A
        and ∂w/∂x = 0 at x = 0, free at x = L, continuity of w, w', D w'', (D w'')'
        at the joints.  With w = Re(W(x) e^{iωt}) the thrust of RFT is
        (C₃ − C₁) ⟨w_t w_x⟩ per width and the tangential drag C₁ U L balances it."""
        import numpy as np

        n = len(moduli)
        ell = self.L / n
        ds = [self.bending(E) for E in moduli]
        turns = [cmath.exp(1j * (-math.pi / 8 + j * math.pi / 2)) for j in range(4)]
        ks = [
            [(self.c_normal * self.omega / d) ** 0.25 * z for z in turns] for d in ds
        ]  # the roots of k⁴ = −i C₃ ω / D
        M = np.zeros((4 * n, 4 * n), complex)
        rhs = np.zeros(4 * n, complex)
        M[0, 0:4], rhs[0] = 1.0, self.A  # W(0) = A
        M[1, 0:4] = ks[0]  # W'(0) = 0 (clamped heave)
        row = 2
        for s in range(n - 1):  # the joints: W, W', D W'', D W''' continuous
            for p, (da, db) in enumerate(((1, 1), (1, 1), (ds[s], ds[s + 1]), (ds[s], ds[s + 1]))):
                M[row, 4 * s : 4 * s + 4] = [da * k**p * cmath.exp(k * ell) for k in ks[s]]
                M[row, 4 * s + 4 : 4 * s + 8] = [-db * k**p for k in ks[s + 1]]
                row += 1
        for p in (2, 3):  # the free end: no moment, no shear force
            M[row, 4 * n - 4 :] = [k**p * cmath.exp(k * ell) for k in ks[-1]]
            row += 1
        c = np.linalg.solve(M, rhs).reshape(n, 4)
        x = np.linspace(0.0, ell, samples)
        flux = 0.0  # ∫ ⟨w_t w_x⟩ dx over the strip
        for s in range(n):
            modes = np.exp(np.outer(x, ks[s]))
            W, dW = modes @ c[s], modes @ (c[s] * np.array(ks[s]))
            f = 0.5 * np.real(1j * self.omega * W * np.conj(dW))
            flux += float(np.sum(0.5 * (f[1:] + f[:-1]) * np.diff(x)))  # trapezoid rule
        return -(self.c_normal - self.c_along) * flux / (self.c_along * self.L)


def optimize(
    out: Path, vary: list[str], method: str, budget: int, sets: list[str], reuse: bool
) -> tuple[dict, list[dict], float]:
    """Run ``rftfem optimize``; its best row, all its ok rows, its wall time."""
    cmd = [sys.executable, "-m", "rftfem", "optimize", str(SCENE)]
    for v in vary:
        cmd += ["--vary", v]
    for s in sets:
        cmd += ["--set", s]
    cmd += [
        "--objective",
        OBJECTIVE,
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
    subprocess.run(cmd, check=True)
    wall = time.perf_counter() - t0
    with open(out / "optimize.csv", newline="") as f:
        rows = [r for r in csv.DictReader(f) if r["status"] == "ok"]
    if not rows:
        sys.exit(f"stiffness_design.py: no run of {out} succeeded (optimize.csv)")
    return max(rows, key=lambda r: float(r["objective"])), rows, wall


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--out",
        type=Path,
        default=Path("results/stiffness_design"),
        help="the results folder (default results/stiffness_design)",
    )
    parser.add_argument("--grid", type=int, default=11, help="uniform E values of the scan")
    parser.add_argument(
        "--refine", type=int, default=8, help="runs refining the scan's best (0: none)"
    )
    parser.add_argument("--budget", type=int, default=40, help="the 3-part search's runs at most")
    parser.add_argument("--no-film", action="store_true", help="skip the film of the optimum")
    parser.add_argument("--reuse", action="store_true", help="read finished runs")
    args = parser.parse_args(argv)
    strip = Strip(SCENE)
    t_start = time.perf_counter()

    # 1. uniform: a grid over shell.E, then its best refined between its neighbours
    scan, scan_rows, scan_wall = optimize(
        args.out / "uniform", [f"shell.E={E_LO}:{E_HI}:log"], "grid", args.grid, [], args.reuse
    )
    uniform, uniform_runs, uniform_wall = scan, len(scan_rows), scan_wall
    if args.refine > 0:
        grid = sorted(float(r["shell.E"]) for r in scan_rows)
        i = grid.index(float(scan["shell.E"]))
        lo, hi = grid[max(i - 1, 0)], grid[min(i + 1, len(grid) - 1)]
        fine, fine_rows, fine_wall = optimize(
            args.out / "uniform-refine",
            [f"shell.E={lo:.10g}:{hi:.10g}:log"],
            "nelder-mead",
            args.refine,
            [f"shell.E={scan['shell.E']}"],
            args.reuse,
        )
        uniform_runs += len(fine_rows)
        uniform_wall += fine_wall
        if float(fine["objective"]) > float(uniform["objective"]):
            uniform = fine
    E_u, U_u = float(uniform["shell.E"]), float(uniform["objective"])

    # 2. designed: the three parts' E, from the uniform optimum
    keys = [f"shell.parts.{j}.E" for j in range(3)]
    design, design_rows, design_wall = optimize(
        args.out / "design",
        [f"{k}={E_LO}:{E_HI}:log" for k in keys],
        "nelder-mead",
        args.budget,
        [f"{k}={E_u!r}" for k in keys],
        args.reuse,
    )
    E_d = [float(design[k]) for k in keys]
    U_d = float(design["objective"])
    gain = U_d / U_u - 1.0

    # 3. the table, beside the linearised theory of the same stiffnesses
    E_g, U_g = float(scan["shell.E"]), float(scan["objective"])
    lin_g, lin_u, lin_d = (strip.linear_speed(m) for m in ([E_g], [E_u], E_d))
    best = args.out / "design" / design["folder"]

    def row(name, moduli, sp, U, lin, gain, search, runs, wall):
        return (
            f"| {name} | {moduli} | {sp} | {U:.5g} | {lin:.5g} | {gain} | {search} | "
            f"{runs} | {wall:.0f} |"
        )

    lines = [
        f"Heaved strip (L = {strip.L:g} mm, t = {strip.t:g} mm, A = {strip.A:g} mm, "
        f"ω = {strip.omega:.4g} rad/s), E in [{E_LO:g}, {E_HI:g}] MPa; "
        f"speed U = {OBJECTIVE} mm/s.",
        "",
        "| swimmer | E (MPa) | Sp | U (mm/s) | linear theory U | gain | search | runs | wall (s) |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- |",
        row(
            "uniform, grid's best",
            f"{E_g:.4g}",
            f"{strip.sp(E_g):.3f}",
            U_g,
            lin_g,
            f"{100 * (U_g / U_u - 1):+.2f} %",
            f"grid of {len(scan_rows)}",
            len(scan_rows),
            scan_wall,
        ),
        row(
            "uniform optimum",
            f"{E_u:.4g}",
            f"{strip.sp(E_u):.3f}",
            U_u,
            lin_u,
            "0",
            "grid + refine",
            uniform_runs,
            uniform_wall,
        ),
        row(
            "designed (3 parts)",
            ", ".join(f"{p} {E:.3g}" for p, E in zip(PARTS, E_d)),
            " / ".join(f"{strip.sp(E):.2f}" for E in E_d),
            U_d,
            lin_d,
            f"{100 * gain:+.2f} %",
            "nelder-mead",
            len(design_rows),
            design_wall,
        ),
        "",
        f"Uniform optimum at Sp = {strip.sp(E_u):.3f}; the designed swimmer is "
        f"{100 * gain:+.2f} % faster (linear theory of the same moduli: "
        f"{100 * (lin_d / lin_u - 1):+.2f} %). Best design: {best}.",
    ]
    if args.reuse:
        lines.append("(--reuse: the wall times are this invocation's; finished runs were read.)")
    print("\n".join(lines))
    (args.out / "stiffness.md").write_text("\n".join(lines) + "\n", encoding="utf-8")
    if not args.no_film:
        film = args.out / "optimum.mp4"
        subprocess.run(
            [sys.executable, "-m", "rftfem", "render", str(best), "--out", str(film)], check=True
        )
        print(
            f"film of the designed swimmer: {film}; the searches' histories: "
            f"{args.out}/*/optimize.png"
        )
    print(f"total wall time {time.perf_counter() - t_start:.0f} s")
    if U_d < U_u:
        print("the designed swimmer is slower than the uniform optimum", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
