"""When the Newton tangent is factorised (``solver.factorization``, docs/model.md §7.7).

A MUMPS factorisation of the tangent costs several Jacobian assemblies on large
meshes (at 59k unknowns 2 s against 0.4 s), and in a time run the tangent changes
little from one step to the next.  The policies that keep factors solve each
Newton system by GMRES on the current tangent, preconditioned by the factors of an
older one; the Newton updates are exact to GMRES's tolerance, so the answer does
not depend on the policy.

- ``"every-iteration"``: new factors for every tangent, a direct solve;
- ``"every-step"``: new factors for a solve's first tangent;
- ``"reused"``: new factors when the last linear solve took more than
  ``REUSE_ITERATIONS`` GMRES iterations or failed.  A solve whose GMRES gives up on
  old factors is made again from its start with new factors for every tangent, and
  so are the next solves, for a spell that doubles with each such failure (a
  static roll-up, whose tangent changes between iterates, ends up factorising
  nearly every tangent) and is forgotten once old factors serve a whole solve.

SNES is told to keep its preconditioner (``snes_lag_preconditioner -2``:
factorise once, then never); new factors are made here, in the Jacobian callback.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from rftfem import petsc_options

if TYPE_CHECKING:
    from petsc4py import PETSc

#: the longest spell of solves that factorise every tangent after old factors failed
LONGEST_SPELL = 64


class Factorization:
    """The choice, tangent by tangent, of a ``StepSolver``'s factors."""

    def __init__(self, policy: str):
        self.policy = policy
        #: factorisations made
        self.made = 0
        self._next_fresh = True  # the next tangent gets new factors
        self._spell, self._spell_left = 1, 0  # solves that factorise every tangent
        self._every_tangent = False  # in the solve under way
        self._stale_used = False  # old factors served a tangent of this solve
        self._tangents = 0  # tangents of the solve under way
        #: the last tangent's solve used older factors
        self.stale = False

    @property
    def keeps_factors(self) -> bool:
        return self.policy != "every-iteration"

    def start_solve(self, retry: bool = False) -> None:
        """A Newton solve begins (``retry``: the same solve again after GMRES failed
        on old factors; it and the next solves of a spell factorise every tangent)."""
        if retry:
            self._spell_left = self._spell
            self._spell = min(2 * self._spell, LONGEST_SPELL)
        self._every_tangent = self._spell_left > 0
        self._spell_left -= self._every_tangent
        self._tangents, self._stale_used, self.stale = 0, False, False

    def end_solve(self, converged: bool) -> None:
        """The solve ended: old factors that served a converged one reset the spell."""
        if converged and self._stale_used:
            self._spell = 1

    def choose(self, ksp: PETSc.KSP, A: PETSc.Mat) -> bool:
        """Whether the tangent ``A`` just assembled gets new factors (made here, for
        ``ksp``'s preconditioner); True for every tangent of the "every-iteration"
        policy, which SNES factorises itself."""
        self._tangents += 1
        if not self.keeps_factors:
            self.made += 1
            return True
        if self.policy == "every-step" or self._every_tangent:
            fresh = self._tangents == 1 or self._every_tangent
        else:
            fresh = (
                self._next_fresh
                or ksp.getConvergedReason() < 0
                or ksp.getIterationNumber() > petsc_options.REUSE_ITERATIONS
            )
        if fresh:
            self.made += 1
            if self.made > 1:  # (SNES makes the first factors itself)
                self._factorise(ksp, A)
        self._next_fresh = False
        self._stale_used |= not fresh
        self.stale = not fresh
        return fresh

    @staticmethod
    def _factorise(ksp, A):
        """Factorise ``A`` into ``ksp``'s preconditioner now: SNES, told to keep its
        preconditioner, then leaves these factors alone.  The matrix keeps its
        nonzero pattern, so MUMPS's analysis is kept and only the numerical
        factorisation is made."""
        operator = ksp.getOperators()[0]  # a coupled tangent's shell matrix stays
        ksp.setOperators(operator if operator.getType() == "python" else A, A)
        pc = ksp.getPC()
        pc.setReusePreconditioner(False)
        pc.setUp()
