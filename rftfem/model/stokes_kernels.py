"""Compiled kernels of the Stokes layer (numba): the regularized Stokeslet, a plane
wall's images and their exact position derivatives, summed over quadrature points
straight into the dense rows of the operator (docs/stokes.md §Cost).

Every sum has the same shape.  A quadrature point ``p`` lies at ``y_p = Σ_a ψ_pa x_a``
on its element (nodes ``nodes[p]``, basis ``psi[p]``, weight ``w_p``), and the
velocity it makes at a target ``x_t`` is ``K(x_t, y_p) w_p Σ_a ψ_pa f_a``, so

    A[t, :, nodes[p, a], :] += w_p ψ_pa K(x_t, y_p),                        (matrix)

and at a fixed density, with ``F_p = w_p Σ_a ψ_pa f_a`` and ``T = ∂(K F_p)``,

    G[t, :, t, :] += ∂(K F_p)/∂x_t,   G[t, :, nodes[p, a], :] += ψ_pa ∂(K F_p)/∂y_p.

The free kernel is ``S_ε(r) F = a F + b (r·F) r`` with ``r = x_t − y_p`` (ε = 0:
the Stokeslet, ``a = 1/r``, ``b = 1/r³``; ε > 0: the Gaussian blob of
``rftfem.model.stokeslets``); the wall's is Blake's image system written out in
closed form in the wall's frame (``rftfem.model.stokes_images``).  With a
wall everything is summed in its frame (the free kernel is the same in any) and
each 3 × 3 block of the rows is turned back once at the end (``from_frame``), not
once per point.  Nothing here
divides by 8πμ; the callers do.

The far rule pairs every target with every point (``far_*``, threaded over the
targets: each thread writes its own rows); the near and singular rules are lists
of (target, point) pairs ordered by target (``pairs_*``, threaded the same way).
"""

from __future__ import annotations

from math import erf, exp, sqrt

import numba as nb
import numpy as np

from rftfem.model import blob_radial
from rftfem.model.stokes_images import image_block, image_gradient

# the blob's radial functions below ρ = 0.3 as series (blob_radial.radial's own)
_S0, _S1, _S2, _S3 = (np.array(c) for c in blob_radial._COEFFS)
_SERIES_BELOW, _STOKESLET_BEYOND = blob_radial._SERIES_BELOW, blob_radial._STOKESLET_BEYOND
_C = 2.0 / sqrt(np.pi)
_JIT = dict(cache=True)


@nb.njit(**_JIT)
def _horner(c, x):
    s = 0.0
    for k in range(len(c) - 1, -1, -1):
        s = s * x + c[k]
    return s


@nb.njit(**_JIT)
def radial(d: float, eps: float) -> tuple[float, float, float, float]:
    """``(a, b, a′/r, b′/r)`` of the free kernel at the distance ``d``."""
    if eps == 0.0 or d > _STOKESLET_BEYOND * eps:
        inv = 1.0 / d
        inv3 = inv * inv * inv
        return inv, inv3, -inv3, -3.0 * inv3 * inv * inv
    r = d / eps
    if r < _SERIES_BELOW:
        f0, f1 = _horner(_S0, r), _horner(_S1, r)
        f2, f3 = _horner(_S2, r), _horner(_S3, r)
    else:
        E = exp(-r * r)
        e = erf(r)
        s1 = e + _C * r * (3 - 2 * r * r) * E
        s2 = e - _C * r * (1 - 2 * r * r) * E
        ds1 = _C * E * (4 - 12 * r * r + 4 * r**4)
        ds2 = _C * E * (8 * r * r - 4 * r**4)
        f0, f1 = s1 / r, s2 / r**3
        f2, f3 = (r * ds1 - s1) / r**3, (r * ds2 - 3 * s2) / r**5
    e3 = eps * eps * eps
    return f0 / eps, f1 / e3, f2 / e3, f3 / (e3 * eps * eps)


@nb.njit(**_JIT)
def free_block(r: np.ndarray, eps: float, out: np.ndarray) -> None:
    """``out = S_ε(r)`` (3 × 3), set (not added)."""
    d = sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2])
    a, b, _, _ = radial(d, eps)
    for i in range(3):
        for k in range(3):
            out[i, k] = b * r[i] * r[k]
        out[i, i] += a


@nb.njit(**_JIT)
def free_gradient(r: np.ndarray, F: np.ndarray, eps: float, out: np.ndarray) -> None:
    """``out = ∂(S_ε(r) F)/∂r`` (3 × 3), set."""
    d = sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2])
    _, b, da, db = radial(d, eps)
    rF = r[0] * F[0] + r[1] * F[1] + r[2] * F[2]
    for i in range(3):
        for m in range(3):
            out[i, m] = da * F[i] * r[m] + db * rF * r[i] * r[m] + b * r[i] * F[m]
        out[i, i] += b * rF


