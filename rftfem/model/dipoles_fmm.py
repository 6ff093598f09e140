"""The sums of rftfem/model/dipoles.py by fast multipoles (fmm3dpy's Laplace FMM with
dipole sources), for many dipoles.

The others' field at a dipole is the gradient of the scalar potential
``ψ(x) = Σ_j m_j·(x − x_j)/|x − x_j|³`` of the dipoles of the other groups:
``G_i = ∂E/∂m_i = k ∇ψ(x_i)`` and ``H_i = ∂E/∂x_i = k ∇∇ψ(x_i) m_i`` (``k = μ₀/4π``),
and the energy is ``E = ½ Σ_i m_i·G_i``.  fmm3dpy gives ``ψ/4π``, its gradient and
its Hessian at targets; one call per group takes that group's targets and every
other group's dipoles as sources.

The Hessian's product would need the third derivatives of ψ (a moved source is a
quadrupole), which the library does not give: :func:`hessian_product` takes the
central difference of :func:`gradient` along the direction instead.  Its step is
``STEP`` of the dipoles' extent and of the largest moment; its error is of the
order of ``(STEP × extent / nearest distance)²`` (tests/test_magnetic_interactions.py
checks the Taylor order of a run's forces against it).
"""

from __future__ import annotations

import numpy as np

#: the multipoles' requested precision
PRECISION = 1e-12
#: the central difference's step, as a share of the extent and of the largest moment
STEP = 1e-5
#: fmm3dpy's potential is ψ / 4π
_FOUR_PI = 4.0 * np.pi
#: fmm3dpy's Hessian components (xx, yy, zz, xy, xz, yz) into a 3 × 3 matrix
_HESSIAN = np.array([[0, 3, 4], [3, 1, 5], [4, 5, 2]])


def gradient(
    m: np.ndarray,
    x: np.ndarray,
    group: np.ndarray,
    lo: int,
    hi: int,
    scale: float,
    G: np.ndarray,
    H: np.ndarray,
    energy: np.ndarray,
    eps: float = PRECISION,
) -> None:
    """As ``dipoles.gradient``: for the targets ``lo:hi``, ``G``, ``H`` and each one's
    half of its pairs' energy."""
    import fmm3dpy

    own = group[lo:hi]
    for g in np.unique(own):
        targets = lo + np.flatnonzero(own == g)
        sources = group != g
        if not sources.any():
            G[targets - lo] = H[targets - lo] = 0.0
            continue
        out = fmm3dpy.lfmm3d(
            eps=eps,
            sources=np.ascontiguousarray(x[sources].T),
            dipvec=np.ascontiguousarray(m[sources].T),
            targets=np.ascontiguousarray(x[targets].T),
            pgt=3,
        )
        grad = _FOUR_PI * scale * np.asarray(out.gradtarg).T.reshape(-1, 3)
        hess = _FOUR_PI * scale * np.asarray(out.hesstarg).T.reshape(-1, 6)[:, _HESSIAN]
        G[targets - lo] = grad
        H[targets - lo] = np.einsum("nij,nj->ni", hess, m[targets])
    energy[:] = 0.5 * np.einsum("ni,ni->n", m[lo:hi], G)


def hessian_product(
    m: np.ndarray,
    x: np.ndarray,
    group: np.ndarray,
    dm: np.ndarray,
    dx: np.ndarray,
    lo: int,
    hi: int,
    scale: float,
    dG: np.ndarray,
    dH: np.ndarray,
    eps: float = PRECISION,
) -> None:
    """As ``dipoles.hessian_product``, by the central difference of :func:`gradient`
    along ``(dm, dx)`` (module doc)."""
    extent = float(np.ptp(x, axis=0).max()) or 1.0
    moment = float(np.abs(m).max()) or 1.0
    along = max(float(np.abs(dx).max()) / extent, float(np.abs(dm).max()) / moment)
    if along == 0.0:
        dG[:] = dH[:] = 0.0
        return
    h = STEP / along
    n = hi - lo
    plus, minus = [np.empty((n, 3)) for _ in range(2)], [np.empty((n, 3)) for _ in range(2)]
    energy = np.empty(n)
    gradient(m + h * dm, x + h * dx, group, lo, hi, scale, *plus, energy, eps)
    gradient(m - h * dm, x - h * dx, group, lo, hi, scale, *minus, energy, eps)
    dG[:] = (plus[0] - minus[0]) / (2.0 * h)
    dH[:] = (plus[1] - minus[1]) / (2.0 * h)
