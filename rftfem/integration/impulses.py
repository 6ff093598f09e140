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

from typing import TYPE_CHECKING

import numpy as np
from mpi4py import MPI

if TYPE_CHECKING:
    from petsc4py import PETSc

    from rftfem.integration.solver import StepSolver
    from rftfem.model.shell_model import Model


def corner(model: Model, solver: StepSolver, t: float, start: bool = False) -> bool:
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


def initial_acceleration(model: Model, solver: StepSolver) -> None:
    """The acceleration the forces at t = 0 give the body at rest: ``a(0)`` from

        M a = −F(u₀, t = 0)   on the rows with mass,   a = 0 on the others,

    ``F`` the non-inertial forces (internal minus external; no drag at rest) and ``M``
    the mass matrix.  Rows without mass (the rotations, whose inertia is neglected,
    and the nodes of massless parts) and Dirichlet rows hold ``a = 0``; a motion's own
    acceleration at the start is handed on after this by :func:`corner`.  Without it
    generalized-α would start from ``a = 0`` under a load already on at t = 0 and
    lag the exact motion ``F t²/(2m)`` of a free body by a transient
    (docs/model.md §6.7).  The model's loads and time must be set to t = 0."""
    from petsc4py import PETSc

    from rftfem import compat

    comm = model.comm
    F = _forces_at_start(model, solver)
    M = _mass_matrix(model, solver)
    diag = M.getDiagonal()
    scale = diag.norm(PETSc.NormType.NORM_INFINITY)
    massless = np.flatnonzero(np.abs(diag.array) <= 1e-12 * scale)
    first = M.getOwnershipRange()[0]
    M.zeroRows((first + massless).astype(PETSc.IntType), diag=1.0)
    F.scale(-1.0)
    F.array[massless] = 0.0
    compat.set_bc(F, model.bcs, None, 0.0)  # a = 0 on the Dirichlet rows
    a = F.duplicate()
    ksp = PETSc.KSP().create(comm)
    try:
        ksp.setOperators(M)
        ksp.setType("preonly")
        pc = ksp.getPC()
        pc.setType("lu")
        pc.setFactorSolverType("mumps" if compat.has_mumps() else "petsc")
        ksp.solve(F, a)
        if ksp.getConvergedReason() < 0:
            raise RuntimeError(
                f"the mass matrix could not be factorised (KSP reason {ksp.getConvergedReason()})"
            )
        a.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        with a.localForm() as local:
            model.a_n.x.array[:] = local.array[model.u_dofs]
    finally:
        for obj in (ksp, M, F, a, diag):
            obj.destroy()


def _forces_at_start(model: Model, solver: StepSolver) -> PETSc.Vec:
    """A new vector of the non-inertial forces ``F(u₀, t = 0)``, the contact forces
    among them."""
    from petsc4py import PETSc

    from rftfem import compat

    F = compat.create_vector(model.forces_form, model.W)
    solver.assemble_forces(F)
    if model.end_form is not None:  # the contact forces at t = 0
        F_end = F.duplicate()
        with F_end.localForm() as local:
            local.set(0.0)
        compat.assemble_vector(F_end, model.end_form)
        F_end.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        F.axpy(1.0, F_end)
        F_end.destroy()
    return F


def _mass_matrix(model: Model, solver: StepSolver) -> PETSc.Mat:
    """A new assembled mass matrix ``M`` at the model's state (its Dirichlet rows
    those of the step's Jacobian); the model's coefficients are left as they were."""
    from rftfem import compat, petsc_options
    from rftfem.integration.schemes import Coefficients

    # the mass matrix: the step's Jacobian with c_a = 1 and the forces weighted by 1 − α_f = 0
    saved = model.coefficients
    model.set_coefficients(Coefficients(ca=1.0, alpha_f=1.0, end_weight=0.0))
    M = compat.create_matrix(model.jacobian_form, petsc_options.matrix_type(solver.options))
    model.start_newton()
    model.tangent_at_iterate()
    compat.assemble_matrix(M, model.jacobian_form, model.bcs)
    M.assemble()
    model.set_coefficients(saved)
    return M


def frictional_acceleration(model: Model, solver: StepSolver, dt: float) -> None:
    """The acceleration at t = 0 of a body that rests on a plane with friction.

    A regularized Coulomb law has no force at zero slip, so :func:`initial_acceleration`
    gives such a body the acceleration it would have on ice, and the first step
    starts it sliding where static friction should hold it.  Here the acceleration
    is instead the mean one of a first step ``dt`` from rest, found with every force,
    friction at that step's slip rate among them (docs/contact.md §3):

        M a + F(u₀ + ½ a dt²) = 0,   the slip rate (u − u₀)/dt,

    solved by Newton for ``u``, then ``a = 2 (u − u₀)/dt²``; the state is restored.
    """
    from rftfem.integration.schemes import Coefficients

    saved = model.coefficients
    holding = [c for c in model.components if c.holds_at_rest()]  # friction (contact)
    model.set_coefficients(Coefficients(cv=1.0 / dt, ca=2.0 / dt**2, dt=dt))
    for c in holding:  # its step of slip now has this dt
        c.set_time(0.0)
    try:
        ok, its, res, reason = solver.solve()
        if not ok:
            raise RuntimeError(f"the first step's mean acceleration on the planes: {reason}")
        u = model.w.x.array[model.u_dofs]
        model.a_n.x.array[:] = 2.0 * (u - model.u_n.x.array) / dt**2
    finally:
        model.restore()
        model.set_coefficients(saved)
        for c in holding:
            c.set_time(0.0)
        solver.forget_forces()
