"""Shell kinematics (docs/model.md §3 and §4), written in UFL.

The reference mid-surface is the mesh itself (tdim 2 in gdim 3).  Greek indices
run over the two reference-cell coordinates; every 2x2 tensor here is a matrix of
*covariant* components in the reference cell's coordinates, and every 2-vector a
covector, so the contractions with the inverse metric ``A^{-1}`` are explicit.
"""

from __future__ import annotations

import ufl


def covariant_basis(mesh: object) -> tuple[ufl.core.expr.Expr, ufl.core.expr.Expr]:
    """Reference covariant basis ``(G_1, G_2)``: the columns of ``J = dX/dxi`` (3x2)."""
    J = ufl.Jacobian(mesh)
    return J[:, 0], J[:, 1]


def metric(a1: ufl.core.expr.Expr, a2: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
    """First fundamental form ``a_ab = a_a . a_b`` of a pair of tangent vectors."""
    return ufl.as_matrix([[ufl.dot(a1, a1), ufl.dot(a1, a2)], [ufl.dot(a2, a1), ufl.dot(a2, a2)]])


def unit(v: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
    """``v / |v|``."""
    return v / ufl.sqrt(ufl.dot(v, v))


def unit_normal(a1: ufl.core.expr.Expr, a2: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
    """``N = a_1 x a_2 / |a_1 x a_2|``."""
    return unit(ufl.cross(a1, a2))


def area_ratio(
    g1: ufl.core.expr.Expr, g2: ufl.core.expr.Expr, G1: ufl.core.expr.Expr, G2: ufl.core.expr.Expr
) -> ufl.core.expr.Expr:
    """Current over reference area element ``|g_1 x g_2| / |G_1 x G_2|`` (docs/model.md §5.4)."""
    n, N = ufl.cross(g1, g2), ufl.cross(G1, G2)
    return ufl.sqrt(ufl.dot(n, n) / ufl.dot(N, N))


def surface_deformation_gradient(u: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
    """``F_s = I + grad u``; on tangent vectors, where it is used, it equals ``grad x``."""
    return ufl.Identity(3) + ufl.grad(u)


def tangent_axis(
    axis: ufl.core.expr.Expr, G1: ufl.core.expr.Expr, G2: ufl.core.expr.Expr
) -> ufl.core.expr.Expr:
    """The material axis ``E₁*`` projected onto the reference tangent plane.

    A scene gives the axis as one constant vector; on a curved (or rotated)
    reference surface only its tangential part is a material direction.
    """
    N = unit_normal(G1, G2)
    return axis - ufl.dot(axis, N) * N


def convected_axis(
    F_s: ufl.core.expr.Expr,
    axis: ufl.core.expr.Expr,
    G1: ufl.core.expr.Expr,
    G2: ufl.core.expr.Expr,
) -> ufl.core.expr.Expr:
    """The material axis carried by the deformation, ``F_s E₁*`` with ``E₁*`` taken
    tangent (``tangent_axis``); not normalised."""
    return F_s * tangent_axis(axis, G1, G2)


# --- the director -----------------------------------------------------------


def interpolated_director(d_nodal: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
    """The director between the nodes (docs/model.md §4.3): the nodal directors
    ``d_I`` (unit vectors, each its node's last director turned exactly by its
    rotation increment) interpolated, ``Σ N_I d_I``, and normalised.

    Only unit vectors are interpolated, so a rigid rotation ``R`` of every nodal
    director turns this field by ``R`` too: with the reference director ``D``
    interpolated alike, no strain measure below sees a rigid motion.
    """
    return unit(d_nodal)


# --- strain measures -------------------------------------------------------


def surface_basis(
    u: ufl.core.expr.Expr, G1: ufl.core.expr.Expr, G2: ufl.core.expr.Expr
) -> tuple[ufl.core.expr.Expr, ufl.core.expr.Expr]:
    """Current covariant basis ``g_a = F_s G_a = G_a + grad(u) G_a``."""
    F = ufl.grad(u)
    return G1 + F * G1, G2 + F * G2


def membrane_strain(
    g1: ufl.core.expr.Expr, g2: ufl.core.expr.Expr, G1: ufl.core.expr.Expr, G2: ufl.core.expr.Expr
) -> ufl.core.expr.Expr:
    """``ε_ab = ½ (g_a·g_b − G_a·G_b)``."""
    return 0.5 * (metric(g1, g2) - metric(G1, G2))


def _curvature(g1, g2, d, G1, G2):
    dd1, dd2 = ufl.grad(d) * G1, ufl.grad(d) * G2
    k12 = 0.5 * (ufl.dot(g1, dd2) + ufl.dot(g2, dd1))
    return ufl.as_matrix([[ufl.dot(g1, dd1), k12], [k12, ufl.dot(g2, dd2)]])


def bending_strain(
    g1: ufl.core.expr.Expr,
    g2: ufl.core.expr.Expr,
    d: ufl.core.expr.Expr,
    G1: ufl.core.expr.Expr,
    G2: ufl.core.expr.Expr,
    D: ufl.core.expr.Expr,
) -> ufl.core.expr.Expr:
    """``κ_ab = ½ (g_a·∂_b d + g_b·∂_a d) − B_ab`` with ``∂_b d = grad(d) G_b``.

    ``B_ab`` is the same expression for the reference state ``(X, D)``; it is
    zero for flat bodies and makes curved reference surfaces stress free.
    """
    return _curvature(g1, g2, d, G1, G2) - _curvature(G1, G2, D, G1, G2)


def shear_strain(
    g1: ufl.core.expr.Expr,
    g2: ufl.core.expr.Expr,
    d: ufl.core.expr.Expr,
    G1: ufl.core.expr.Expr,
    G2: ufl.core.expr.Expr,
    D: ufl.core.expr.Expr,
) -> ufl.core.expr.Expr:
    """``γ_a = g_a·d − G_a·D``."""
    return ufl.as_vector([ufl.dot(g1, d) - ufl.dot(G1, D), ufl.dot(g2, d) - ufl.dot(G2, D)])


def deformation_gradient(
    g1: ufl.core.expr.Expr,
    g2: ufl.core.expr.Expr,
    d: ufl.core.expr.Expr,
    G1: ufl.core.expr.Expr,
    G2: ufl.core.expr.Expr,
    N: ufl.core.expr.Expr,
) -> ufl.core.expr.Expr:
    """Shell deformation gradient ``F = F_s + d ⊗ N`` (docs/model.md §3.1), as
    ``g_a ⊗ G^a + d ⊗ N``."""
    A_inv = ufl.inv(metric(G1, G2))
    G_up1 = A_inv[0, 0] * G1 + A_inv[0, 1] * G2
    G_up2 = A_inv[1, 0] * G1 + A_inv[1, 1] * G2
    return ufl.outer(g1, G_up1) + ufl.outer(g2, G_up2) + ufl.outer(d, N)
