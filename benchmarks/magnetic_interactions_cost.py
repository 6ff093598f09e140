"""What the magnetic interactions cost against the number of dipoles, direct and by
fast multipoles.

Two parallel square plates of dipoles 0.2 apart (two groups, N/2 each, a uniform
grid) stand for two magnetized parts summed by ``[magnetic] interactions = true``
(rftfem/model/effects/magnetic_interactions.py: N is the magnetized cells times
the points ``interaction_points`` gives each).  Timed, per N:

- the compiled direct sums of rftfem/model/dipoles.py: the energy's gradient (every
  residual) and the Hessian's product (every GMRES iteration of a Newton update),
  threaded over the targets;
- fmm3dpy's Laplace fast multipole method with dipole sources, giving what the
  gradient needs (the others' field and its gradient at every target, ``pgt = 3``),
  once per group as targets, at the precision ``--eps``.  Its Hessian product would
  need third derivatives, which it does not give (quadrupoles from moved sources).

Printed: the seconds of each per N, the power of N fitted to each, and where the
multipoles start to pay for the gradient alone.  The run's numba threads and the
multipoles' OpenMP threads are both the machine's cores unless NUMBA_NUM_THREADS and
OMP_NUM_THREADS say otherwise.

    .venv/bin/python benchmarks/magnetic_interactions_cost.py            # 1000 … 32 000
    .venv/bin/python benchmarks/magnetic_interactions_cost.py --dipoles 2000 8000 --eps 1e-10
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

from rftfem.model import dipoles  # noqa: E402


def plates(n: int, rng: np.random.Generator):
    """About ``n`` dipoles on two unit square grids 0.2 apart: positions, moments
    (random), groups."""
    side = max(2, int(round(np.sqrt(n / 2))))
    s = np.linspace(0.0, 1.0, side)
    X, Y = (a.ravel() for a in np.meshgrid(s, s))
    x = np.vstack(
        [np.column_stack([X, Y, np.zeros_like(X)]), np.column_stack([X, Y, np.full_like(X, 0.2)])]
    )
    group = np.repeat(np.arange(2, dtype=np.int64), side * side)
    return x, rng.standard_normal(x.shape), group


def best(f, repeat: int = 2) -> float:
    """The shortest of ``repeat`` wall times of ``f()``."""
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        f()
        times.append(time.perf_counter() - t0)
    return min(times)


def multipoles(x, m, group, eps: float):
    """The others' potential gradient and Hessian at every dipole, one call per group."""
    import fmm3dpy

    out = []
    for g in np.unique(group):
        mine = group == g
        out.append(
            fmm3dpy.lfmm3d(
                eps=eps,
                sources=np.ascontiguousarray(x[~mine].T),
                dipvec=np.ascontiguousarray(m[~mine].T),
                targets=np.ascontiguousarray(x[mine].T),
                pgt=3,
            )
        )
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--dipoles", type=int, nargs="+", default=[1000, 2000, 4000, 8000, 16000, 32000]
    )
    parser.add_argument("--eps", type=float, default=1e-6, help="the multipoles' precision")
    args = parser.parse_args(argv)
    rng = np.random.default_rng(0)
    dipoles.warm()  # compiled (or loaded) before the clock starts
    rows = []
    print(f"{'dipoles':>8} {'gradient s':>11} {'Hessian product s':>18} {'multipoles s':>13}")
    for n in args.dipoles:
        x, m, group = plates(n, rng)
        k = len(x)
        G, H, e = np.empty((k, 3)), np.empty((k, 3)), np.empty(k)
        dm, dx = rng.standard_normal((k, 3)), rng.standard_normal((k, 3))
        dG, dH = np.empty((k, 3)), np.empty((k, 3))
        t_grad = best(lambda: dipoles.gradient(m, x, group, 0, k, 1.0, G, H, e))
        t_prod = best(lambda: dipoles.hessian_product(m, x, group, dm, dx, 0, k, 1.0, dG, dH))
        t_fmm = best(lambda: multipoles(x, m, group, args.eps))
        rows.append((k, t_grad, t_prod, t_fmm))
        print(f"{k:8d} {t_grad:11.4f} {t_prod:18.4f} {t_fmm:13.4f}", flush=True)
    a = np.array(rows)
    if len(a) > 1:
        for j, name in enumerate(("gradient", "Hessian product", "multipoles"), start=1):
            slope = np.polyfit(np.log(a[:, 0]), np.log(a[:, j]), 1)[0]
            print(f"exponent of {name}: {slope:.2f}")
        # the power laws of the two largest sizes, extrapolated to where they cross
        (n0, d0, f0), (n1, d1, f1) = a[-2, [0, 1, 3]], a[-1, [0, 1, 3]]
        pd, pf = np.log(d1 / d0) / np.log(n1 / n0), np.log(f1 / f0) / np.log(n1 / n0)
        if d1 >= f1:
            print(f"the multipoles' gradient is cheaper from about {int(n0)} dipoles on")
        elif pd > pf:
            cross = n1 * (f1 / d1) ** (1.0 / (pd - pf))
            print(f"the multipoles' gradient would be cheaper beyond about {cross:.2g} dipoles")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
