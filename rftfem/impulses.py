"""Velocity jumps of prescribed motions in second-order schemes (docs/model.md §6.10).

A ``[[motion]]`` table has corners, and every motion starts from rest at t = 0:
there the driven dofs' velocity jumps.  In a body that is stiff against the
jump (a link hinged to a driven edge), the free dofs must jump with it.
Generalized-α and HHT carry velocity and acceleration from step to step, and a
jump they are not told of comes out of Newmark's relations as a ringing of every
dof the driven ones hold, which HHT α = −0.05 damps by only 0.9 a step.  The
three-link swimmer of demos/three_link.toml then folded twice as far in nine
cycles as it does.

Here, at a step end on a corner (and at the start), the jump is handed to the
whole body as an impulse: the velocity change ``Δv`` that the linearised step
gives when its Dirichlet values are the driven dofs' jump,

    J Δ = 0 on the free rows,   Δ = [v(t⁺) − v(t⁻)] on the driven dofs,

with ``J = c_a M + (1 − α_f) (K + c_v C)`` the step's tangent.  Modes whose
stiffness dominates ``c_a M`` (everything but the hinges' folds, for stiff links)
follow the driven dofs rigidly; a free fold takes its share by its mass.  The
acceleration jump is handed on the same way (the travelling wave's at t = 0).
"""

from __future__ import annotations

import numpy as np
from mpi4py import MPI


def corner(model, solver, t: float, start: bool = False) -> bool:
    """Hand the driven dofs' velocity and acceleration jumps at ``t`` to the body
    (from rest with ``start``).  Returns whether there was a jump."""
    motions = model["prescribed-motion"].motions
    jumps = []
    for motion in motions:
        after = motion.rates(t, side=+1)
        before = (np.zeros_like(after[0]),) * 2 if start else motion.rates(t, side=-1)
        jumps.append((after[0] - before[0], after[1] - before[1]))
    largest = np.zeros(2)
    for dv, da in jumps:
        if len(dv):
            largest = np.maximum(largest, [np.abs(dv).max(), np.abs(da).max()])
    model.comm.Allreduce(MPI.IN_PLACE, largest, op=MPI.MAX)
    if not largest.any():
        return False
    solver.assemble_tangent()
    for k, state in enumerate((model.v_n, model.a_n)):
        if largest[k] == 0.0:
            continue
        for motion, jump in zip(motions, jumps):
            motion.value.x.array[motion.value_dofs] = jump[k]
        delta = solver.dirichlet_response()
        state.x.array[:] += delta[model.u_dofs]
    for motion in motions:
        motion.set(t)
    model.drive_state(t, None)
    return True
