"""Designing a magnetic strip's thickness with ``rftfem optimize --vary-field``.

    python3 demos/thickness_design.py [--out results/thickness_design]
                                      [--figures docs/figures] [--no-film]

The scene ``demos/thickness_design.toml`` is a strip 10 mm long and 1 mm wide,
clamped at X = 0, magnetized along its length (100 A/mm) in a small field
across it (8e-10 along Z): the field turns the magnetization toward itself and
bends the strip up.  Its thickness is the profile ``demos/thickness.csv``:
21 values at X = 0, 0.5, ..., 10, linear between them, all 0.1 mm as shipped.

Which thickness, of the same mass, turns the strip's end the most?  The couple
the field puts on each piece grows with its thickness (more magnet), the
bending stiffness with the cube of it.  This script lets rftfem find out:

1. ``rftfem optimize`` with ``--vary-field shell.thickness=0.05:0.2`` (the 21
   values are the variables, each between 0.05 and 0.2 mm), ``--constraint
   mass=start`` (the mass stays the uniform strip's) and ``--maximize`` the
   angle of the last half millimetre of the strip, read from the two probes
   ``back`` (X = 9.5) and ``tip`` (X = 10).  Each run also solves one adjoint
   problem that gives the objective's derivative by all 21 values, so SLSQP
   needs a dozen runs (a few seconds);
2. the same answer from beam theory (tests/material_references.py): the best
   profile of the same kind (21 values, linear between), and the best of any
   profile at all (thin up to X = 20/3, thick after);
3. the field ramped up from 0 on the uniform and on the designed strip, for
   the film.

It prints the table (tip rotation and angle of the last half millimetre, and
their ratio to the uniform strip's) and the two optimal profiles node by node,
writes the table to ``OUT/thickness_design.md`` and draws
``FIGURES/thickness_design.png`` (profiles, bent strips, the search's history)
and ``FIGURES/thickness_design.mp4`` (the two strips as the field grows, their
bending drawn 10 times larger).  The runs are folders under ``OUT``: the
search's in ``OUT/optimize`` (``optimize.csv``, ``best-thickness.csv``,
``best.toml``, ``eval-NNNN``), the ramps in ``OUT/ramp-uniform`` and
``OUT/ramp-designed``.  docs/thickness_design.md explains the numbers.  Exit
status 1 if the design does not beat the uniform strip.
"""

from __future__ import annotations

import argparse
import csv
import subprocess
import sys
import time
import tomllib
from pathlib import Path

# the repository's .venv when this python3 lacks rftfem (scripts/repository_python.py)
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))
import repository_python  # noqa: E402

repository_python.ensure()

import numpy as np  # noqa: E402

HERE = Path(__file__).resolve().parent
SCENE = HERE / "thickness_design.toml"
BOUNDS = (0.05, 0.2)  # mm: the thinnest and the thickest the strip may be anywhere
CHORD = 0.5  # mm: from the back probe to the tip probe
#: the angle of the chord from the back probe to the tip probe (rad): the tip's rotation
#: less 1e-3 of it (the last half millimetre hardly bends: the moment vanishes at the end)
OBJECTIVE = f"atan((tip_uz@end - back_uz@end)/({CHORD} + tip_ux@end - back_ux@end))"
DESIGN = [
    "--vary-field",
    f"shell.thickness={BOUNDS[0]}:{BOUNDS[1]}",
    "--constraint",
    "mass=start",
    "--maximize",
    "--objective",
    OBJECTIVE,
]
RAMP_STEPS = 25  # load steps of the film's runs
SCALE = 10.0  # the film draws the displacements this many times larger


class Strip:
    """The scene's numbers that beam theory needs (read from the TOML file)."""

    def __init__(self, path: Path = SCENE):
        s = tomllib.loads(path.read_text(encoding="utf-8"))
        self.length = s["mesh"]["length"]
        self.E = s["shell"]["E"]
        self.M0 = s["magnetic"]["parts"][0]["magnetization"]
        self.B = float(s["magnetic"]["field"]["B"][2])
        profile = s["shell"]["thickness"]  # "thickness.csv", or { profile = "..." }
        profile = profile["profile"] if isinstance(profile, dict) else profile
        with open(path.parent / profile, newline="") as f:
            rows = list(csv.DictReader(f))
        self.X = np.array([float(r["X"]) for r in rows])
        self.start = np.array([float(r["thickness"]) for r in rows])
        # the mean thickness (the profile is linear between its nodes: trapezoids)
        self.mean = np.sum((self.start[1:] + self.start[:-1]) / 2 * np.diff(self.X)) / self.length
        #: beam theory: theta_L = K * J[t], J = int_0^L (int_x^L t ds) / t(x)^3 dx
        self.K = 12 * self.M0 * self.B / self.E

    def centre_line(self, t_nodes, n=4001):
        """Small-deflection beam: the deflection w(x) of the thickness t_nodes
        (curvature K (int_x^L t ds) / t^3, clamped at x = 0)."""
        from scipy.integrate import cumulative_trapezoid as integral

        x = np.linspace(0.0, self.length, n)
        t = np.interp(x, self.X, t_nodes)
        above = integral(t[::-1], -x[::-1], initial=0.0)[::-1]  # int_x^L t ds
        theta = integral(self.K * above / t**3, x, initial=0.0)
        return x, integral(theta, x, initial=0.0)


