"""Purcell's three-link swimmer and the scallop theorem, in the Stokes regime.

    python3 demos/scallop.py [--out results/scallop] [--sp 0.5 1 2 4 8] [--cycles 3]

Without inertia a swimmer's displacement depends only on the sequence of shapes
it goes through.  A *reciprocal* stroke, one that goes out and comes back along
the same sequence, then returns it to where it started (Purcell's scallop
theorem); a stroke loop that encloses an area in shape space does not.  This
script shows both on the scene ``demos/scallop.toml``:

1. rigid links (E = 400 MPa), the square loop against the out-and-back loop at
   the same amplitude: the square loop swims (checked against the exact
   rigid-link result), the out-and-back loop does not;
2. soft outer links ("arms"): the out-and-back loop of the edges is no longer a
   reciprocal sequence of *shapes*, since the arms bend behind their edges and
   straighten after them.  The swim per cycle is measured over a range of the
   elasto-viscous number of the arms, ``Sp = ℓ (C₃ ω / D)^¼`` (ℓ the link width,
   ω = 2π/T, D = E t³ / (12 (1 − ν²))): zero for rigid arms (Sp → 0) and for
   arms too soft to move anything (Sp → ∞), largest in between.

Writes ``scallop.csv`` (one row per run), ``scallop.png`` (net displacement per
cycle against Sp for both loops) and prints the table.  Exit status 1 when the
rigid square loop misses the exact result by more than 2 % or the rigid
out-and-back loop moves more than 1e-3 of it.
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
from pathlib import Path

# the repository's .venv when this python3 lacks rftfem (scripts/repository_python.py)
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))
import repository_python  # noqa: E402

repository_python.ensure()

import numpy as np

HERE = Path(__file__).resolve().parent
SCENE = HERE / "scallop.toml"

#: exact rigid-link result per square cycle at A = 0.1 (docs/hinges.md)
SQUARE_Y_PER_CYCLE = -1.29213e-3
LINK_WIDTH, THICKNESS, NU, C3 = 0.5, 0.2, 0.3, 5.67e-9
RIGID_E = 400.0

#: (w_L, w_R) corners of each loop, in units of the amplitude; each leg T/4
LOOPS = {
    "square": [(0, 0), (1, 0), (1, 1), (0, 1), (0, 0)],
    "reciprocal": [(0, 0), (1, 0), (1, 1), (1, 0), (0, 0)],
}


def loop_tables(kind: str, amplitude: float, period: float, cycles: int):
    """``[[t, w]]`` tables of ``w_L`` and ``w_R`` (piecewise linear, each leg T/4)."""
    corners = LOOPS[kind]
    wl, wr = [[0.0, 0.0]], [[0.0, 0.0]]
    for n in range(cycles):
        for j, (a, b) in enumerate(corners[1:], start=1):
            t = round(period * (n + j / 4), 12)
            wl.append([t, float(amplitude * a)])
            wr.append([t, float(amplitude * b)])
    return wl, wr


def arm_modulus(sp: float, period: float) -> float:
    """Young's modulus of an arm with elasto-viscous number ``Sp`` at ω = 2π/T."""
    omega = 2 * math.pi / period
    D = C3 * omega * LINK_WIDTH**4 / sp**4
    return 12 * (1 - NU**2) * D / THICKNESS**3


def sperm_number(E: float, period: float) -> float:
    D = E * THICKNESS**3 / (12 * (1 - NU**2))
    return LINK_WIDTH * (C3 * 2 * math.pi / period / D) ** 0.25


