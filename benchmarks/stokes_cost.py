"""What the Stokes operator costs against the number of nodes, dense and matrix-free.

For a flat square plate of N nodes (a uniform grid, the blob its spacing) it
times the three pieces of a Newton iteration with ``[fluid] model = "stokes"``
(rftfem/model/stokeslets.py): building the 3N × 3N mobility and its Cholesky
factorisation (every residual at new positions; under mpirun each process its
rows, the processes factorising together), the position derivative G
(every tangent), and one tangent product (every GMRES iteration). Printed: the
seconds of each per N, and the exponent of a power law fitted over the sizes.

With ``--fast`` it times the matrix-free operator instead (``[fluid] operator =
"fmm"``, rftfem/model/stokes_fmm.py; with ``--direct`` the compiled direct sums of
``operator = "direct"``, rftfem/model/stokes_direct.py; ``--wall`` adds a plane
wall below the plate to either): setting it up at new positions (near pairs and the
clusters' Cholesky factors), one product M F (one fast multipole call), one solve
M⁻¹ v by preconditioned conjugate gradients (a residual; its iterations printed),
and the position derivative (set up once per tangent, then one product per GMRES
iteration).  A tangent product is a solve plus a G product.

    .venv/bin/python benchmarks/stokes_cost.py                 # dense, 500 … 3000 nodes
    .venv/bin/python benchmarks/stokes_cost.py --nodes 500 1000 2000
    .venv/bin/python benchmarks/stokes_cost.py --fast          # 500 … 20 000 nodes
    .venv/bin/python benchmarks/stokes_cost.py --direct --wall # the same, direct sums
    mpirun -n 2 .venv/bin/python benchmarks/stokes_cost.py     # the dense kernel by rows

The fast multipole library runs threaded: set OMP_NUM_THREADS to fix the threads.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))
import repository_python  # noqa: E402

repository_python.ensure()

import numpy as np  # noqa: E402

from rftfem.model import stokeslets  # noqa: E402


def plate(n: int):
    """About ``n`` nodes on a unit square grid in the XY plane, and their spacing."""
    side = max(2, int(round(np.sqrt(n))))
    s = np.linspace(0.0, 1.0, side)
    X, Y = np.meshgrid(s, s)
    x = np.column_stack([X.ravel(), Y.ravel(), np.zeros(side * side)])
    return x, s[1] - s[0]


def best(f, repeat: int = 2, comm=None) -> float:
    """The shortest of ``repeat`` wall times of ``f()`` (the slowest process's)."""
    times = []
    for _ in range(repeat):
        if comm is not None:
            comm.Barrier()
        t0 = time.perf_counter()
        f()
        if comm is not None:
            comm.Barrier()
        times.append(time.perf_counter() - t0)
    return min(times)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--nodes", type=int, nargs="+")
    parser.add_argument(
        "--fast",
        action="store_true",
        help="the matrix-free operator (fast multipoles) instead of the dense one",
    )
    parser.add_argument(
        "--direct", action="store_true", help="the matrix-free direct sums (operator = direct)"
    )
    parser.add_argument("--wall", action="store_true", help="with --fast or --direct: a wall below")
    args = parser.parse_args(argv)
    if args.fast or args.direct:
        sizes = args.nodes or [500, 1000, 2000, 5000, 10000, 20000]
        return fast(sizes, direct=args.direct, wall=args.wall)
    args.nodes = args.nodes or [500, 1000, 2000, 3000]
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    say = print if comm.rank == 0 else (lambda *a, **k: None)
    rng = np.random.default_rng(0)
    rows = []
    say(f"{comm.size} process(es)")
    say(f"{'nodes':>6} {'mobility+Cholesky s':>20} {'G s':>8} {'product s':>10}")
    for n in args.nodes:
        x, h = plate(n)
        delta = np.full(len(x), h)
        F = rng.standard_normal((len(x), 3))
        du = rng.standard_normal(3 * len(x))
        # each process evaluates the kernel on its share of the rows (as a run does)
        cut = np.linspace(0, len(x), comm.size + 1).astype(int)
        mine = slice(int(cut[comm.rank]), int(cut[comm.rank + 1]))
        res = G = None

        def factor():
            nonlocal res
            res = stokeslets.Resistance(x, delta, 1.0, comm=comm, rows=mine)

        def derivative():
            nonlocal G
            G = res.position_operator(F)

        t_factor = best(factor, comm=comm)
        t_g = best(derivative, comm=comm)
        t_prod = best(lambda: res.solve(du - G @ du), repeat=5, comm=comm)
        rows.append((len(x), t_factor, t_g, t_prod))
        say(f"{len(x):6d} {t_factor:20.3f} {t_g:8.3f} {t_prod:10.4f}", flush=True)
    if comm.rank == 0:
        exponents(rows, ["mobility+Cholesky", "G", "product"])
    return 0


def exponents(rows, names):
    """The power of N fitted to each column over the sizes (printed)."""
    if len(rows) < 2:
        return
    a = np.array(rows, dtype=float)
    for k, name in enumerate(names, start=1):
        slope = np.polyfit(np.log(a[:, 0]), np.log(a[:, k]), 1)[0]
        print(f"exponent of {name}: {slope:.2f}")


def fast(sizes, direct: bool = False, wall: bool = False) -> int:
    """The matrix-free operator's pieces per N (the plate's free edges keep half blobs):
    fast multipoles or the direct sums, with a wall 0.3 below the plate if ``wall``."""
    from rftfem.model import stokes_direct, stokes_fmm

    plane = stokeslets.Wall([0.0, 0.0, -0.3], [0.0, 0.0, 1.0]) if wall else None
    if direct:
        stokes_direct.warm()  # compiled (or loaded) before the clock starts

    rng = np.random.default_rng(0)
    rows = []
    print(
        f"{'nodes':>6} {'set-up s':>9} {'M F s':>7} {'solve s':>8} {'CG its':>6} "
        f"{'G set-up s':>10} {'G dx s':>7} {'vs dense':>9}"
    )
    for n in sizes:
        x, h = plate(n)
        x[:, 2] = 0.02 * np.sin(3.0 * x[:, 0])  # not exactly flat
        delta = np.full(len(x), h)
        edge = np.isclose(x[:, :2], 0.0).any(axis=1) | np.isclose(x[:, :2], 1.0).any(axis=1)
        delta[edge] *= 0.5
        v = rng.standard_normal(3 * len(x))
        t0 = time.perf_counter()
        if direct:
            res = stokes_direct.DirectResistance(x, delta, 1.0, plane)
        else:
            res = stokes_fmm.FastResistance(x, delta, 1.0, plane)
        t_setup = time.perf_counter() - t0
        t_apply = best(lambda: res.apply(v), repeat=1)
        t0 = time.perf_counter()
        F = res.solve(v)
        t_solve = time.perf_counter() - t0
        t0 = time.perf_counter()
        G = res.position_operator(F)
        t_gset = time.perf_counter() - t0
        t_g = best(lambda: G @ v, repeat=1)
        check = ""
        if len(x) <= 2100:  # against the dense Cholesky
            dense = stokeslets.Resistance(x, delta, 1.0, plane).solve(v)
            check = f"{np.linalg.norm(F - dense) / np.linalg.norm(dense):9.1e}"
        rows.append((len(x), t_setup, t_apply, t_solve, t_gset, t_g))
        print(
            f"{len(x):6d} {t_setup:9.2f} {t_apply:7.3f} {t_solve:8.2f} "
            f"{res.history[-1]:6d} {t_gset:10.2f} {t_g:7.3f} {check}",
            flush=True,
        )
    names = ["set-up", "M F", "solve", "G set-up", "G dx"]
    # a body of up to WHOLE_UP_TO nodes is one cluster, factorised whole (a direct
    # solve); larger ones are conjugate gradients on clusters: fitted apart
    from rftfem.model.stokes_matrix_free import WHOLE_UP_TO

    for label, part in (
        (f"one cluster (up to {WHOLE_UP_TO} nodes)", [r for r in rows if r[0] <= WHOLE_UP_TO]),
        ("clusters (conjugate gradients)", [r for r in rows if r[0] > WHOLE_UP_TO]),
    ):
        if len(part) > 1:
            print(label + ":")
            exponents(part, names)
    return 0


if __name__ == "__main__":
    sys.exit(main())
