"""What the Stokes flow's discretisation costs and how wrong it is (``rftfem check``,
summary.json's ``fluid``; docs/stokes.md §The error shown).

The estimate is the body's rigid resistance at the scene's ``fluid.refine`` against
the next level, at the reference positions: six unit rigid motions about the
centroid (rotations scaled by the body's size, so that all six move it at unit
speed) give the 6 × 6 matrix ``R`` of the power they dissipate, and the estimate is
the largest relative change of that power over all rigid motions,

    e = max |λ|,   (R_r − R_{r+1}) q = λ R_{r+1} q,

unit-free and blind to no direction (a small edgewise drag counts as much as the
broadside one).  It measures the force grid's and the quadrature's error, not the
shell mesh's geometry.
"""

from __future__ import annotations

import os
import time
from typing import TYPE_CHECKING

import numpy as np

from rftfem.errors import SceneError
from rftfem.model import dense_factors, layer_rules, stokes_layer

if TYPE_CHECKING:
    from rftfem.model import stokeslets
    from rftfem.model.effects.stokes import Stokes

#: a run whose estimate exceeds this warns
WARN_ABOVE = 0.05
#: the next level is not built beyond this many grid nodes (its dense matrix)
ESTIMATE_NODES = 5000
#: a scene whose step is estimated to take longer than this is refused (seconds)
LONGEST_STEP = 3600.0
#: Newton updates a step takes, for that estimate (1 to 3 on the shipped scenes)
UPDATES_A_STEP = 2
#: near and singular quadrature points a grid node adds to its row (the rules'
#: count on the shipped meshes: 580 to 640)
SPECIAL_POINTS = 640


def machine_memory() -> int:
    """The machine's memory in bytes (0 if unknown)."""
    try:
        return int(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))
    except (ValueError, OSError, AttributeError):
        return 0


def _rates() -> tuple[float, float]:
    """This machine's dense LU rate (flop/s, a 1000 × 1000 factorisation) and seconds
    per (target, quadrature point) pair of the compiled kernel, measured once."""
    global _MEASURED
    if _MEASURED is None:
        import scipy.linalg as sl

        from rftfem.model import stokes_kernels

        a = np.random.default_rng(0).random((1000, 1000)) + 1000 * np.eye(1000)
        t0 = time.perf_counter()
        sl.lu_factor(a, overwrite_a=True, check_finite=False)
        lu = (2 / 3) * 1000**3 / max(time.perf_counter() - t0, 1e-6)
        pair = stokes_kernels.pair_seconds()
        _MEASURED = (lu, pair)
    return _MEASURED


_MEASURED = None


def admit(
    rows: int, points_a_row: float, processes: int, method: str = "layer"
) -> tuple[float, float | None]:
    """Refuse a dense Stokes operator that would not fit in the machine's memory or whose
    step would take over LONGEST_STEP, with the numbers and what to change.  ``rows``:
    the grid's nodes (the blobs': the shell's); ``points_a_row``: quadrature points each
    row sums over (the layer)."""
    n3 = 3 * rows
    if dense_factors.shared(processes, n3):
        # each process's share of: its rows, their copy handed to ScaLAPACK, the
        # factors, the layer's kept factors, the derivative's rows
        memory = 8 * n3 * n3 * (5 if method == "layer" else 4) / processes
    else:
        # on every process the matrix (and the layer's kept factors), the
        # derivative's share of rows
        memory = 8 * n3 * n3 * ((2 if method == "layer" else 1) + 1 / processes)
    have = machine_memory()
    change = (
        "a coarser mesh"
        + (" or a lower fluid.refine" if method == "layer" else "")
        + ', or fluid.method = "blobs" with operator = "direct" (matrix-free, memory O(N))'
    )
    if have and memory > have:
        raise SceneError(
            f"fluid: the dense Stokes operator of {rows} nodes needs "
            f"{memory / 1e9:.3g} GB on each process, over this machine's "
            f"{have / 1e9:.3g} GB: use {change}"
        )
    if n3 < 6000:  # (at most seconds a step on any machine: not measured)
        return memory, None
    factor, kernel = update_cost(rows, points_a_row, processes, method)
    step = UPDATES_A_STEP * (factor + kernel)
    if step > LONGEST_STEP:
        raise SceneError(
            f"fluid: a step of the dense Stokes operator of {rows} nodes would "
            f"take about {step / 3600:.3g} h on this machine (a factorisation of "
            f"{factor:.3g} s and kernels of {kernel:.3g} s a Newton update, "
            f"{UPDATES_A_STEP} updates a step): use {change}"
        )
    return memory, step


