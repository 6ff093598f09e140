"""Accuracy against cost for the bidirectional magnetic strip (demos/bidirectional_strip.toml).

What a user sweeping frequencies has to choose is the mesh and the steps per
field period.  This runs the +X protocol at one frequency on a few meshes and
step sizes and prints, for each: unknowns, accepted steps, dt cuts, Newton
iterations, wall time, and the mean swimming speed over the first two field
periods after the strip has settled (0.1 s after the ramp), with its difference
from the finest run of the set.  The speed there is a transient (the strip still
slows down over later periods, docs/magnetic_strip.md), but a well-defined one that every run
resolves the same way.

    .venv/bin/python benchmarks/strip_accuracy_cost.py                  # 4 Hz, about 10 minutes
    .venv/bin/python benchmarks/strip_accuracy_cost.py --frequency 16 --steps 25 50 100

Figures go to stdout and to results/benchmarks/strip_accuracy_cost.csv.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

# the repository's .venv when this python3 lacks rftfem (scripts/repository_python.py)
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))
import repository_python  # noqa: E402

repository_python.ensure()

import numpy as np

import rftfem  # noqa: F401  (sets up the FEniCSx stack)
from rftfem.integration.simulation import Simulation
from rftfem.scene.reading import load_scene

SCENE = Path(__file__).resolve().parents[1] / "demos" / "bidirectional_strip.toml"
RAMP, SETTLE, PERIODS = 0.1, 0.1, 2


class Centroid:
    """Observer: the centroid after every accepted step."""

    def __init__(self):
        self.t, self.c = [], []

    def __call__(self, sim):
        self.t.append(sim.t)
        self.c.append(sim.model.centroid())

    def speed_z(self, t0, t1):
        t, z = np.array(self.t), np.array(self.c)[:, 2]
        i, j = int(np.argmin(abs(t - t0))), int(np.argmin(abs(t - t1)))
        return (z[j] - z[i]) / (t[j] - t[i])


def run(frequency: float, divisions: tuple[int, int], steps: int) -> dict:
    end = RAMP + SETTLE + PERIODS / frequency
    scene = load_scene(
        SCENE,
        [
            f"magnetic.field.frequency={frequency!r}",
            f"time.end={end!r}",
            f"time.dt={1 / (frequency * steps)!r}",
            f"mesh.divisions={list(divisions)}",
            "output.fields=false",
        ],
    )
    track = Centroid()
    sim = Simulation(scene, quiet=True, observers=[track])
    wall = time.perf_counter()
    try:
        summary = sim.run()
    finally:
        sim.close()
    c = summary["counts"]
    return {
        "mesh": f"{divisions[0]}x{divisions[1]}",
        "steps_per_period": steps,
        "dofs": summary["dofs"],
        "steps": c["steps"],
        "cuts": c["dt_cuts"],
        "newton": c["newton_iterations"],
        "wall_s": time.perf_counter() - wall,
        "status": summary["status"],
        "speed": track.speed_z(RAMP + SETTLE, end),
    }


def _positive(kind):
    def parse(text: str):
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a number, found '{text}'") from None
        if not 0 < value < float("inf"):
            raise argparse.ArgumentTypeError(f"expected a finite number > 0, found '{text}'")
        return value

    return parse


def _divisions(text: str) -> tuple[int, int]:
    """``"20x4"`` -> ``(20, 4)``; anything else is an argparse error, not a traceback."""
    try:
        nx, ny = (int(n) for n in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected divisions like 20x4, found '{text}'") from None
    if nx < 1 or ny < 1:
        raise argparse.ArgumentTypeError(f"expected positive divisions, found '{text}'")
    return nx, ny


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--frequency", type=_positive(float), default=4.0, help="field frequency (Hz)"
    )
    parser.add_argument(
        "--steps",
        type=_positive(int),
        nargs="+",
        default=[25, 50, 100],
        help="steps per field period on the demo mesh",
    )
    parser.add_argument(
        "--meshes",
        nargs="+",
        type=_divisions,
        default=["20x4", "40x8"],
        help="meshes (divisions along x y); the finer ones at 50 steps per period",
    )
    parser.add_argument("--out", type=Path, default=Path("results/benchmarks"))
    args = parser.parse_args(argv)
    meshes = [m if isinstance(m, tuple) else _divisions(m) for m in args.meshes]

    cases = [(meshes[0], s) for s in args.steps] + [(m, 50) for m in meshes[1:]]
    rows = []
    for divisions, steps in cases:
        rows.append(run(args.frequency, divisions, steps))

    # the runs log their steps; the table comes after them
    print(
        f"\nstrip, +X protocol, {args.frequency:g} Hz: mean speed along Z over {PERIODS} "
        f"periods from {RAMP + SETTLE:g} s"
    )
    print(
        f"{'mesh':>6} {'steps/T':>7} {'dofs':>6} {'steps':>6} {'cuts':>5} {'newton':>7} "
        f"{'wall s':>7} {'s/step':>7} {'speed mm/s':>11}"
    )
    for r in rows:
        print(
            f"{r['mesh']:>6} {r['steps_per_period']:>7} {r['dofs']:>6} {r['steps']:>6} "
            f"{r['cuts']:>5} {r['newton']:>7} {r['wall_s']:>7.1f} "
            f"{r['wall_s'] / max(r['steps'], 1):>7.3f} {r['speed']:>+11.4f}"
            + ("" if r["status"] == "ok" else "  FAILED")
        )

    # time step on the first mesh against its finest step; meshes at 50 steps per
    # period against the finest mesh
    first = [r for r in rows if r["mesh"] == rows[0]["mesh"]]
    at50 = [r for r in rows if r["steps_per_period"] == 50]
    print()
    for label, group in (("time step", first), ("mesh", at50)):
        if len(group) < 2:
            continue
        ref = max(group, key=lambda r: (r["dofs"], r["steps_per_period"]))
        for r in group:
            r[f"diff_{label.replace(' ', '_')}_percent"] = d = (
                100 * (r["speed"] - ref["speed"]) / abs(ref["speed"])
            )
            print(
                f"{label:>9}: {r['mesh']:>6} at {r['steps_per_period']:>4} steps/T "
                f"{d:+8.3f} % from {ref['mesh']} at {ref['steps_per_period']}"
            )

    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / "strip_accuracy_cost.csv"
    keys = [k for k in rows[0] if not k.startswith("diff_")]
    keys += ["diff_time_step_percent", "diff_mesh_percent"]
    with open(path, "w", encoding="utf-8") as f:
        f.write(",".join(keys) + "\n")
        for r in rows:
            f.write(
                ",".join(
                    f"{r[k]:.6g}" if isinstance(r.get(k), float) else str(r.get(k, ""))
                    for k in keys
                )
                + "\n"
            )
    print(f"wrote {path}")
    return 0 if all(r["status"] == "ok" for r in rows) else 1


if __name__ == "__main__":
    raise SystemExit(main())
