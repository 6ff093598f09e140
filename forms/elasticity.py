"""Stored energy of the Reissner-Mindlin shell and its locking cure (docs/model.md §3).

    ψ = ½ t ε:C:ε + ½ (t³/12) κ:C:κ + ½ t k_s μ γ_a A^{ab} γ_b
    C(e) = E/(1−ν²) [ν tr(A⁻¹e) A⁻¹ + (1−ν) A⁻¹ e A⁻¹],   μ = E/(2(1+ν)),  k_s = 5/6

Locking: partial selective reduced integration (PSRI).  The membrane and shear
energies are split as ``α ψ`` at full quadrature plus ``(1 − α) ψ`` at reduced
quadrature with ``α = t²/h²`` per cell (h the cell diameter), clipped to 1;
bending is always fully integrated.  With Q2 (P2) displacements and rotations,
full degree 4 and reduced degree 2 (2×2 Gauss on quadrilaterals).
"""

from __future__ import annotations

import ufl

from .kinematics import metric

SHEAR_CORRECTION = 5.0 / 6.0
FULL_DEGREE = 4
REDUCED_DEGREE = 2


def plane_stress(e, A_inv, E, nu):
    """Contravariant stress resultant density ``C(e)`` of covariant strain ``e``."""
    return E / (1 - nu**2) * (nu * ufl.tr(A_inv * e) * A_inv + (1 - nu) * A_inv * e * A_inv)


def membrane_energy(eps, A_inv, E, nu, t):
    """``½ t ε:C(ε)`` per reference area."""
    return 0.5 * t * ufl.inner(eps, plane_stress(eps, A_inv, E, nu))


def bending_energy(kappa, A_inv, E, nu, t):
    """``½ (t³/12) κ:C(κ)`` per reference area."""
    return 0.5 * t**3 / 12 * ufl.inner(kappa, plane_stress(kappa, A_inv, E, nu))


def shear_energy(gamma, A_inv, E, nu, t):
    """``½ t k_s μ γ_a A^{ab} γ_b`` per reference area."""
    mu = E / (2 * (1 + nu))
    return 0.5 * t * SHEAR_CORRECTION * mu * ufl.dot(gamma, A_inv * gamma)


def psri_weight(t, h):
    """Full-integration share ``α = min(t²/h², 1)`` of the membrane and shear energies."""
    return ufl.min_value(t**2 / h**2, 1.0)


def stored_energy(strains, G1, G2, E, nu, t, dx, h):
    """Total stored energy ``Π = ∫ ψ dA₀`` with PSRI (a UFL 0-form).

    ``strains = (ε, κ, γ)``; ``dx`` is the reference area measure (its subdomain
    data may be set; the quadrature degrees are set here); ``h`` the cell size.
    """
    eps, kappa, gamma = strains
    A_inv = ufl.inv(metric(G1, G2))
    psi_b = bending_energy(kappa, A_inv, E, nu, t)
    psi_ms = membrane_energy(eps, A_inv, E, nu, t) + shear_energy(gamma, A_inv, E, nu, t)
    alpha = psri_weight(t, h)
    dx_full = dx(metadata={"quadrature_degree": FULL_DEGREE})
    dx_reduced = dx(metadata={"quadrature_degree": REDUCED_DEGREE})
    return (psi_b + alpha * psi_ms) * dx_full + (1 - alpha) * psi_ms * dx_reduced


def mixed_point_tangent(strains, defects, G1, G2, E, nu, t, dx, h):
    """The 0-form ``−∫ [n(R_ε):ε + q(R_γ)·γ] dA₀`` whose second derivative, added to the
    exact tangent, gives the tangent of the mixed-integration-point Newton method
    (docs/model.md §7.4).

    ``strains = (ε, κ, γ)`` of the unknown; ``defects = (R_ε, R_γ)``, the membrane and
    shear strains' linearization defects at the iterate, ``R = ε(w) − ε(w_p) −
    Dε(w_p)[w − w_p]`` with ``w_p`` the previous iterate; the form treats them as
    data.  The exact tangent's geometric stiffness carries the iterate's stress
    resultants ``n = t C(ε)``; this one carries those linearized from the previous
    iterate, ``n − t C(R_ε)`` (and the same for the shear force), so the membrane
    forces of a linearized rotation, ``t C(½ δg_a·δg_b)``, do not enter the next
    tangent.  Same PSRI weights and quadrature as ``stored_energy``.
    """
    eps, _, gamma = strains
    R_eps, R_gamma = defects
    A_inv = ufl.inv(metric(G1, G2))
    mu = E / (2 * (1 + nu))
    n_defect = t * plane_stress(R_eps, A_inv, E, nu)
    q_defect = t * SHEAR_CORRECTION * mu * A_inv * R_gamma
    work = ufl.inner(n_defect, eps) + ufl.dot(q_defect, gamma)
    alpha = psri_weight(t, h)
    dx_full = dx(metadata={"quadrature_degree": FULL_DEGREE})
    dx_reduced = dx(metadata={"quadrature_degree": REDUCED_DEGREE})
    return -(alpha * work * dx_full + (1 - alpha) * work * dx_reduced)