def swim(
    kind: str,
    arm_E: float,
    cycles: int,
    amplitude: float = 0.1,
    period: float = 1.0,
    steps_per_leg: int = 40,
    divisions=(1, 4),
    out=None,
):
    """Run the scene with the given loop and arm modulus (into ``out``, or a
    temporary folder without fields); return the centre's Y displacement at the end
    of every cycle (mm) and the run's summary."""
    import tempfile

    import rftfem

    wl, wr = loop_tables(kind, amplitude, period, cycles)
    scene = rftfem.load_scene(
        SCENE,
        set={
            "time.end": float(cycles * period),
            "time.dt": period / (4 * steps_per_leg),
            "motion.0.values": wl,
            "motion.1.values": wr,
            "mesh.divisions": list(divisions),
        },
    )
    if arm_E != scene["shell.E"]:
        scene["shell.parts"] = [
            {"region": r, "E": float(arm_E), "nu": NU, "thickness": THICKNESS, "density": 0.0}
            for r in ("left", "right")
        ]
    with tempfile.TemporaryDirectory() as scratch:
        if out is None:
            out = Path(scratch) / "run"
            scene["output.fields"] = False
        try:
            result = rftfem.run(scene, out=out)
            summary = result.summary
        except rftfem.RunFailed as err:  # a study goes on; the row says why this run stopped
            result = rftfem.Result(err.folder)
            summary = {"status": "failed", "failure": str(err), "counts": result.summary["counts"]}
        probes = result.probes
    t, y = probes["time"].to_numpy(), probes["centre_uy"].to_numpy()
    ends = [
        y[int(np.argmin(abs(t - n * period)))] if t[-1] >= n * period - 1e-9 else np.nan
        for n in range(1, cycles + 1)
    ]
    return np.array(ends), summary


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=Path("results/scallop"))
    parser.add_argument(
        "--sp",
        type=float,
        nargs="+",
        default=[0.5, 1, 1.5, 2, 2.5, 3],
        help="elasto-viscous numbers of the soft arms",
    )
    parser.add_argument("--cycles", type=int, default=3)
    args = parser.parse_args(argv)
    if args.cycles < 2:
        parser.error("--cycles: expected at least 2 (the first cycle starts from rest)")
    if any(not (s > 0 and math.isfinite(s)) for s in args.sp):
        parser.error("--sp: expected positive numbers")
    args.out.mkdir(parents=True, exist_ok=True)

    rows, ok = [], True
    runs = [("square", RIGID_E), ("reciprocal", RIGID_E)]
    runs += [(kind, arm_modulus(sp, 1.0)) for sp in args.sp for kind in ("reciprocal", "square")]
    for kind, E in runs:
        ends, summary = swim(kind, E, args.cycles)
        per_cycle = ends[-1] - ends[-2]  # the last cycle: past the start from rest
        rows.append(
            {
                "loop": kind,
                "arm_E": E,
                "Sp": sperm_number(E, 1.0),
                "y_per_cycle": per_cycle,
                "y_total": ends[-1],
                "status": summary["status"],
                "steps": summary["counts"]["steps"],
            }
        )
        print(
            f"{kind:10s} Sp = {rows[-1]['Sp']:8.3g}  net Y per cycle {per_cycle:+.4e} mm"
            + ("" if summary["status"] == "ok" else f"  FAILED: {summary['failure']}")
        )

    square, recip = rows[0]["y_per_cycle"], rows[1]["y_per_cycle"]
    if rows[0]["status"] != "ok" or rows[1]["status"] != "ok":
        print("a rigid-link run did not complete")
        ok = False
    if abs(square / SQUARE_Y_PER_CYCLE - 1) > 0.02:
        print(
            f"rigid square loop: {square:.5e} mm per cycle, exact {SQUARE_Y_PER_CYCLE:.5e}: "
            "more than 2 % off"
        )
        ok = False
    if abs(recip) > 1e-3 * abs(square):
        print(f"rigid out-and-back loop moved {recip:.3e} mm per cycle: not reciprocal")
        ok = False

    with open(args.out / "scallop.csv", "w", newline="", encoding="utf-8") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    failed = [r for r in rows if r["status"] != "ok"]
    if failed:
        print(
            "runs that did not complete (left out of the plot): "
            + ", ".join(f"{r['loop']} at Sp = {r['Sp']:.3g}" for r in failed)
        )
    soft = [r for r in rows[2:] if r["loop"] == "reciprocal" and r["status"] == "ok"]
    if soft:
        peak = max(soft, key=lambda r: abs(r["y_per_cycle"]))
        print(
            f"out-and-back loop with soft arms: largest swim {peak['y_per_cycle']:+.3e} mm "
            f"per cycle at Sp = {peak['Sp']:.3g} ({abs(peak['y_per_cycle']) / LINK_WIDTH:.2e} "
            f"link widths; rigid arms: {recip:+.1e})"
        )
    _plot(rows, args.out / "scallop.png")
    print(f"wrote {args.out / 'scallop.csv'} and {args.out / 'scallop.png'}")
    return 0 if ok else 1


def _plot(rows, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4))
    for kind, marker in (("square", "s"), ("reciprocal", "o")):
        soft = sorted(
            (r for r in rows[2:] if r["loop"] == kind and r["status"] == "ok"),
            key=lambda r: r["Sp"],
        )
        if soft:
            ax.plot(
                [r["Sp"] for r in soft],
                [abs(r["y_per_cycle"]) / LINK_WIDTH for r in soft],
                marker=marker,
                label=f"{kind} loop, soft arms",
            )
        rigid = next(r for r in rows[:2] if r["loop"] == kind)
        ax.axhline(
            max(abs(rigid["y_per_cycle"]) / LINK_WIDTH, 1e-12),
            ls="--",
            lw=0.8,
            color="k" if kind == "square" else "grey",
            label=f"{kind} loop, rigid arms",
        )
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("Sp = ℓ (C₃ ω / D)^¼ of the arms")
    ax.set_ylabel("|net displacement per cycle| / link width")
    ax.set_title("Three-link swimmer, Stokes regime, A = 0.2 ℓ")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    sys.exit(main())
