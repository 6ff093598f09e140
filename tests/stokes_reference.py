"""The Stokes kernels as numpy wrote them before they were compiled
(``rftfem.model.stokes_kernels``): the reference the compiled ones are held to
(tests/test_stokes_kernels.py).  The wall's derivative here is by complex steps,
independent of the closed form it checks."""

from __future__ import annotations

import numpy as np

from rftfem.model import stokeslets


def radial(r: np.ndarray, eps: float):
    """``(a, b, a′/r, b′/r)`` of ``S_ε(r) F = a F + b (r·F) r`` at separations ``r``
    (..., 3); ``eps = 0`` is the Stokeslet itself."""
    dist = np.sqrt(np.einsum("...k,...k->...", r, r))
    if eps == 0.0:
        inv = 1.0 / dist
        inv3 = inv**3
        return inv, inv3, -inv3, -3.0 * inv3 * inv * inv
    f0, f1, f2, f3 = stokeslets.radial(dist / eps)
    return f0 / eps, f1 / eps**3, f2 / eps**3, f3 / eps**5


def kernel_blocks(r, eps):
    """The 3 × 3 blocks ``S_ε(r)`` (..., 3, 3)."""
    a, b, _, _ = radial(r, eps)
    out = b[..., None, None] * r[..., :, None] * r[..., None, :]
    out += a[..., None, None] * np.eye(3)
    return out


def kernel_gradient(r, F, eps):
    """``T = ∂(S_ε(r) F)/∂r`` (..., 3, 3) for separations ``r`` and forces ``F`` (..., 3)."""
    _, b, da, db = radial(r, eps)
    rF = np.einsum("...k,...k->...", r, F)
    T = da[..., None, None] * F[..., :, None] * r[..., None, :]
    T += (db * rF)[..., None, None] * r[..., :, None] * r[..., None, :]
    T += b[..., None, None] * r[..., :, None] * F[..., None, :]
    T += (b * rF)[..., None, None] * np.eye(3)
    return T


def image_pairs(wall: stokeslets.Wall, targets, sources, forces):
    """Per pair (N_t, N_s, 3): each source's image velocity at each target, written
    from Blake's Φ as the wall's docstring gives it (complex-safe)."""
    xi = _local(wall, targets)[:, None, :]
    eta = _local(wall, sources)[None, :, :]
    f = (np.asarray(forces) @ wall.Q.T)[None, :, :]
    h = eta[..., 2]
    R = xi - eta * np.array([1.0, 1.0, -1.0])
    Rn = np.sqrt(np.sum(R * R, axis=-1))
    R3 = R[..., 2]
    inv1, inv3 = 1.0 / Rn, 1.0 / Rn**3
    inv5 = inv3 / Rn**2
    RF = np.sum(R * f, axis=-1)
    g = f * np.array([1.0, 1.0, -1.0])  # D F
    Rg = np.sum(R * g, axis=-1)
    g3 = g[..., 2]
    e3 = np.array([0.0, 0.0, 1.0])
    # Σ_j g_j ∂Φ/∂R_j
    dphi = (
        h[..., None] * (g * inv3[..., None] - 3 * R * (Rg * inv5)[..., None])
        + e3 * (Rg * inv3)[..., None]
        - (g * R3[..., None] + R * g3[..., None]) * inv3[..., None]
        + 3 * R * (R3 * Rg * inv5)[..., None]
    )
    u = -(f * inv1[..., None] + R * (RF * inv3)[..., None]) + 2 * h[..., None] * dphi
    return u @ wall.Q


def _local(wall, x):
    return (x - wall.point) @ wall.Q.T


def image_blocks(wall, targets, sources) -> np.ndarray:
    """Per pair the image's 3 × 3 block (N_t, N_s, 3, 3), without 1/8πμ."""
    out = np.empty((len(targets), len(sources), 3, 3), dtype=complex)
    for k in range(3):
        unit = np.zeros((len(sources), 3))
        unit[:, k] = 1.0
        out[:, :, :, k] = image_pairs(wall, targets, sources, unit)
    return out.real