def rftfem(*args: str) -> None:
    subprocess.run([sys.executable, "-m", "rftfem", *args], check=True)


def design(out: Path) -> tuple[list[dict], float]:
    """Run ``rftfem optimize`` into ``out``: the rows of optimize.csv, each marked
    ``feasible`` (status "ok": its mass the start's, to 1e-6; SLSQP may try a step
    that leaves the constraint, whose row says "infeasible"), and the wall time."""
    t0 = time.perf_counter()
    rftfem("optimize", str(SCENE), *DESIGN, "--out", str(out))
    wall = time.perf_counter() - t0
    with open(out / "optimize.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    for r in rows:
        r["feasible"] = r["status"] == "ok"
    return rows, wall


def measure(folder: Path) -> dict:
    """A run's objective, the rotation of its director at the tip, its thickness and
    its centre line (X and the displacement along the strip's middle)."""
    import rftfem as api

    result = api.Result(folder)
    fields = result.fields()
    X = np.asarray(fields.points)
    d, u = fields.point_data["director"], fields.point_data["displacement"]
    middle = (X[:, 1].min() + X[:, 1].max()) / 2
    tip = np.argmin(np.hypot(X[:, 0] - X[:, 0].max(), X[:, 1] - middle))
    line = np.flatnonzero(np.isclose(X[:, 1], middle))
    line = line[np.argsort(X[line, 0])]
    with open(folder / "thickness.csv", newline="") as f:
        t = np.array([float(r["thickness"]) for r in csv.DictReader(f)])
    return {
        "folder": folder,
        "chord": result.quantity(OBJECTIVE),  # rftfem optimize's formula
        "tip": float(np.arctan2(-d[tip, 0], d[tip, 2])),
        "t": t,
        "X": X[line, 0],
        "u": np.asarray(u[line]),
    }


def beam(strip: Strip) -> dict | None:
    """Beam theory's uniform strip and its optima (tests/material_references.py), or
    None where the repository's tests folder is not beside the demos."""
    tests = HERE.parent / "tests"
    if not (tests / "material_references.py").exists():
        return None
    sys.path.insert(0, str(tests))
    try:
        import material_references as mr
    finally:
        sys.path.pop(0)
    L, (lo, hi), K = strip.length, BOUNDS, strip.K
    uniform = np.full(len(strip.X), strip.mean)
    best, J = mr.magnetic_strip_piecewise_linear_optimum(L, strip.mean, lo, hi, len(strip.X))
    a, J_cont, _ = mr.bang_bang_coefficients(L, strip.mean, lo, hi)
    return {
        "uniform": (
            K * mr.magnetic_strip_linear_coefficient(uniform, L),
            K * mr.magnetic_strip_linear_coefficient(uniform, L, CHORD),
        ),
        "same": (K * J, K * mr.magnetic_strip_linear_coefficient(best, L, CHORD)),
        # thick over the last CHORD: its bending there is K CHORD^2 / (6 hi^2)
        "continuous": (K * J_cont, K * (J_cont - CHORD**2 / (6 * hi**2))),
        "t_same": best,
        "a": a,
    }


def ramp(scene, out: Path, title: str) -> Path:
    """The scene with its field grown from 0 (t = 0) to its value (t = 1) in
    RAMP_STEPS static steps, fields written at each: the film's frames."""
    import rftfem as api

    B = api.load_scene(scene)["magnetic.field.B"]
    api.run(
        api.load_scene(
            scene,
            set={
                "magnetic.field.B": [f"({b})*t" for b in B],
                "time.dt": 1.0 / RAMP_STEPS,
                "title": title,
            },
        ),
        out=out,
    )
    return out


def table(start, best, ref, runs, wall) -> list[str]:
    rows = [
        ("rftfem, uniform (the start)", start["tip"], start["chord"]),
        (f"rftfem, designed ({best['folder'].name})", best["tip"], best["chord"]),
    ]
    if ref is not None:
        rows += [
            ("beam, uniform", *ref["uniform"]),
            ("beam, best of 21 nodes, linear between", *ref["same"]),
            (f"beam, best of all (thin, then thick from X = {ref['a']:.3f})", *ref["continuous"]),
        ]
    lines = [
        "| strip | tip rotation (rad) | ÷ uniform | angle of the last 0.5 mm "
        "(rad, the objective) | ÷ uniform |",
        "| --- | ---: | ---: | ---: | ---: |",
    ]
    for i, (name, tip, chord) in enumerate(rows):
        base = rows[0] if i < 2 else rows[2]
        lines.append(
            f"| {name} | {tip:.7f} | {tip / base[1]:.4f} | {chord:.7f} | {chord / base[2]:.4f} |"
        )
    lines += [
        "",
        f"rftfem optimize: {runs} runs in {wall:.1f} s (each a static run and its adjoint).",
    ]
    return lines


def figure(strip, start, best, ref, rows, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a, b, c) = plt.subplots(3, 1, figsize=(7, 9.5))
    a.plot(strip.X, start["t"], "o--", color="0.5", ms=3, label="start (uniform)")
    a.plot(strip.X, best["t"], "o-", ms=5, label=f"rftfem optimize ({best['folder'].name})")
    if ref is not None:
        a.plot(
            strip.X,
            ref["t_same"],
            "x",
            color="C3",
            ms=8,
            label="beam theory, best of the same 21 nodes",
        )
        a.step(
            [0, ref["a"], strip.length],
            [BOUNDS[0], BOUNDS[1], BOUNDS[1]],
            where="post",
            color="C2",
            lw=1,
            label="beam theory, best of all profiles",
        )
    a.set_ylabel("thickness (mm)")
    a.set_title("Thickness along the strip (same mass, 0.05-0.2 mm)", fontsize=10)
    a.legend(fontsize=8)
    for run, name, colour in ((start, "uniform", "0.4"), (best, "designed", "C0")):
        b.plot(
            run["X"] + run["u"][:, 0], run["u"][:, 2], color=colour, lw=3, label=f"rftfem, {name}"
        )
    if ref is not None:
        for t in (start["t"], ref["t_same"]):
            b.plot(*strip.centre_line(t), "--", color="w", lw=1)
        b.plot([], [], "--", color="0.6", label="beam theory (small deflection; on top)")
    b.set_xlabel("X (mm)")
    b.set_ylabel("deflection along Z (mm)")
    b.set_title("The strips' centre lines in the field", fontsize=10)
    b.legend(fontsize=8)
    ok = [r for r in rows if r["status"] in ("ok", "infeasible")]
    c.plot([int(r["evaluation"]) for r in ok], [float(r["objective"]) for r in ok], "o-")
    off = [r for r in ok if not r["feasible"]]
    if off:
        c.plot(
            [int(r["evaluation"]) for r in off],
            [float(r["objective"]) for r in off],
            "o",
            mfc="w",
            color="C3",
            label="off the mass constraint (a trial step)",
        )
    if ref is not None:
        c.axhline(ref["same"][1], color="C3", ls="--", lw=1, label="beam, same 21 nodes")
        c.axhline(ref["continuous"][1], color="C2", ls=":", lw=1, label="beam, best of all")
    if ref is not None or off:
        c.legend(fontsize=8)
    c.set_xlabel("evaluation (run)")
    c.set_ylabel("angle of the last 0.5 mm (rad)")
    c.set_title("The search (SLSQP, exact gradients)", fontsize=10)
    for ax in (a, b, c):
        ax.grid(True, alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def film(runs: list[tuple[str, Path, np.ndarray, str]], strip: Strip, path: Path) -> bool:
    """The strips drawn as bands of their true thickness about their centre lines,
    the displacements SCALE times larger, at each load step of the ramp runs."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.animation import FFMpegWriter

    import rftfem as api

    try:
        import imageio_ffmpeg

        plt.rcParams["animation.ffmpeg_path"] = imageio_ffmpeg.get_ffmpeg_exe()
    except ImportError:
        pass
    if not FFMpegWriter.isAvailable():
        print("no ffmpeg: the film is not drawn")
        return False
    frames = []  # per load step, per strip: (outline x, outline z, tip rotation)
    results = [api.Result(folder) for _, folder, _, _ in runs]
    for k, time_ in enumerate(results[0].times):
        shapes = []
        for (name, _, t_nodes, _), result in zip(runs, results):
            f = result.fields(time_)
            X = np.asarray(f.points)
            line = np.flatnonzero(np.isclose(X[:, 1], (X[:, 1].min() + X[:, 1].max()) / 2))
            line = line[np.argsort(X[line, 0])]
            u = f.point_data["displacement"][line]
            x, z = X[line, 0] + SCALE * u[:, 0], SCALE * u[:, 2]
            dx, dz = np.gradient(x), np.gradient(z)
            n = np.stack([-dz, dx]) / np.hypot(dx, dz)
            half = np.interp(X[line, 0], strip.X, t_nodes) / 2
            d = f.point_data["director"][line[-1]]
            shapes.append(
                (
                    np.r_[x + n[0] * half, (x - n[0] * half)[::-1]],
                    np.r_[z + n[1] * half, (z - n[1] * half)[::-1]],
                    float(np.arctan2(-d[0], d[2])),
                )
            )
        frames.append((time_, shapes))
    fig, ax = plt.subplots(figsize=(8, 3.6))
    writer = FFMpegWriter(fps=8, codec="libx264", extra_args=["-pix_fmt", "yuv420p"])
    top = max(z.max() for _, shapes in frames for _, z, _ in shapes)
    with writer.saving(fig, str(path), dpi=100):
        for time_, shapes in frames + [frames[-1]] * 12:  # hold the last frame
            ax.clear()
            ax.axvline(0.0, color="0.3", lw=4)  # the clamp
            for (name, _, _, colour), (xs, zs, tip) in zip(runs, shapes):
                ax.fill(
                    xs,
                    zs,
                    color=colour,
                    alpha=0.8,
                    label=f"{name}: tip turned {1000 * tip:.1f} mrad",
                )
            ax.set_xlim(-0.3, strip.length + 0.3)
            ax.set_ylim(-0.3, top + 0.3)
            ax.set_aspect("equal")
            ax.set_xlabel("X (mm)")
            ax.set_ylabel("Z (mm)")
            ax.legend(loc="upper left", fontsize=9)
            ax.set_title(
                f"field {time_:.2f} × 8e-10 along Z; same mass; displacements × "
                f"{SCALE:g}, thickness true",
                fontsize=10,
            )
            fig.tight_layout()
            writer.grab_frame()
    plt.close(fig)
    return True


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--out",
        type=Path,
        default=Path("results/thickness_design"),
        help="the results folder (default results/thickness_design)",
    )
    parser.add_argument(
        "--figures",
        type=Path,
        default=HERE.parent / "docs" / "figures",
        help="where thickness_design.png and .mp4 go (default docs/figures)",
    )
    parser.add_argument("--no-film", action="store_true", help="skip the ramps and the film")
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    args.figures.mkdir(parents=True, exist_ok=True)
    strip = Strip()

    # 1. the search (its first evaluation is the uniform strip as shipped)
    rows, wall = design(args.out / "optimize")
    best = max((r for r in rows if r["feasible"]), key=lambda r: float(r["objective"]))
    start = measure(args.out / "optimize" / rows[0]["folder"])
    best = measure(args.out / "optimize" / best["folder"])

    # 2. beam theory
    ref = beam(strip)
    lines = table(start, best, ref, len(rows), wall)
    if ref is not None:
        lines += [
            "",
            "Optimal thickness node by node (mm):",
            "",
            "| X | " + " | ".join(f"{x:g}" for x in strip.X) + " |",
            "| --- " * (len(strip.X) + 1) + "|",
            "| rftfem | " + " | ".join(f"{t:.4f}" for t in best["t"]) + " |",
            "| beam | " + " | ".join(f"{t:.4f}" for t in ref["t_same"]) + " |",
            "",
            f"largest difference {np.abs(best['t'] - ref['t_same']).max():.1e} mm",
        ]
    else:
        lines += ["", "tests/material_references.py not found: no beam theory"]
    text = "\n".join(lines)
    print(text)
    (args.out / "thickness_design.md").write_text(text + "\n", encoding="utf-8")
    figure(strip, start, best, ref, rows, args.figures / "thickness_design.png")
    print(f"figure: {args.figures / 'thickness_design.png'}")

    # 3. the film: the field ramped up on both strips
    if not args.no_film:
        runs = [
            (
                "uniform",
                ramp(SCENE, args.out / "ramp-uniform", "uniform strip"),
                start["t"],
                "0.55",
            ),
            (
                "designed",
                ramp(
                    args.out / "optimize" / "best.toml",
                    args.out / "ramp-designed",
                    "designed strip",
                ),
                best["t"],
                "C0",
            ),
        ]
        if film(runs, strip, args.figures / "thickness_design.mp4"):
            print(f"film: {args.figures / 'thickness_design.mp4'}")
    return 0 if best["chord"] > start["chord"] else 1


if __name__ == "__main__":
    sys.exit(main())
