"""What the dense Stokes operator costs against the number of nodes.

For a flat square plate of N nodes (a uniform grid, the blob its spacing) it
times the three pieces of a Newton iteration with ``[fluid] model = "stokes"``
(rftfem/stokeslets.py): building the 3N × 3N mobility and its Cholesky
factorisation (every residual at new positions), the position derivative G
(every tangent), and one tangent product (every GMRES iteration). Printed: the
seconds of each per N, and the exponent of a power law fitted over the sizes.

    .venv/bin/python benchmarks/stokes_cost.py                 # 500 … 3000 nodes
    .venv/bin/python benchmarks/stokes_cost.py --nodes 500 1000 2000

The dense operator is meant for up to a few thousand nodes; the fast multipole
path for larger bodies is not in this version.
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

from rftfem import stokeslets  # noqa: E402


def plate(n: int):
    """About ``n`` nodes on a unit square grid in the XY plane, and their spacing."""
    side = max(2, int(round(np.sqrt(n))))
    s = np.linspace(0.0, 1.0, side)
    X, Y = np.meshgrid(s, s)
    x = np.column_stack([X.ravel(), Y.ravel(), np.zeros(side * side)])
    return x, s[1] - s[0]


def best(f, repeat: int = 2) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        f()
        times.append(time.perf_counter() - t0)
    return min(times)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--nodes", type=int, nargs="+", default=[500, 1000, 2000, 3000])
    args = parser.parse_args(argv)
    rng = np.random.default_rng(0)
    rows = []
    print(f"{'nodes':>6} {'mobility+Cholesky s':>20} {'G s':>8} {'product s':>10}")
    for n in args.nodes:
        x, h = plate(n)
        delta = np.full(len(x), h)
        F = rng.standard_normal((len(x), 3))
        du = rng.standard_normal(3 * len(x))
        res = None

        def factor():
            nonlocal res
            res = stokeslets.Resistance(x, delta, 1.0)

        t_factor = best(factor)
        G = None

        def derivative():
            nonlocal G
            G = stokeslets.position_derivative(x, delta, 1.0, F)

        t_g = best(derivative)
        t_prod = best(lambda: res.solve(du - G @ du), repeat=5)
        rows.append((len(x), t_factor, t_g, t_prod))
        print(f"{len(x):6d} {t_factor:20.3f} {t_g:8.3f} {t_prod:10.4f}", flush=True)
    if len(rows) >= 2:
        a = np.array(rows)
        for k, name in ((1, "mobility+Cholesky"), (2, "G"), (3, "product")):
            slope = np.polyfit(np.log(a[:, 0]), np.log(a[:, k]), 1)[0]
            print(f"exponent of {name}: {slope:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
