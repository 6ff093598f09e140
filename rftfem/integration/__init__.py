"""Time stepping and path following: a run of a scene.

- ``simulation``: :class:`Simulation`, the run: it composes the parts below and
  orchestrates them; ``run_state``: where the run is (time, steps, counts) and
  what its loops call back;
- ``schemes``: the time integrators (generalized-α, HHT, backward Euler, BDF2,
  static); ``step_control``: the step controller (one step, its cuts and growth,
  fixed steps); ``error_control``: the time-error estimate and error-controlled
  steps; ``arclength``: static path following; ``steady``: stopping once periodic;
- ``solver``, ``factorization``, ``coupled``: the Newton solve of a step around
  PETSc SNES (the tangent's factorisation, the nonlocal operator's coupling);
- ``run_outputs``, ``restart``: the run's outputs and summary.json, its
  checkpoints and going on from them (the files themselves: ``rftfem.outputs``);
- ``impulses``: velocity jumps of prescribed motions; ``interrupts``: signals.
"""
