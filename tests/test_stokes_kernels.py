"""The compiled Stokes kernels (rftfem.model.stokes_kernels) against the numpy they
replaced (tests/stokes_reference.py): each to round-off, the wall's closed-form
derivative against complex steps, and the layer's whole operator and position
derivative against numpy sums of the same rules.  Their Taylor order 2 is
tests/test_stokes.py's (test_layer_position_derivative_taylor_order_two, the wall
included; test_wall_images_meet_no_slip)."""

from __future__ import annotations

import numpy as np
import pytest
import stokes_reference as ref

from rftfem.model import stokes_kernels, stokes_layer, stokeslets

WALL = stokeslets.Wall([0.1, -0.2, -0.6], [0.3, 0.2, 1.0])


def q2_strip(nx: int, ny: int, length: float = 3.0, width: float = 2.0):
    """A bent strip of second-order quadrilaterals (nodes in basix's order)."""
    xs, ys = np.linspace(0, length, 2 * nx + 1), np.linspace(-width / 2, width / 2, 2 * ny + 1)
    X = np.array([[x, y, 0.3 * np.sin(x) + 0.1 * y * x] for y in ys for x in xs])

    def node(i, j):
        return j * (2 * nx + 1) + i

    cells = [
        [
            node(i, j),
            node(i + 2, j),
            node(i, j + 2),
            node(i + 2, j + 2),
            node(i + 1, j),
            node(i, j + 1),
            node(i + 2, j + 1),
            node(i + 1, j + 2),
            node(i + 1, j + 1),
        ]
        for j in range(0, 2 * ny, 2)
        for i in range(0, 2 * nx, 2)
    ]
    return X, np.array(cells)


@pytest.mark.parametrize("eps", [0.0, 0.05])
def test_free_kernel_matches_numpy(eps):
    """Blocks S_ε(r) and gradients ∂(S_ε F)/∂r at separations from 0.02 ε (the
    series) through the erf range to beyond 7 ε (the Stokeslet): within 1e-13 of
    the numpy kernel (reached 1.7e-15).  Broke: the gradient's ``b (r·F) δ`` term
    dropped (0.85), ε's power in ``b′/r`` made 4 (1.45 at ε = 0.05)."""
    rng = np.random.default_rng(3)
    size = np.geomspace(1e-3, 3.0, 60)[:, None]
    r = rng.standard_normal((60, 3))
    r *= size / np.linalg.norm(r, axis=1, keepdims=True)
    F = rng.standard_normal((60, 3))
    blocks, grads = ref.kernel_blocks(r, eps), ref.kernel_gradient(r, F, eps)
    K, T = np.empty((3, 3)), np.empty((3, 3))
    worst = [0.0, 0.0]
    for i in range(len(r)):
        stokes_kernels.free_block(r[i], eps, K)
        stokes_kernels.free_gradient(r[i], F[i], eps, T)
        worst[0] = max(worst[0], np.abs(K - blocks[i]).max() / np.abs(blocks[i]).max())
        worst[1] = max(worst[1], np.abs(T - grads[i]).max() / np.abs(grads[i]).max())
    print(f"ε = {eps}: block {worst[0]:.2e}, gradient {worst[1]:.2e}")
    assert max(worst) < 1e-13, worst


def test_wall_images_and_closed_form_derivative_match_numpy():
    """Blake's image blocks and their closed-form derivatives in the target and the
    source position, a tilted wall, heights 0.05 to 2: within 1e-12 of the numpy
    images and of their complex-step derivatives (reached 7e-16).  Broke: the
    ``∂h/∂η`` column (``d_eta[i, 2] += dh``) dropped (0.97); the sign of the
    ``g₃`` term flipped in the gradient (1.2)."""
    rng = np.random.default_rng(5)
    lift = WALL.point + rng.uniform(0.05, 2.0, (2, 7, 1)) * WALL.Q[2]
    targets = lift[0] + rng.standard_normal((7, 2)) @ WALL.Q[:2]
    sources = lift[1] + rng.standard_normal((7, 2)) @ WALL.Q[:2]
    F = rng.standard_normal((7, 3))
    W0 = ref.image_blocks(WALL, targets, sources)
    d_t, d_s = ref.image_derivatives(WALL, targets, sources, F)
    k, Q, p = stokes_kernels, WALL.Q, WALL.point
    W = np.zeros((7, 3, 7, 3))  # in the wall's frame, turned back
    k.far_matrix(
        k.to_frame(Q, p, targets),
        k.to_frame(Q, p, sources),
        np.ones((7, 1)),
        np.arange(7)[:, None],
        0.0,
        False,
        True,
        W,
    )
    W = k.from_frame(Q, W)
    block = np.abs(W.transpose(0, 2, 1, 3) - W0).max() / np.abs(W0).max()
    G = np.zeros((7, 3, 14, 3))  # sources are nodes 0..6, targets 7..13
    k.far_derivative(
        k.to_frame(Q, p, targets),
        np.arange(7, 14),
        k.to_frame(Q, p, sources),
        np.ones((7, 1)),
        np.arange(7)[:, None],
        k.to_frame(Q, None, F),
        0.0,
        False,
        True,
        G,
    )
    G = k.from_frame(Q, G)
    scale = max(np.abs(d_t).max(), np.abs(d_s).max())
    target = np.abs(G[np.arange(7), :, np.arange(7, 14), :] - d_t.sum(axis=1)).max() / scale
    source = np.abs(G[:, :, :7].transpose(0, 2, 1, 3) - d_s).max() / scale
    print(f"images: block {block:.2e}, ∂/∂target {target:.2e}, ∂/∂source {source:.2e}")
    assert max(block, target, source) < 1e-12, (block, target, source)