#: a single node's coefficient (:func:`_scatter` of a target's own block)
_ONE = np.ones(1)


@nb.njit(**_JIT)
def _scatter(row, nodes, coeffs, scale, block):
    """``row[:, nodes[a], :] += scale · coeffs[a] · block`` for an element's nodes
    (``row``: one target's (3, N, 3) of the operator or its derivative)."""
    for a in range(len(nodes)):
        j, c = nodes[a], scale * coeffs[a]
        for i in range(3):
            for m in range(3):
                row[i, j, m] += c * block[i, m]


@nb.njit(parallel=True, **_JIT)
def far_matrix(
    targets: np.ndarray,
    y: np.ndarray,
    wpsi: np.ndarray,
    nodes: np.ndarray,
    eps: float,
    free: bool,
    wall: bool,
    out: np.ndarray,
) -> None:
    """``out[t, :, nodes[p, a], :] += wpsi[p, a] K(targets[t], y[p])`` over every
    target and point (``out``: (k, 3, N, 3)); ``K`` is the free kernel if ``free``,
    plus the images of the wall if ``wall``, the wall the plane z = 0 (the callers
    work in its frame: :func:`to_frame`, :func:`from_frame`)."""
    k, q = len(targets), len(y)
    for t in nb.prange(k):
        K = np.empty((3, 3))
        W = np.empty((3, 3))
        r = np.empty(3)
        for p in range(q):
            if free:
                for c in range(3):
                    r[c] = targets[t, c] - y[p, c]
                free_block(r, eps, K)
            else:
                K[:] = 0.0
            if wall:
                image_block(targets[t], y[p], W)
                K += W
            _scatter(out[t], nodes[p], wpsi[p], 1.0, K)


@nb.njit(parallel=True, **_JIT)
def far_derivative(
    targets: np.ndarray,
    target_nodes: np.ndarray,
    y: np.ndarray,
    psi: np.ndarray,
    nodes: np.ndarray,
    F: np.ndarray,
    eps: float,
    free: bool,
    wall: bool,
    out: np.ndarray,
) -> None:
    """The far rule's ``G`` at the weighted point densities ``F`` (q, 3), added to
    ``out`` (k, 3, N, 3); ``target_nodes[t]`` is the node whose position ``targets[t]``
    is; the wall as for :func:`far_matrix`."""
    k, q = len(targets), len(y)
    for t in nb.prange(k):
        T = np.empty((3, 3))
        own = np.zeros((3, 3))
        src = np.empty((3, 3))
        dxi = np.empty((3, 3))
        deta = np.empty((3, 3))
        r = np.empty(3)
        for p in range(q):
            src[:] = 0.0
            if free:
                for c in range(3):
                    r[c] = targets[t, c] - y[p, c]
                free_gradient(r, F[p], eps, T)
                own += T
                src -= T
            if wall:
                image_gradient(targets[t], y[p], F[p], dxi, deta)
                own += dxi
                src += deta
            _scatter(out[t], nodes[p], psi[p], 1.0, src)
        _scatter(out[t], target_nodes[t : t + 1], _ONE, 1.0, own)


def to_frame(Q: np.ndarray, point: np.ndarray | None, x: np.ndarray) -> np.ndarray:
    """Points or forces (…, 3) in the wall's frame: ``Q (x − point)`` (``point`` None:
    vectors, rotated only)."""
    x = np.asarray(x, dtype=float)
    return np.ascontiguousarray((x if point is None else x - point) @ Q.T)


def from_frame(Q: np.ndarray, M: np.ndarray) -> np.ndarray:
    """Rows (k, 3, N, 3) of a matrix or derivative made in the wall's frame, in global
    coordinates: each 3 × 3 block ``Qᵀ M Q`` (velocities and positions both turn)."""
    return np.einsum("ai,tajb,bm->tijm", Q, M, Q, optimize=True)


@nb.njit(parallel=True, **_JIT)
def pairs_matrix(
    x: np.ndarray,
    lo: int,
    starts: np.ndarray,
    psi: np.ndarray,
    weight: np.ndarray,
    nodes: np.ndarray,
    eps: float,
    out: np.ndarray,
) -> None:
    """The near and singular rules: ``out[t − lo, :, nodes[p, a], :] += weight[p] ψ_pa
    S_ε(x_t − y_p)`` (free kernel only) for the points ``p`` of ``starts[t − lo] :
    starts[t − lo + 1]`` (the pairs ordered by target, threaded over the targets)."""
    nd = nodes.shape[1]
    for row in nb.prange(len(starts) - 1):
        t = lo + row
        K = np.empty((3, 3))
        r = np.empty(3)
        for p in range(starts[row], starts[row + 1]):
            for c in range(3):
                s = x[t, c]
                for a in range(nd):
                    s -= psi[p, a] * x[nodes[p, a], c]
                r[c] = s
            free_block(r, eps, K)
            _scatter(out[row], nodes[p], psi[p], weight[p], K)


