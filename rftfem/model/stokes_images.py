"""Blake's image system of a plane wall, compiled (numba): the images' 3 × 3 block and
its exact derivatives in closed form, in the wall's frame (``rftfem.model.stokes_kernels``
sums them over quadrature points; ``stokeslets.Wall``).
"""

from __future__ import annotations

from math import sqrt

import numba as nb
import numpy as np

_JIT = dict(cache=True)


@nb.njit(**_JIT)
def image_block(xi: np.ndarray, eta: np.ndarray, out: np.ndarray) -> None:
    """Blake's image block ``W`` (3 × 3, set) in the wall's frame: ``u = W f`` at
    ``xi`` for a force ``f`` at ``eta`` (heights ``xi[2]``, ``eta[2]`` > 0),

        W_ik = −δ_ik/R − R_i R_k/R³ + 2h [h (δ_ik/R³ − 3 R_i R_k/R⁵) D_k + δ_i3 R_k D_k/R³
               − (δ_ik R₃ D_k + R_i δ_k3 D_3)/R³ + 3 R_i R₃ R_k D_k/R⁵],

    ``R = xi − D eta``, ``h = eta[2]``, ``D = diag(1, 1, −1)`` (stokeslets.Wall)."""
    R = (xi[0] - eta[0], xi[1] - eta[1], xi[2] + eta[2])  # (no array: none allocated)
    h = eta[2]
    n2 = R[0] * R[0] + R[1] * R[1] + R[2] * R[2]
    i1 = 1.0 / sqrt(n2)
    i3 = i1 / n2
    i5 = i3 / n2
    # W_ik = R_i R_k (a + b D_k) + δ_ik (c + d D_k) + δ_i3 e R_k D_k + δ_k3 e R_i
    a, b = -i3, 6 * h * (R[2] - h) * i5
    c, d, e = -i1, 2 * h * (h - R[2]) * i3, 2 * h * i3
    for k in range(3):
        Dk = 1.0 if k < 2 else -1.0
        ab = a + b * Dk
        for i in range(3):
            out[i, k] = R[i] * R[k] * ab
        out[k, k] += c + d * Dk
        out[2, k] += e * R[k] * Dk
    for i in range(3):
        out[i, 2] += e * R[i]


@nb.njit(**_JIT)
def image_gradient(
    xi: np.ndarray, eta: np.ndarray, f: np.ndarray, d_xi: np.ndarray, d_eta: np.ndarray
) -> None:
    """The images' velocity ``W f`` (``f`` fixed, the wall's frame) differentiated:
    ``d_xi = ∂(W f)/∂xi``, ``d_eta = ∂(W f)/∂eta`` (3 × 3 each, set), in closed form
    (``∂R/∂xi = I``, ``∂R/∂eta = −D``, ``∂h/∂eta = e₃``)."""
    R = (xi[0] - eta[0], xi[1] - eta[1], xi[2] + eta[2])
    g = (f[0], f[1], -f[2])
    h = eta[2]
    n2 = R[0] * R[0] + R[1] * R[1] + R[2] * R[2]
    n = sqrt(n2)
    i1 = 1.0 / n
    i3 = i1 / n2
    i5 = i3 / n2
    i7 = i5 / n2
    R3, g3 = R[2], g[2]
    s = R[0] * f[0] + R[1] * f[1] + R[2] * f[2]
    q = R[0] * g[0] + R[1] * g[1] + R[2] * g[2]
    for i in range(3):
        dh = 2 * (
            h * g[i] * i3
            - 3 * h * R[i] * q * i5
            - g[i] * R3 * i3
            - R[i] * g3 * i3
            + 3 * R[i] * R3 * q * i5
        ) + 2 * h * (g[i] * i3 - 3 * R[i] * q * i5)
        if i == 2:
            dh += 2 * q * i3
        for m in range(3):
            dim = 1.0 if i == m else 0.0
            dm3 = 1.0 if m == 2 else 0.0
            di3 = 1.0 if i == 2 else 0.0
            v = f[i] * R[m] * i3 - dim * s * i3 - R[i] * f[m] * i3 + 3 * R[i] * s * R[m] * i5
            w = (
                -3 * h * g[i] * R[m] * i5
                - 3 * h * (dim * q * i5 + R[i] * g[m] * i5 - 5 * R[i] * q * R[m] * i7)
                + di3 * (g[m] * i3 - 3 * q * R[m] * i5)
                - g[i] * (dm3 * i3 - 3 * R3 * R[m] * i5)
                - g3 * (dim * i3 - 3 * R[i] * R[m] * i5)
                + 3
                * (
                    dim * R3 * q * i5
                    + R[i] * dm3 * q * i5
                    + R[i] * R3 * g[m] * i5
                    - 5 * R[i] * R3 * q * R[m] * i7
                )
            )
            d_xi[i, m] = v + 2 * h * w
        d_eta[i, 0], d_eta[i, 1] = -d_xi[i, 0], -d_xi[i, 1]
        d_eta[i, 2] = d_xi[i, 2] + dh
