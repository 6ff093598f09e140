"""Stored energy of the Reissner-Mindlin shell and its locking cure (docs/model.md §3).

    ψ = ½ t ε:C:ε + ½ (t³/12) κ:C:κ + ½ t k_s γ·H·γ,   k_s = 5/6

``C`` is the plane-stress law: isotropic,

    C(e) = E/(1−ν²) [ν tr(A⁻¹e) A⁻¹ + (1−ν) A⁻¹ e A⁻¹],   H = μ A⁻¹,  μ = E/(2(1+ν)),

or orthotropic in the frame (a, b) of the fibre a (in the surface) and b = N × a:
with ẽ = T e Tᵀ the strain's components in that frame (T's rows the contravariant
components of a and b),

    σ̃ = Q [ẽ₁₁, ẽ₂₂, 2ẽ₁₂],  Q = 1/(1−ν12ν21) [[E1, ν21E1, 0], [ν12E2, E2, 0],
                                                [0, 0, (1−ν12ν21)G12]],  ν21 = ν12E2/E1,
    C(e) = Tᵀ σ̃ T,   H = G13 a⊗a + G23 b⊗b (contravariant: Tᵀ diag(G13, G23) T).

Every coefficient may vary over the body (material fields); with E1 = E2 = E,
G12 = G13 = G23 = E/(2(1+ν)) the orthotropic law is the isotropic one (Tᵀ T = A⁻¹).

Locking: partial selective reduced integration (PSRI).  The membrane and shear
energies are split as ``α ψ`` at full quadrature plus ``(1 − α) ψ`` at reduced
quadrature with ``α = t²/h²`` (h the cell diameter, t the local thickness), clipped
to 1; bending is always fully integrated.  With Q2 (P2) displacements and
rotations, full degree 4 and reduced degree 2 (2×2 Gauss on quadrilaterals).
"""

from __future__ import annotations

import ufl

from .kinematics import metric, unit, unit_normal

SHEAR_CORRECTION = 5.0 / 6.0
FULL_DEGREE = 4
REDUCED_DEGREE = 2