@nb.njit(parallel=True, **_JIT)
def pairs_derivative(
    x: np.ndarray,
    f: np.ndarray,
    lo: int,
    starts: np.ndarray,
    psi: np.ndarray,
    weight: np.ndarray,
    nodes: np.ndarray,
    eps: float,
    out: np.ndarray,
) -> None:
    """The near and singular rules' part of ``G`` at the nodal density ``f`` (N, 3),
    the pairs ordered by target as for :func:`pairs_matrix`."""
    nd = nodes.shape[1]
    x_index = np.arange(len(x))
    for row in nb.prange(len(starts) - 1):
        t = lo + row
        T = np.empty((3, 3))
        own = np.zeros((3, 3))
        r = np.empty(3)
        F = np.empty(3)
        for p in range(starts[row], starts[row + 1]):
            for c in range(3):
                s = x[t, c]
                v = 0.0
                for a in range(nd):
                    s -= psi[p, a] * x[nodes[p, a], c]
                    v += psi[p, a] * f[nodes[p, a], c]
                r[c] = s
                F[c] = weight[p] * v
            free_gradient(r, F, eps, T)
            own += T
            _scatter(out[row], nodes[p], psi[p], -1.0, T)
        _scatter(out[row], x_index[t : t + 1], _ONE, 1.0, own)


def warm() -> None:
    """Compile (or load from numba's cache) every kernel, on a few points."""
    x = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 1.0]])
    y = np.array([[0.5, 0.5, 1.5], [1.5, 0.5, 1.5]])
    psi, nodes, w = np.ones((2, 1)), np.array([[1], [0]], dtype=np.int64), np.ones(2)
    out = np.zeros((2, 3, 2, 3))
    far_matrix(x, y, psi, nodes, 0.0, True, True, out)
    far_derivative(x, np.arange(2), y, psi, nodes, x, 0.0, True, True, out)
    starts = np.array([0, 1, 2], dtype=np.int64)
    pairs_matrix(x, 0, starts, psi, w, nodes, 0.0, out)
    pairs_derivative(x, x, 0, starts, psi, w, nodes, 0.0, out)


def pair_seconds() -> float:
    """Seconds per (target, quadrature point) pair of :func:`far_matrix` on this machine
    (second-order elements; measured on 96 targets × 768 points, once compiled)."""
    import time

    rng = np.random.default_rng(0)
    targets, y = rng.random((96, 3)), rng.random((768, 3)) + 2.0
    nodes = rng.integers(0, 96, (768, 9))
    wpsi = rng.random((768, 9))
    out = np.zeros((96, 3, 96, 3))
    warm()
    t0 = time.perf_counter()
    far_matrix(targets, y, wpsi, nodes, 0.0, True, False, out)
    return (time.perf_counter() - t0) / (96 * 768)


@nb.njit(parallel=True, **_JIT)
def edge_distance(y: np.ndarray, P: np.ndarray, t: np.ndarray) -> np.ndarray:
    """The distance of each point ``y[p]`` to the nearest of its candidate free edges,
    quadratic curves through ``P[p, c]`` (start, middle, end), by Newton's method on
    ``|c(t) − y|²`` from the parameters ``t[p, c]`` (a chord's projection; four
    updates reach round-off), ``t`` kept in [0, 1]."""
    n, k = t.shape
    out = np.empty(n)
    for p in nb.prange(n):
        best = np.inf
        for c in range(k):
            s = t[p, c]
            for it in range(5):
                N0, N1, N2 = (1 - s) * (1 - 2 * s), 4 * s * (1 - s), s * (2 * s - 1)
                g = 0.0
                h = 0.0
                d2 = 0.0
                for j in range(3):
                    r = N0 * P[p, c, 0, j] + N1 * P[p, c, 1, j] + N2 * P[p, c, 2, j] - y[p, j]
                    d2 += r * r
                    if it == 4:
                        continue
                    dc = (
                        (4 * s - 3) * P[p, c, 0, j]
                        + (4 - 8 * s) * P[p, c, 1, j]
                        + (4 * s - 1) * P[p, c, 2, j]
                    )
                    ddc = 4 * P[p, c, 0, j] - 8 * P[p, c, 1, j] + 4 * P[p, c, 2, j]
                    g += r * dc
                    h += dc * dc + r * ddc
                if it < 4:
                    s = min(max(s - g / (h if h > 0 else 1.0), 0.0), 1.0)
            best = min(best, d2)
        out[p] = sqrt(best)
    return out