def image_derivatives(wall, targets, sources, forces, step=1e-30):
    """``∂(W F)/∂target`` and ``∂(W F)/∂source`` per pair (N_t, N_s, 3, 3) by complex steps."""
    d_t = np.empty((len(targets), len(sources), 3, 3))
    d_s = np.empty_like(d_t)
    for m in range(3):
        dx = np.zeros(3, dtype=complex)
        dx[m] = 1j * step
        d_t[..., m] = image_pairs(wall, targets + dx, sources, forces).imag / step
        d_s[..., m] = image_pairs(wall, targets, sources + dx, forces).imag / step
    return d_t, d_s


def layer_matrix(layer, x, wall=None) -> np.ndarray:
    """``A`` of ``rftfem.model.stokes_layer.Layer`` (all rows, times 8πμ) summed with
    numpy over the far rule (every node) and the listed near and singular pairs."""
    n = len(x)
    far, s = layer.far, layer.special
    y = far.positions(x)
    K = kernel_blocks(x[:, None] - y[None], layer.epsilon)  # (n, q, 3, 3)
    if wall is not None:
        K = K + image_blocks(wall, x, y)
    A = np.zeros((n, 3, n, 3))
    wpsi = far.psi * far.weight[:, None]
    for a in range(far.nodes.shape[1]):
        for t in range(n):
            np.add.at(A[t].transpose(1, 0, 2), far.nodes[:, a], wpsi[:, a, None, None] * K[t])
    r = x[s.target] - s.positions(x)
    Ks = kernel_blocks(r, layer.epsilon) * s.weight[:, None, None]
    for a in range(s.nodes.shape[1]):
        np.add.at(A, (s.target, slice(None), s.nodes[:, a]), s.psi[:, a, None, None] * Ks)
    return A.reshape(3 * n, 3 * n)


def layer_derivative(layer, x, f, wall=None) -> np.ndarray:
    """``G = ∂(A f)/∂x`` (times 8πμ) by the same sums, the wall's part by complex steps."""
    n = len(x)
    far, s = layer.far, layer.special
    y = far.positions(x)
    fq = far.density(f)
    T = kernel_gradient(x[:, None] - y[None], np.broadcast_to(fq, y.shape), layer.epsilon)
    own, src = T.sum(axis=1), -T
    if wall is not None:
        d_t, d_s = image_derivatives(wall, x, y, fq)
        own, src = own + d_t.sum(axis=1), src + d_s
    G = np.zeros((n, 3, n, 3))
    G[np.arange(n), :, np.arange(n), :] += own
    for a in range(far.nodes.shape[1]):
        for t in range(n):
            np.add.at(G[t].transpose(1, 0, 2), far.nodes[:, a], far.psi[:, a, None, None] * src[t])
    r = x[s.target] - s.positions(x)
    Ts = kernel_gradient(r, s.density(f), layer.epsilon)
    np.add.at(G, (s.target, slice(None), s.target), Ts)
    for a in range(s.nodes.shape[1]):
        np.add.at(G, (s.target, slice(None), s.nodes[:, a]), -s.psi[:, a, None, None] * Ts)
    return G.reshape(3 * n, 3 * n)


def edge_distance(P, t, y):
    """The free edges' Newton projection as numpy made it (layer_rules.EdgeWeight):
    curves ``P`` (n, k, 3, 3), starting parameters ``t`` (n, k), points ``y`` (n, 3)."""
    from rftfem.model.layer_rules import _quadratic

    for _ in range(4):
        c, dc, ddc = _quadratic(P, t)
        r = c - y[:, None]
        g = np.einsum("pkj,pkj->pk", r, dc)
        h = np.einsum("pkj,pkj->pk", dc, dc) + np.einsum("pkj,pkj->pk", r, ddc)
        t = np.clip(t - g / np.where(h > 0, h, 1.0), 0.0, 1.0)
    r = _quadratic(P, t)[0] - y[:, None]
    return np.sqrt(np.einsum("pkj,pkj->pk", r, r)).min(axis=1)