def update_cost(
    rows: int, points_a_row: float, processes: int, method: str = "layer"
) -> tuple[float, float]:
    """The seconds of a Newton update that factorises, on this machine's measured
    rates: ``(factorisation, kernels)`` (the matrix and its derivative)."""
    lu, pair = _rates()
    factor = (2 / 3 if method == "layer" else 1 / 3) * (3 * rows) ** 3 / lu
    if dense_factors.shared(processes, 3 * rows):
        factor /= processes  # (ScaLAPACK: 1.7 to 1.8 times faster on two processes)
    return factor, 2.5 * rows * points_a_row * pair / processes


def rigid_motions(X: np.ndarray) -> np.ndarray:
    """The six unit rigid velocity fields (6, N, 3) about the centroid of ``X``."""
    c = X.mean(axis=0)
    size = float(np.linalg.norm(np.ptp(X, axis=0))) / 2 or 1.0
    out = np.zeros((6, len(X), 3))
    for k in range(3):
        out[k, :, k] = 1.0
        out[3 + k] = np.cross(np.eye(3)[k], X - c) / size
    return out


def rigid_resistance(
    resistance: stokes_layer.LayerResistance | stokeslets.Resistance, X: np.ndarray
) -> np.ndarray:
    """``R_jk = Σ v_j · F(v_k)`` (6 × 6, symmetrised) of a factorised resistance."""
    V = rigid_motions(X)
    F = resistance.solve(V.reshape(6, -1).T).T  # (6, 3N)
    R = V.reshape(6, -1) @ F.T
    return 0.5 * (R + R.T)


def relative_change(coarse: np.ndarray, fine: np.ndarray) -> float:
    """``max |λ|`` of ``(coarse − fine) q = λ fine q``."""
    import scipy.linalg as sl

    return float(np.abs(sl.eigh(coarse - fine, fine, eigvals_only=True)).max())


def describe(stokes: Stokes) -> dict:
    """The discretisation of a Stokes component: sizes, cost and estimated error."""
    if getattr(stokes, "_description", None) is not None:
        return stokes._description
    out = {
        "model": "stokes",
        "method": stokes.method,
        "operator": stokes.operator,
        "nodes": int(len(stokes.X)),
    }
    if stokes.method == "blobs":
        uniform = stokes.settings.regularization is not None
        out.update(
            {
                "memory_bytes": blob_memory(stokes.operator, len(stokes.X)),
                "regularization": float(stokes.delta[0]) if uniform else "node spacing",
                "estimated_error": None,
                "estimate_from": 'not estimated for method = "blobs" (first order in the '
                "spacing: refine the mesh; docs/stokes.md)",
            }
        )
        stokes._description = out
        return out
    comm = stokes.model.comm
    grid = len(stokes.layer.X)
    points = comm.allreduce(stokes.layer.quadrature_points) - (comm.size - 1) * len(
        stokes.layer.far.weight
    )
    out.update(
        {
            "refine": stokes.refine,
            "grid_nodes": grid,
            "quadrature_points": int(points),
            "epsilon": stokes.epsilon,
            # the operator, its factors (kept: beside the next operator), derivative
            "memory_bytes": int(72 * grid**2 * (3 if stokes.keep_factors else 2)),
        }
    )
    value = None
    if comm.rank == 0:
        value = _estimate(stokes)
    out.update(comm.bcast(value, root=0) if comm.size > 1 else value)
    stokes._description = out
    return out


