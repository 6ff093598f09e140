"""Shell kinematics (docs/model.md §3 and §4), written in UFL.

The reference mid-surface is the mesh itself (tdim 2 in gdim 3).  Greek indices
run over the two reference-cell coordinates; every 2x2 tensor here is a matrix of
*covariant* components in the reference cell's coordinates, and every 2-vector a
covector, so the contractions with the inverse metric ``A^{-1}`` are explicit.
"""

from __future__ import annotations

import ufl


def covariant_basis(mesh):
    """Reference covariant basis ``(G_1, G_2)``: the columns of ``J = dX/dxi`` (3x2)."""
    J = ufl.Jacobian(mesh)
    return J[:, 0], J[:, 1]


def metric(a1, a2):
    """First fundamental form ``a_ab = a_a . a_b`` of a pair of tangent vectors."""
    return ufl.as_matrix([[ufl.dot(a1, a1), ufl.dot(a1, a2)],
                          [ufl.dot(a2, a1), ufl.dot(a2, a2)]])


def unit(v):
    """``v / |v|``."""
    return v / ufl.sqrt(ufl.dot(v, v))


def unit_normal(a1, a2):
    """``N = a_1 x a_2 / |a_1 x a_2|``."""
    return unit(ufl.cross(a1, a2))


def area_ratio(g1, g2, G1, G2):
    """Current over reference area element ``|g_1 x g_2| / |G_1 x G_2|`` (docs/model.md §5.4)."""
    n, N = ufl.cross(g1, g2), ufl.cross(G1, G2)
    return ufl.sqrt(ufl.dot(n, n) / ufl.dot(N, N))


# --- finite rotations ------------------------------------------------------

#: below this value of |theta|^2 the rotation coefficients use their Taylor
#: series; the first omitted term is then < 1e-4^4/8! ~ 2e-21.
SERIES_THRESHOLD = 1.0e-4


def rotation_coefficients(s):
    """``(cos|θ|, sin|θ|/|θ|, (1 - cos|θ|)/|θ|²)`` as functions of ``s = θ·θ``.

    Near ``s = 0`` a Taylor series in ``s`` replaces the closed form, so neither
    the value nor any derivative takes ``sqrt`` of zero: the tangent at θ = 0
    (the start of every Newton solve) is finite.  The closed-form branch sees
    ``s`` clipped from below so that its own derivative stays finite too.
    """
    small = ufl.lt(s, SERIES_THRESHOLD)
    s_big = ufl.conditional(small, SERIES_THRESHOLD, s)
    angle = ufl.sqrt(s_big)
    cos_series = 1 - s / 2 + s**2 / 24 - s**3 / 720 + s**4 / 40320
    sinc_series = 1 - s / 6 + s**2 / 120 - s**3 / 5040 + s**4 / 362880
    vers_series = 0.5 - s / 24 + s**2 / 720 - s**3 / 40320 + s**4 / 3628800
    c = ufl.conditional(small, cos_series, ufl.cos(angle))
    sc = ufl.conditional(small, sinc_series, ufl.sin(angle) / angle)
    vc = ufl.conditional(small, vers_series, (1 - ufl.cos(angle)) / s_big)
    return c, sc, vc


def surface_deformation_gradient(u):
    """``F_s = I + grad u``; on tangent vectors, where it is used, it equals ``grad x``."""
    return ufl.Identity(3) + ufl.grad(u)


def tangent_axis(axis, G1, G2):
    """The material axis ``E₁*`` projected onto the reference tangent plane.

    A scene gives the axis as one constant vector; on a curved (or rotated)
    reference surface only its tangential part is a material direction.
    """
    N = unit_normal(G1, G2)
    return axis - ufl.dot(axis, N) * N


def convected_axis(F_s, axis, G1, G2):
    """The material axis carried by the deformation, ``F_s E₁*`` with ``E₁*`` taken
    tangent (``tangent_axis``); not normalised."""
    return F_s * tangent_axis(axis, G1, G2)


def rotation_vector(theta, a1, a2):
    """Rotation increment ``θ = θ¹ a₁ + θ² a₂`` from its two components (docs/model.md §4.1)."""
    return theta[0] * a1 + theta[1] * a2


def director(theta, a1, a2, dn):
    """Current director ``d = cos|θ| dₙ + (sin|θ|/|θ|) θ × dₙ`` (docs/model.md §4.2).

    ``(a1, a2, dn)`` is the nodal triad of the last converged step, interpolated;
    ``dn`` is normalised where interpolated.  ``θ`` has no drilling component, so
    this is the exact rotation of ``dn`` by ``θ`` at the nodes.
    """
    dn = unit(dn)
    rot = rotation_vector(theta, a1, a2)
    c, sc, _ = rotation_coefficients(ufl.dot(rot, rot))
    return c * dn + sc * ufl.cross(rot, dn)


# --- strain measures -------------------------------------------------------


def surface_basis(u, G1, G2):
    """Current covariant basis ``g_a = F_s G_a = G_a + grad(u) G_a``."""
    F = ufl.grad(u)
    return G1 + F * G1, G2 + F * G2


def membrane_strain(g1, g2, G1, G2):
    """``ε_ab = ½ (g_a·g_b − G_a·G_b)``."""
    return 0.5 * (metric(g1, g2) - metric(G1, G2))


def _curvature(g1, g2, d, G1, G2):
    dd1, dd2 = ufl.grad(d) * G1, ufl.grad(d) * G2
    k12 = 0.5 * (ufl.dot(g1, dd2) + ufl.dot(g2, dd1))
    return ufl.as_matrix([[ufl.dot(g1, dd1), k12], [k12, ufl.dot(g2, dd2)]])


def bending_strain(g1, g2, d, G1, G2, D):
    """``κ_ab = ½ (g_a·∂_b d + g_b·∂_a d) − B_ab`` with ``∂_b d = grad(d) G_b``.

    ``B_ab`` is the same expression for the reference state ``(X, D)``; it is
    zero for flat bodies and makes curved reference surfaces stress free.
    """
    return _curvature(g1, g2, d, G1, G2) - _curvature(G1, G2, D, G1, G2)


def shear_strain(g1, g2, d, G1, G2, D):
    """``γ_a = g_a·d − G_a·D``."""
    return ufl.as_vector([ufl.dot(g1, d) - ufl.dot(G1, D), ufl.dot(g2, d) - ufl.dot(G2, D)])


def deformation_gradient(g1, g2, d, G1, G2, N):
    """Shell deformation gradient ``F = F_s + d ⊗ N`` (docs/model.md §3.1), as
    ``g_a ⊗ G^a + d ⊗ N``."""
    A_inv = ufl.inv(metric(G1, G2))
    G_up1 = A_inv[0, 0] * G1 + A_inv[0, 1] * G2
    G_up2 = A_inv[1, 0] * G1 + A_inv[1, 1] * G2
    return ufl.outer(g1, G_up1) + ufl.outer(g2, G_up2) + ufl.outer(d, N)