class Isotropic:
    """The isotropic plane-stress law of modulus ``E`` and Poisson's ratio ``nu``."""

    def __init__(self, E: ufl.core.expr.Expr | float, nu: ufl.core.expr.Expr | float):
        self.E, self.nu = E, nu

    def stress(self, e: ufl.core.expr.Expr, A_inv: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
        """Contravariant stress resultant density ``C(e)`` of covariant strain ``e``."""
        E, nu = self.E, self.nu
        return E / (1 - nu**2) * (nu * ufl.tr(A_inv * e) * A_inv + (1 - nu) * A_inv * e * A_inv)

    def shear(self, gamma: ufl.core.expr.Expr, A_inv: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
        """Contravariant shear force density ``H γ`` (over t k_s) of covariant ``γ``."""
        return self.E / (2 * (1 + self.nu)) * A_inv * gamma


class Orthotropic:
    """The orthotropic plane-stress law along the fibre field ``fibre`` (projected on
    the reference surface spanned by ``G1, G2`` and normalised)."""

    def __init__(
        self,
        E1: ufl.core.expr.Expr | float,
        E2: ufl.core.expr.Expr | float,
        G12: ufl.core.expr.Expr | float,
        nu12: ufl.core.expr.Expr | float,
        G13: ufl.core.expr.Expr | float,
        G23: ufl.core.expr.Expr | float,
        fibre: ufl.core.expr.Expr,
        G1: ufl.core.expr.Expr,
        G2: ufl.core.expr.Expr,
    ):
        self.moduli = (E1, E2, G12, nu12, G13, G23)
        self.T = fibre_frame(fibre, G1, G2)

    def stress(self, e: ufl.core.expr.Expr, A_inv: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
        E1, E2, G12, nu12, _, _ = self.moduli
        nu21 = nu12 * E2 / E1
        T = self.T
        local = T * e * T.T
        scale = 1 / (1 - nu12 * nu21)
        s11 = scale * (E1 * local[0, 0] + nu21 * E1 * local[1, 1])
        s22 = scale * (nu12 * E2 * local[0, 0] + E2 * local[1, 1])
        s12 = G12 * 2 * local[0, 1]
        return T.T * ufl.as_matrix([[s11, s12], [s12, s22]]) * T

    def shear(self, gamma: ufl.core.expr.Expr, A_inv: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
        _, _, _, _, G13, G23 = self.moduli
        T = self.T
        local = T * gamma
        return T.T * ufl.as_vector([G13 * local[0], G23 * local[1]])


def fibre_frame(
    fibre: ufl.core.expr.Expr, G1: ufl.core.expr.Expr, G2: ufl.core.expr.Expr
) -> ufl.core.expr.Expr:
    """``T``: the rows are the contravariant components (in the basis G₁, G₂) of the
    unit fibre ``a`` (``fibre`` projected on the surface) and of ``b = N × a``."""
    N = unit_normal(G1, G2)
    a = unit(fibre - ufl.dot(fibre, N) * N)
    b = ufl.cross(N, a)
    A_inv = ufl.inv(metric(G1, G2))
    ca = A_inv * ufl.as_vector([ufl.dot(G1, a), ufl.dot(G2, a)])
    cb = A_inv * ufl.as_vector([ufl.dot(G1, b), ufl.dot(G2, b)])
    return ufl.as_matrix([[ca[0], ca[1]], [cb[0], cb[1]]])


def membrane_energy(
    eps: ufl.core.expr.Expr,
    A_inv: ufl.core.expr.Expr,
    law: Isotropic | Orthotropic,
    t: ufl.core.expr.Expr | float,
) -> ufl.core.expr.Expr:
    """``½ t ε:C(ε)`` per reference area."""
    return 0.5 * t * ufl.inner(eps, law.stress(eps, A_inv))


def bending_energy(
    kappa: ufl.core.expr.Expr,
    A_inv: ufl.core.expr.Expr,
    law: Isotropic | Orthotropic,
    t: ufl.core.expr.Expr | float,
) -> ufl.core.expr.Expr:
    """``½ (t³/12) κ:C(κ)`` per reference area."""
    return 0.5 * t**3 / 12 * ufl.inner(kappa, law.stress(kappa, A_inv))


def shear_energy(
    gamma: ufl.core.expr.Expr,
    A_inv: ufl.core.expr.Expr,
    law: Isotropic | Orthotropic,
    t: ufl.core.expr.Expr | float,
) -> ufl.core.expr.Expr:
    """``½ t k_s γ·H γ`` per reference area."""
    return 0.5 * t * SHEAR_CORRECTION * ufl.dot(gamma, law.shear(gamma, A_inv))


def psri_weight(t: ufl.core.expr.Expr | float, h: ufl.core.expr.Expr | float) -> ufl.core.expr.Expr:
    """Full-integration share ``α = min(t²/h², 1)`` of the membrane and shear energies."""
    return ufl.min_value(t**2 / h**2, 1.0)


def stored_energy(
    strains: tuple[ufl.core.expr.Expr, ufl.core.expr.Expr, ufl.core.expr.Expr],
    G1: ufl.core.expr.Expr,
    G2: ufl.core.expr.Expr,
    law: Isotropic | Orthotropic,
    t: ufl.core.expr.Expr | float,
    dx: ufl.Measure,
    h: ufl.core.expr.Expr | float,
) -> ufl.Form:
    """Total stored energy ``Π = ∫ ψ dA₀`` with PSRI (a UFL 0-form).

    ``strains = (ε, κ, γ)``; ``law`` an :class:`Isotropic` or :class:`Orthotropic`;
    ``dx`` is the reference area measure (its subdomain data may be set; the
    quadrature degrees are set here); ``h`` the cell size.
    """
    eps, kappa, gamma = strains
    A_inv = ufl.inv(metric(G1, G2))
    psi_b = bending_energy(kappa, A_inv, law, t)
    psi_ms = membrane_energy(eps, A_inv, law, t) + shear_energy(gamma, A_inv, law, t)
    alpha = psri_weight(t, h)
    dx_full = dx(metadata={"quadrature_degree": FULL_DEGREE})
    dx_reduced = dx(metadata={"quadrature_degree": REDUCED_DEGREE})
    return (psi_b + alpha * psi_ms) * dx_full + (1 - alpha) * psi_ms * dx_reduced


def mixed_point_tangent(
    strains: tuple[ufl.core.expr.Expr, ufl.core.expr.Expr, ufl.core.expr.Expr],
    defects: tuple[ufl.core.expr.Expr, ufl.core.expr.Expr],
    G1: ufl.core.expr.Expr,
    G2: ufl.core.expr.Expr,
    law: Isotropic | Orthotropic,
    t: ufl.core.expr.Expr | float,
    dx: ufl.Measure,
    h: ufl.core.expr.Expr | float,
) -> ufl.Form:
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
    n_defect = t * law.stress(R_eps, A_inv)
    q_defect = t * SHEAR_CORRECTION * law.shear(R_gamma, A_inv)
    work = ufl.inner(n_defect, eps) + ufl.dot(q_defect, gamma)
    alpha = psri_weight(t, h)
    dx_full = dx(metadata={"quadrature_degree": FULL_DEGREE})
    dx_reduced = dx(metadata={"quadrature_degree": REDUCED_DEGREE})
    return -(alpha * work * dx_full + (1 - alpha) * work * dx_reduced)
