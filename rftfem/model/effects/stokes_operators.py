"""The Stokes flow's operators (docs/stokes.md §Two discretisations, §Cost): the
integrated layer on its force grid, the choice of ``fluid.operator`` and the
resistance of one configuration.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from rftfem.errors import SceneError
from rftfem.model import (
    layer_rules,
    stokes_direct,
    stokes_fmm,
    stokes_layer,
    stokes_report,
    stokeslets,
)

if TYPE_CHECKING:
    import numpy as np
    import scipy.sparse as sp
    from mpi4py import MPI

    from rftfem.model.effects.stokes import Stokes
    from rftfem.model.layer_resistance import LayerResistance
    from rftfem.model.stokes_matrix_free import MatrixFreeResistance

#: the most nodes the dense operator is meant for: two 3N × 3N matrices of 1.7 GB
#: at 5000, a Cholesky factorisation of ~1e12 flops a residual
DENSE_NODES = 5000


def grid_layer(
    X: np.ndarray, cells: np.ndarray, cell: str, refine: int, epsilon: float, comm: MPI.Comm
) -> tuple[stokes_layer.Layer, sp.csr_matrix]:
    """The integrated layer on the force grid of ``fluid.refine`` (its rows: this
    process's share) and the grid's interpolation from the shell's nodes."""
    grid, grid_cells, interpolation = layer_rules.refined(X, cells, cell, refine)
    # refused before its rules are made if too large (16 far points an element)
    stokes_report.admit(len(grid), 16 * len(grid_cells) + stokes_report.SPECIAL_POINTS, comm.size)
    size, rank = comm.size, comm.rank  # the grid's rows shared out evenly
    counts = [len(grid) // size + (r < len(grid) % size) for r in range(size)]
    start = int(sum(counts[:rank]))
    layer = stokes_layer.Layer(
        grid, grid_cells, cell, epsilon, rows=slice(start, start + counts[rank])
    )
    smallest = float(layer.size.min())
    if epsilon > 0.5 * smallest:
        raise SceneError(
            f"fluid.regularization: ε = {epsilon:.4g} is over half the force grid's "
            f"smallest element ({smallest:.4g}); collocation then blurs the layer and its "
            "matrix is ill-conditioned: leave the key out (ε = 0, the most accurate) or "
            f"give at most {0.5 * smallest:.3g}"
            + (" (fluid.refine shrinks the grid)" if refine else "")
        )
    return layer, interpolation


def choose_operator(asked: str, nodes: int, method: str) -> str:
    """ "dense", "direct" or "fmm" for ``fluid.operator`` (``auto``: the blobs' direct
    sums above DENSE_NODES nodes, dense below and for the layer)."""
    if asked == "auto":
        big = nodes > DENSE_NODES and method == "blobs"
        return "direct" if big else "dense"
    if asked == "fmm" and not stokes_fmm.available():
        raise SceneError(
            'fluid.operator = "fmm": the fast multipole library (fmm3dpy) '
            'is not installed; run the README\'s set-up, or use operator = "direct"'
        )
    return asked


def dense_warnings(nodes: int, operator: str) -> list[str]:
    """A body of ``nodes`` too large for the dense operator (docs/stokes.md, Cost)."""
    if nodes <= DENSE_NODES or operator in ("direct", "fmm"):
        return []
    gigabytes = 2 * (3 * nodes) ** 2 * 8 / 1e9
    return [
        f'fluid.model = "stokes": {nodes} nodes make a dense operator of '
        f"{gigabytes:.1f} GB, factorised at every residual; the Stokes flow is "
        f"meant for up to {DENSE_NODES} nodes in this version"
    ]


def new_resistance(
    stokes: Stokes, x: np.ndarray, kept: LayerResistance | MatrixFreeResistance | None
) -> LayerResistance | MatrixFreeResistance | stokes_fmm.OnFirst | stokeslets.Resistance:
    """The resistance of the positions ``x`` for the body's method and operator;
    ``kept``: the resistance whose factors the layer's or the direct sums' keep."""
    comm = stokes.model.comm
    if stokes.method == "layer":
        return stokes_layer.LayerResistance(
            stokes.layer,
            x,
            stokes.viscosity,
            stokes.wall,
            comm=comm,
            interpolation=stokes.interpolation,
            kept=kept,
        )
    if stokes.operator == "direct":
        return stokes_direct.DirectResistance(
            x, stokes.delta, stokes.viscosity, stokes.wall, comm, kept=kept
        )
    if stokes.operator == "fmm":
        return stokes_fmm.OnFirst(
            comm,
            x,
            lambda: stokes_fmm.FastResistance(x, stokes.delta, stokes.viscosity, stokes.wall),
        )
    return stokeslets.Resistance(
        x,
        stokes.delta,
        stokes.viscosity,
        stokes.wall,
        comm=comm,
        rows=slice(stokes.offset, stokes.offset + stokes.n_owned),
    )
