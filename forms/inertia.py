"""Translational inertia (docs/model.md §5.3): ``∫ ρ t a·δu dA₀``.

Rotary inertia of the director is neglected: it is of order t²/L² of the
translational inertia for the thin shells this code is for.
"""

import ufl


def inertia_work(rho, t, acceleration, du, dx):
    """Virtual work of the inertia forces, ``∫ ρ t a·δu dA₀``."""
    return rho * t * ufl.dot(acceleration, du) * dx


def kinetic_energy(rho, t, velocity, dx):
    """``½ ∫ ρ t v·v dA₀``."""
    return 0.5 * rho * t * ufl.dot(velocity, velocity) * dx
