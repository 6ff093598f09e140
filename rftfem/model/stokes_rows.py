"""The blobs' dense operator by rows, compiled (``fluid.operator = "dense"``,
docs/stokes.md §Cost and scale): the rows of the target nodes ``lo … hi`` of

    M_ij = S_δij(x_i − x_j) / (8πμ),
    G_ij = −T_ij (j ≠ i),   G_ii = Σ_j T_ij,   T_ij = ∂(S_δij(r) F_j)/∂r / (8πμ),

the same numbers as ``rftfem.model.stokeslets.mobility`` and
``stokeslets.position_derivative`` (numpy, kept as their reference) from the
kernels the direct sums and the layer compile (``rftfem.model.stokes_kernels``),
threaded over the targets.  The wall's images are added by ``stokeslets.Wall``.
"""

from __future__ import annotations

from math import pi, sqrt

import numba as nb
import numpy as np

from rftfem.model import stokes_kernels as kernels
from rftfem.model.stokes_direct import _mobility_matrix
from rftfem.model.stokeslets import _bounds

_JIT = dict(cache=True)


def mobility_rows(
    x: np.ndarray, delta: np.ndarray, viscosity: float, rows: slice | None = None
) -> np.ndarray:
    """The free mobility's rows of the targets ``rows`` (all by default), ``3k × 3N``."""
    x = np.ascontiguousarray(x, dtype=float)
    lo, hi = _bounds(rows, len(x))
    out = np.empty((hi - lo, 3, len(x), 3))
    delta = np.ascontiguousarray(delta, dtype=float)
    _mobility_matrix(x, delta, False, np.eye(3), lo, hi, out)
    out /= 8 * pi * viscosity
    return out.reshape(3 * (hi - lo), -1)


def derivative_rows(
    x: np.ndarray,
    delta: np.ndarray,
    viscosity: float,
    forces: np.ndarray,
    rows: slice | None = None,
) -> np.ndarray:
    """The free position derivative's rows at the fixed ``forces``, ``3k × 3N``."""
    x = np.ascontiguousarray(x, dtype=float)
    F = np.ascontiguousarray(np.reshape(forces, (-1, 3)), dtype=float)
    lo, hi = _bounds(rows, len(x))
    out = np.empty((hi - lo, 3, len(x), 3))
    delta = np.ascontiguousarray(delta, dtype=float)
    _derivative_matrix(x, delta, F, lo, hi, out)
    out /= 8 * pi * viscosity
    return out.reshape(3 * (hi - lo), -1)


@nb.njit(parallel=True, **_JIT)
def _derivative_matrix(x, delta, F, lo, hi, out):
    """``out[t − lo, :, j, :] = G_tj`` (no 1/8πμ) for the targets ``lo ≤ t < hi``."""
    n = len(x)
    for t in nb.prange(lo, hi):
        T = np.empty((3, 3))
        r = np.empty(3)
        own = np.zeros((3, 3))
        dt2 = delta[t] * delta[t]
        for j in range(n):
            for c in range(3):
                r[c] = x[t, c] - x[j, c]
            kernels.free_gradient(r, F[j], sqrt(0.5 * (dt2 + delta[j] * delta[j])), T)
            for i in range(3):
                for k in range(3):
                    out[t - lo, i, j, k] = -T[i, k]
                    own[i, k] += T[i, k]
        for i in range(3):
            for k in range(3):
                out[t - lo, i, t, k] += own[i, k]
