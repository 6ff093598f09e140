"""Many runs of a scene: studies, sweeps, design and sensitivities.

- ``study``, ``study_levels``, ``study_report``: ``rftfem study`` (refinement
  studies, accuracy against cost);
- ``sweep``, ``sweep_vary``, ``sweep_report``: ``rftfem sweep`` (a grid of values);
- ``optimize``, ``optimize_options``, ``optimize_parameters``,
  ``optimize_methods``, ``optimize_evaluations``, ``optimize_gradients``,
  ``optimize_report``, ``objective``: ``rftfem optimize`` (the design loop);
  ``optimize_fields``, ``optimize_field_design``, ``optimize_field_cli``: its
  ``--vary-field`` loop over a material field;
- ``sensitivity``, ``sensitivity_adjoint``, ``sensitivity_request``,
  ``field_gradients``, ``gradient_runs``: exact gradients by the adjoint;
- ``executors``, ``slurm``: where runs happen (processes, Dask, SLURM);
  ``batch``: many runs in one process; ``reuse``: what ``--reuse`` compares.
"""
