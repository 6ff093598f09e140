"""Gravity (docs/model.md §5.6): a body force per reference area."""

import ufl


def body_force_work(rho, t, g, du, dx):
    """``∫ ρ t g·δu dA₀``: the work of the weight of a shell of density ``rho`` (net of
    buoyancy if the fluid's density is subtracted) and thickness ``t``."""
    return rho * t * ufl.dot(g, du) * dx
