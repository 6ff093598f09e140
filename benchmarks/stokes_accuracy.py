"""Accuracy against seconds: the Stokes layer against the blobs on a rigid disk.

A thin disk of radius a (exact: broadside 16 μaU, edgewise 32/3 μaU, spin and
rotation about a diameter 32/3 μa³Ω) on uniform meshes, each method at its
default settings: the largest error of the four motions against the seconds to
make the resistance (rules or kernel, factorisation) and apply it to the four
motions, one thread. docs/stokes.md §Convergence quotes the table.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/stokes_accuracy.py
    .venv/bin/python benchmarks/stokes_accuracy.py --sizes 0.6 0.3 --methods layer
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
# the repository's .venv when this python3 lacks rftfem (scripts/repository_python.py)
sys.path.insert(0, str(ROOT / "scripts"))
import repository_python  # noqa: E402

repository_python.ensure()

import numpy as np  # noqa: E402

sys.path.insert(0, str(ROOT / "tests"))
from stokes_bodies import write_disk  # noqa: E402

SCENE = """title = "a rigid disk"
[mesh]
kind = "gmsh"
file = "{mesh}"
[shell]
thickness = 0.05
E = 1.0e8
nu = 0.3
[time]
end = 0.1
dt = 0.1
[fluid]
model = "stokes"
viscosity = 1.0
method = "{method}"
"""

MOTIONS = [
    ((0, 0, 1), (0, 0, 0), 16.0),
    ((1, 0, 0), (0, 0, 0), 32 / 3),
    ((0, 0, 0), (0, 0, 1), 32 / 3),
    ((0, 0, 0), (1, 0, 0), 32 / 3),
]


def measure(mesh: Path, method: str, folder: Path) -> dict:
    from rftfem.integration.simulation import Simulation
    from rftfem.scene.reading import load_scene

    scene = folder / f"{method}.toml"
    scene.write_text(SCENE.format(mesh=mesh, method=method), encoding="utf-8")
    t0 = time.perf_counter()
    stokes = Simulation(load_scene(scene), out_dir=None, quiet=True).model["stokes"]
    t1 = time.perf_counter()
    X = stokes.X
    res = stokes.resistance(X)
    errors = []
    for v, w, exact in MOTIONS:
        velocity = np.asarray(v, float) + np.cross(w, X)
        F = res.solve(velocity.ravel()).reshape(-1, 3)
        force, moment = -F.sum(axis=0), -np.cross(X, F).sum(axis=0)
        errors.append(-(force @ v + moment @ w) / exact - 1)  # the liquid resists
    t2 = time.perf_counter()
    return {"nodes": len(X), "set-up s": t1 - t0, "resistance s": t2 - t1, "errors": errors}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sizes", type=float, nargs="+", default=[0.6, 0.3, 0.2, 0.1])
    parser.add_argument("--methods", nargs="+", default=["layer", "blobs"])
    args = parser.parse_args(argv)
    print(
        "| method | cells | nodes | largest error of the four | broadside, edgewise, spin, "
        "diameter | set-up (s) | resistance and four solves (s) |"
    )
    print("|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        for size in args.sizes:
            mesh = folder / f"disk{size}.msh"
            write_disk(mesh, radius=1.0, size=size)
            for method in args.methods:
                r = measure(mesh, method, folder)
                e = np.array(r["errors"])
                print(
                    f"| {method} | {size} a | {r['nodes']} | {100 * np.abs(e).max():.3g} % | "
                    + ", ".join(f"{100 * x:+.3g} %" for x in e)
                    + f" | {r['set-up s']:.2f} | {r['resistance s']:.2f} |",
                    flush=True,
                )
    return 0


if __name__ == "__main__":
    sys.exit(main())
