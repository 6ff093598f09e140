"""Time stepping and path following: a run of a scene.

- ``simulation``: :class:`Simulation`, the run: it composes the parts below and
  orchestrates them; ``run_view``: what callers read of it; ``run_report``: what
  it says (progress, summary.json, last line); ``run_state``: where the run is
  (time, steps, counts) and what its loops call back; ``model_setup``: the model
  a scene builds;
- ``schemes``: the time integrators (generalized-α, HHT, backward Euler, BDF2,
  static); ``step_control``: the step controller (one step, its cuts and growth,
  fixed steps); ``initial_state``: equilibrium at the start; ``error_control``:
  the time-error estimate and error-controlled steps; ``arclength`` and
  ``arc_newton``: static path following and its bordered Newton solve;
  ``steady``: stopping once periodic;
- ``solver``, ``assembly``, ``convergence``, ``factorization``, ``coupled``: the
  Newton solve of a step around PETSc SNES (the residual and tangent, when it has
  converged, the tangent's factorisation, the nonlocal operator's coupling);
- ``run_outputs``, ``restart``: the run's outputs and summary.json, its
  checkpoints and going on from them (the files themselves: ``rftfem.outputs``);
- ``impulses``: velocity jumps of prescribed motions; ``interrupts`` and
  ``step_watch``: signals, and slow steps made visible and stoppable.
"""
