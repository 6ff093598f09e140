"""The model: a scene turned into unknowns, state and the sum of its effects' forms.

- ``shell_model``: :class:`Model`, the unknowns (u, θ), the state a step starts
  from, and the residual and tangent forms of the active effects;
- ``effects``: one component per effect (elasticity, inertia, drag, Stokes flow,
  magnetic couples, loads, boundaries, motions, hinges), each with its scene keys
  and its UFL terms (the forms themselves are in ``rftfem.forms``);
- ``triad``, ``hinges``, ``dirichlet``, ``measures``, ``step_state``,
  ``reactions``: the parts of the model (director triads, hinge lines, fixed
  dofs, whole-body measures, a step's prediction, reactions);
- ``magnetic_sources``: fields, waveforms and dipoles;
- ``stokeslets``, ``stokes_fmm``: the nonlocal Stokes operator, dense and
  matrix-free (not UFL).
"""
