"""The time scheme's velocity, the one relation every effect with rates uses (the
shell's UFL velocity, the Stokes flow's nodal velocities, a motion's corrections)."""

from __future__ import annotations


def scheme_velocity(du, v_n, a_n, cv, cv_v, cv_a):
    """The velocity a step's scheme gives its end, ``v = c_v Δu + c_v^v v_n + c_v^a a_n``
    (docs/model.md §6), of UFL expressions or arrays alike; the coefficients are
    numbers or constants."""
    return cv * du + cv_v * v_n + cv_a * a_n
