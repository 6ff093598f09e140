"""Two ways to solve a Newton update of a body in Stokes flow on clusters, counted.

The matrix-free blobs above 6000 nodes (``[fluid] operator = "direct"``,
rftfem/model/stokes_matrix_free.py) solve a Newton update ``(K + T) du = b``, with
``T = s M⁻¹ (c_v − G)`` the liquid's tangent, by GMRES on that operator
preconditioned by ``K + D`` (``D`` the liquid's lumped nodal blocks): every GMRES
iteration is a conjugate-gradient solve with ``M`` (nested).  The alternative keeps
the forces' increment ``dF`` as unknowns beside ``du``,

    [ K − D    Eᵀ ] [du]   [b]
    [ −s C E   M  ] [dF] = [0],     C = c_v − G,  E: the nodes' displacements,

solved by one GMRES with the block-triangular preconditioner ``[[K, Eᵀ], [0, M_B]]``
(``M_B``: the clusters' inverses of the conjugate gradients, ``K``'s factors): one
``M`` and one ``G`` product an iteration, no nested solve.

This script runs the swimming sheet in Stokes flow as blobs on clusters (forced
below 6000 nodes), stops at a Newton update of its first step, takes that update's
operators, and solves one right-hand side both ways to 1e-10, printing the
iterations and products of each (a ``G`` product costs about two ``M`` products).

    .venv/bin/python benchmarks/stokes_newton_forms.py                  # 20 × 4, clusters of 80
    .venv/bin/python benchmarks/stokes_newton_forms.py --divisions 40 8 --cluster 200
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts"))
import repository_python  # noqa: E402

repository_python.ensure()

import numpy as np  # noqa: E402
import scipy.sparse as sp  # noqa: E402
import scipy.sparse.linalg as spla  # noqa: E402


class _Stop(Exception):
    pass


def _operators(divisions, cluster: int, which: int):
    """The coupled tangent of the run at its ``which``-th tangent."""
    from rftfem.integration import coupled
    from rftfem.integration.simulation import Simulation
    from rftfem.model import stokes_matrix_free
    from rftfem.scene.reading import load_scene

    stokes_matrix_free.WHOLE_UP_TO = 0  # clusters at any size
    stokes_matrix_free.CLUSTER_NODES = cluster
    real, seen = coupled.CoupledTangent.update, {}

    def update(self, exact=False):
        real(self, exact)
        seen["n"] = seen.get("n", 0) + 1
        if seen["n"] == which:
            seen["tangent"] = self
            raise _Stop

    coupled.CoupledTangent.update = update
    sets = [
        "--unset fluid.drag",
        'fluid.model="stokes"',
        "fluid.viscosity=1.0e-9",
        'fluid.method="blobs"',
        'fluid.operator="direct"',
        f"mesh.divisions=[{divisions[0]},{divisions[1]}]",
        'time.until="end"',
    ]
    scene = load_scene(ROOT / "demos" / "swimming_sheet.toml", sets)
    try:
        Simulation(scene, out_dir=None, quiet=True).run()
    except _Stop:
        pass
    finally:
        coupled.CoupledTangent.update = real
    return seen["tangent"]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--divisions", type=int, nargs=2, default=[20, 4])
    parser.add_argument("--cluster", type=int, default=80, help="nodes per cluster")
    parser.add_argument("--update", type=int, default=6, help="which tangent to take")
    args = parser.parse_args(argv)
    c = _operators(args.divisions, args.cluster, args.update)
    tangent = c.components[0]._tangent
    res, cv, G, s = tangent.resistance, tangent.cv, tangent.G, tangent.scale
    ai, aj, av = c.A.getValuesCSR()
    A = sp.csr_matrix((av, aj, ai), shape=c.A.getSize())  # K + D (one process)
    n, N, block = A.shape[0], res.n, c.block
    cols = np.asarray(c.unknowns[0])
    pairs = [
        (3 * i + k, block * i + comp)
        for i in range(N)
        for k, comp in enumerate(cols)
        if c.free[i, comp]
    ]
    r, q = np.array(pairs).T
    E = sp.csr_matrix((np.ones(len(r)), (r, q)), shape=(3 * N, n))
    D = E.T @ sp.block_diag(list(s * cv * res.lumped()), format="csr") @ E
    lu = spla.splu(A.tocsc())
    b = np.random.default_rng(0).standard_normal(n) * (np.abs(A.diagonal()) > 0)
    counts = {"cg": 0, "products": 0}

    def T(du):
        before = len(res.history)
        out = s * res.solve(cv * (E @ du) - G @ (E @ du), tolerance=1e-10)
        counts["cg"] += sum(res.history[before:])
        return E.T @ out

    def solve(op, rhs, prec, restart):
        its = [0]
        t0 = time.perf_counter()
        x, _ = spla.gmres(
            op,
            rhs,
            M=prec,
            tol=1e-10,
            restart=restart,
            maxiter=3,
            callback=lambda _: its.__setitem__(0, its[0] + 1),
            callback_type="pr_norm",
        )
        return x, its[0], time.perf_counter() - t0

    J = spla.LinearOperator((n, n), matvec=lambda x: A @ x - D @ x + T(x))
    x_nested, its, wall = solve(J, b, spla.LinearOperator((n, n), matvec=lu.solve), 300)
    print(f"{N} nodes, {len(res.clusters)} clusters")
    print(f"nested: {its} GMRES iterations, {counts['cg']} M products in their CG, {wall:.1f} s")

    def augmented(z):
        du, dF = z[:n], z[n:]
        Edu = E @ du
        counts["products"] += 1
        return np.concatenate(
            [A @ du - D @ du + E.T @ dF, res.apply(dF) - s * (cv * Edu - G @ Edu)]
        )

    def block_preconditioner(rhs):
        z2 = res._precondition(rhs[n:])
        return np.concatenate([lu.solve(rhs[:n] - E.T @ z2), z2])

    size = (n + 3 * N,) * 2
    z, its, wall = solve(
        spla.LinearOperator(size, matvec=augmented),
        np.concatenate([b, np.zeros(3 * N)]),
        spla.LinearOperator(size, matvec=block_preconditioner),
        500,
    )
    off = np.linalg.norm(z[:n] - x_nested) / np.linalg.norm(x_nested)
    print(
        f"forces as unknowns: {its} GMRES iterations, {counts['products']} M and G products, "
        f"{wall:.1f} s; du {off:.1e} from the nested one"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
