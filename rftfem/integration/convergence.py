"""When a Newton solve of a step has converged, and when it has diverged
(docs/model.md §6.8, §7.2): the convergence test rftfem gives PETSc SNES.

:class:`NewtonTest` is a part of :class:`~rftfem.integration.solver.StepSolver`;
it reads the solver's SNES, options, model and round-off floors.
"""

from __future__ import annotations

import math

from petsc4py import PETSc

#: an iterate whose rotation increment reaches this (rad) has left the range of the
#: director map: past π, d(θ) folds back onto directors of smaller |θ|
ROTATION_RANGE = math.pi
#: an iterate whose residual exceeds this multiple of the larger of the first two
#: has diverged (converging solves stayed within 400 times, diverging ones grew by 1e10
#: to 1e30 before the iteration limit)
RESIDUAL_GROWTH = 1e6
#: two updates whose lengths shrink by at least this ratio show Newton contracting:
#: the distance left to the solution is then estimated from them (``_converged``)
CONTRACTION = 0.5


class NewtonTest:
    """The convergence test of :class:`~rftfem.integration.solver.StepSolver`."""

    def _converged(self, snes, it, norms):
        """PETSc's default test (atol, rtol, stol on the options' values), and more:

        - from the second update on, a residual below the elastic round-off floor
          that the last update did not halve is converged (a stiff membrane under a
          small load: its residual stalls at 1e-9 of E t however small the load, far
          above a tolerance in the load's units; the matrix-free Stokes forces,
          known to their conjugate gradients' tolerance, add theirs: ``floor``).
          The floor is the larger of that and the round-off of the membrane forces
          (``self.noise``, 100 ε E t W): the roll-up at L/t = 1e5 and the sheet with
          drag ×1e-6 stalled there, 5e3 and 30 times above ``snes_atol``.  (Taken as
          converged at once, without the stall, it stopped a link turning in drag,
          whose forces are of that size, 2 % off its rate.)
        - the step test (``stol``) applied to the distance left, not to the update
          just taken: from the second update on, when the last two updates shrank by
          a ratio θ < ``CONTRACTION``, the iterate is at about θ/(1 − θ) times the
          last update from the solution (Newton's contraction, as in Deuflhard's
          error-oriented test), and that estimate below ``stol ‖x‖`` is converged.
          PETSc's own test (the last update below ``stol ‖x‖``) would take one more
          update to learn that the iterate before it was already that close (the
          roll-up at L/t = 1e5: 5.95 updates a step with PETSc's test alone, 5.25).
        - an iterate whose rotation increment reaches ``ROTATION_RANGE`` (π), or
          whose residual grew ``RESIDUAL_GROWTH``-fold, has diverged: the solve stops
          there instead of spending the rest of ``snes_max_it`` (a step too long for
          Newton then costs 1 to 5 updates instead of 25, docs/model.md §6.8).

        PETSc's divergence tolerance (off by rftfem's defaults) is not read: petsc4py
        3.18 cannot."""
        xnorm, snorm, fnorm = norms
        R = PETSc.SNES.ConvergedReason
        if self.watch is not None:
            self.watch.newton(it, fnorm)
        rtol, atol, stol, _ = snes.getTolerances()
        self._record_update(it, snorm, fnorm)
        if not math.isfinite(fnorm):
            return R.DIVERGED_FNORM_NAN
        if fnorm < atol and (it or not self._forced):
            return R.CONVERGED_FNORM_ABS
        if it == 0:
            return R.CONVERGED_ITERATING
        divergence = self._diverged(it, fnorm)
        if divergence is not None:
            self.divergence = divergence
            return R.DIVERGED_DTOL
        if fnorm <= rtol * self._fnorms[0]:
            return R.CONVERGED_FNORM_RELATIVE
        if self.shortened:  # a shortened update is no measure of the distance left
            self.shortened = False
            return R.CONVERGED_ITERATING
        if snorm < stol * xnorm or self._contracted(it, snorm, stol * xnorm):
            return R.CONVERGED_SNORM_RELATIVE
        if it >= 2 and fnorm <= self.floor() and fnorm > 0.5 * self._fnorms[-2]:
            return R.CONVERGED_FNORM_ABS
        return R.CONVERGED_ITERATING

    def _record_update(self, it: int, snorm: float, fnorm: float) -> None:
        """Keep the iterate's residual, and after an update its length and the largest
        rotation increment it reached."""
        if it == 0:
            self._fnorms, self._snorms = [fnorm], []
        else:
            self._fnorms.append(fnorm)
            self._snorms.append(snorm)
            self.turns.append(self.model.largest_rotation_increment())

    def _diverged(self, it: int, fnorm: float) -> str | None:
        """Why the iterate after update ``it`` has diverged (its rotation increment
        reached ``ROTATION_RANGE``, or its residual grew ``RESIDUAL_GROWTH``-fold), or
        None."""
        if self.turns[-1] >= ROTATION_RANGE:
            return (
                f"Newton diverged: a rotation increment reached "
                f"{self.turns[-1]:.3g} rad >= pi at update {it}"
            )
        if it >= 2 and 0.0 < RESIDUAL_GROWTH * max(self._fnorms[:2]) < fnorm:
            return (
                f"Newton diverged: the residual grew to {fnorm:.3e} at update "
                f"{it}, {fnorm / max(self._fnorms[:2]):.1e} times its start"
            )
        return None

    def _contracted(self, it: int, snorm: float, step_tolerance: float) -> bool:
        """Whether the last two updates shrank by a ratio θ < ``CONTRACTION`` and the
        distance left they estimate, θ/(1 − θ) times the last, is below
        ``step_tolerance`` (``stol ‖x‖``)."""
        if it >= 2 and self._snorms[-2] > 0.0:
            theta = snorm / self._snorms[-2]
            if theta < CONTRACTION and theta / (1.0 - theta) * snorm < step_tolerance:
                return True
        return False

    def floor(self) -> float:
        """The residual below which a stall is round-off or solver noise: the elastic
        and membrane forces' floors, and the error of nonlocal forces that an
        iterative solve gave (the Stokes conjugate gradients')."""
        floors = [self.roundoff, self.noise]
        if self.coupled is not None:
            floors += [c.residual_floor() for c in self.coupled.components]
        return max(floors)

    def force_iteration(self, on: bool | None = None) -> None:
        """Whether a solve must take a Newton update even from a residual within
        tolerance: ``on``, or (None) what the options say (default: yes)."""
        if on is None:
            value = self.options.get("snes_force_iteration", False)
            on = value is True or str(value).lower() in ("", "true", "1", "yes", "on")
        self._forced = bool(on)
        self.snes.setForceIteration(self._forced)