def _estimate(stokes) -> dict:
    """The timing of one Newton update's liquid and the estimate against the next
    level (on this process alone)."""
    from rftfem.model import stokes_kernels

    stokes_kernels.warm()  # (not timed: compiled or loaded once a process)
    X = stokes.X
    level = stokes.refine + 1
    nodes = len(layer_rules.refined(X, stokes.shell_cells, stokes.cell, level)[0])
    if nodes > ESTIMATE_NODES:  # no estimate: the update's time from the rates, not a
        # factorisation made for it (minutes at a few thousand nodes)
        layer = stokes.layer
        points = len(layer.far.weight) + SPECIAL_POINTS
        factor, kernel = update_cost(len(layer.X), points, stokes.model.comm.size)
        return {
            "seconds_per_update": factor + kernel,
            "estimated_error": None,
            "estimate_from": f"not estimated: fluid.refine = {level} would have "
            f"{nodes} grid nodes (over {ESTIMATE_NODES})",
        }
    t0 = time.perf_counter()
    res = stokes_layer.LayerResistance(
        stokes._serial_layer(stokes.refine),
        X,
        stokes.viscosity,
        stokes.wall,
        interpolation=stokes.interpolation,
    )
    t1 = time.perf_counter()
    R = rigid_resistance(res, X)
    F = res.solve(rigid_motions(X)[0].ravel())
    t2 = time.perf_counter()
    G = res.position_operator(F)
    du = np.ones(F.size)
    t3 = time.perf_counter()
    res.tangent(du, 1.0, G)
    t4 = time.perf_counter()
    # a Newton update: a residual and a tangent (matrix and factors, the derivative),
    # and some ten products in the Krylov solver (docs/stokes.md)
    update = (t1 - t0) + (t3 - t2) + 10 * (t4 - t3)
    out = {"seconds_per_update": update}
    fine_layer = stokes._serial_layer(level)
    _, _, I = layer_rules.refined(X, stokes.shell_cells, stokes.cell, level)
    fine = stokes_layer.LayerResistance(
        fine_layer, X, stokes.viscosity, stokes.wall, interpolation=I
    )
    out.update(
        {
            "estimated_error": relative_change(R, rigid_resistance(fine, X)),
            "estimate_from": f"the rigid resistance at fluid.refine = {stokes.refine} "
            f"against {level} ({nodes} grid nodes)",
        }
    )
    return out


def blob_memory(operator: str, nodes: int) -> int:
    """Bytes the blobs' operator holds: dense, the mobility's factors and the position
    derivative (72 N² each); matrix-free, the clusters' factors (one of the whole body
    up to ``stokes_matrix_free.WHOLE_UP_TO`` nodes)."""
    from rftfem.model import stokes_matrix_free as mf

    if operator == "dense":
        return 144 * nodes**2
    largest = nodes if nodes <= mf.WHOLE_UP_TO else min(nodes, mf.CLUSTER_NODES)
    return 72 * largest * nodes


def check_lines(d: dict) -> list[str]:
    """``rftfem check``'s lines for a Stokes description."""
    if d["method"] == "blobs":
        return [
            f"fluid: blobs at {d['nodes']} nodes, {d['operator']} operator, "
            f"{d['memory_bytes'] / 1e6:.3g} MB; {d['estimate_from']}"
        ]
    lines = [
        f"fluid: integrated layer, {d['nodes']} shell nodes, force grid of "
        f"{d['grid_nodes']} nodes (fluid.refine = {d['refine']}), "
        f"{d['quadrature_points']} quadrature points, ε = {d['epsilon']:.3g}",
        f"fluid: {d['operator']} operator, {d['memory_bytes'] / 1e6:.3g} MB; about "
        f"{d['seconds_per_update']:.2g} s of liquid a Newton update that factorises "
        "(a step takes 1–3 updates; kept factors make most of them cheaper)",
    ]
    if d["estimated_error"] is None:
        lines.append(f"fluid: {d['estimate_from']}")
    else:
        lines.append(
            f"fluid: estimated discretisation error {100 * d['estimated_error']:.2g} % "
            f"({d['estimate_from']})"
        )
    return lines


def warnings(d: dict) -> list[str]:
    """A warning when the estimate exceeds WARN_ABOVE."""
    e = d.get("estimated_error")
    if e is None or e <= WARN_ABOVE:
        return []
    return [
        f"fluid: the liquid's estimated discretisation error is {100 * e:.3g} % (over "
        f"{100 * WARN_ABOVE:g} %, {d['estimate_from']}): raise fluid.refine or refine "
        "the mesh"
    ]
