"""Follower pressure (docs/model.md §5.6): a load normal to the current surface."""

import ufl


def follower_pressure_work(p, g1, g2, G1, G2, du, dx):
    """``∫ p (g₁ × g₂)·δu / |G₁ × G₂| dA₀``: the work of a pressure ``p`` along the
    current normal on the current area (positive along g₁ × g₂, the side the
    reference normal points to)."""
    return (
        p
        * ufl.dot(ufl.cross(g1, g2), du)
        / ufl.sqrt(ufl.dot(ufl.cross(G1, G2), ufl.cross(G1, G2)))
        * dx
    )