@pytest.mark.parametrize("eps,wall", [(0.0, True), (0.05, False)], ids=["wall", "blob"])
def test_layer_operator_matches_numpy(eps, wall):
    """The layer's ``A`` and ``G = ∂(A f)/∂x`` on a bent 3 × 2 strip (far, near and
    singular rules, edge weights) against numpy sums of the same rules: within 1e-12
    (reached 4e-14).  Broke: the special points left unsorted by target (7.3 and
    9.4); the derivative's own-node term left out of ``pairs_derivative`` (9.3)."""
    X, cells = q2_strip(3, 2)
    layer = stokes_layer.Layer(X, cells, "quadrilateral", eps)
    rng = np.random.default_rng(2)
    x = X + 0.03 * rng.standard_normal(X.shape)
    f = rng.standard_normal(X.shape)
    w = WALL if wall else None
    A = layer.matrix(x, 1.0 / (8 * np.pi), w)
    A0 = ref.layer_matrix(layer, x, w)
    G = layer.position_derivative(x, f, 1.0 / (8 * np.pi), w)
    G0 = ref.layer_derivative(layer, x, f, w)
    errors = (np.abs(A - A0).max() / np.abs(A0).max(), np.abs(G - G0).max() / np.abs(G0).max())
    print(f"layer (ε = {eps}, wall {wall}): A {errors[0]:.2e}, G {errors[1]:.2e}")
    assert max(errors) < 5e-13, errors


def test_edge_distance_matches_numpy():
    """The distance to the free edges (the edge weight's): each point projected on its
    four candidate quadratic curves by four Newton updates, within 1e-14 of numpy's
    (reached 1e-16).  Broke: the curve's second derivative left out of Newton's h
    (0.43 on these random curves)."""
    rng = np.random.default_rng(11)
    P = rng.standard_normal((200, 4, 3, 3))
    t = rng.random((200, 4))
    y = rng.standard_normal((200, 3))
    ours = stokes_kernels.edge_distance(y, P, t)
    theirs = ref.edge_distance(P, t, y)
    error = np.abs(ours - theirs).max() / theirs.max()
    print(f"edge distance: {error:.2e}")
    assert error < 1e-14, error


def test_dense_blob_rows_match_numpy():
    """The blobs' dense rows, compiled (``stokes_rows``: what ``operator = "dense"``
    assembles), against ``stokeslets.mobility`` and ``stokeslets.position_derivative``
    (numpy): nodal blobs of different sizes, pairs from inside a blob to far, all
    rows and a middle slice of them, each within 5e-15 of the largest entry (reached
    4e-16).  Broke: the pair blob ``δ_j`` for ``√((δ_t² + δ_j²)/2)`` in the derivative
    (0.32); the diagonal's sum left out (1.0)."""
    from rftfem.model import stokes_rows

    g = np.random.default_rng(3)
    x = g.random((300, 3)) * [5.0, 2.0, 0.3]
    delta, F = 0.05 + 0.05 * g.random(300), g.standard_normal((300, 3))
    worst = 0.0
    for rows in (None, slice(100, 220)):
        pairs = (
            (
                stokeslets.mobility(x, delta, 0.7, rows),
                stokes_rows.mobility_rows(x, delta, 0.7, rows),
            ),
            (
                stokeslets.position_derivative(x, delta, 0.7, F, rows),
                stokes_rows.derivative_rows(x, delta, 0.7, F, rows),
            ),
        )
        for numpy_rows, compiled in pairs:
            assert compiled.shape == numpy_rows.shape
            worst = max(worst, np.abs(compiled - numpy_rows).max() / np.abs(numpy_rows).max())
    print(f"dense rows, compiled against numpy: {worst:.2e}")
    assert worst < 5e-15
