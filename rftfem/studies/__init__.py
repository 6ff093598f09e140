"""Many runs of a scene: studies, design and sensitivities.

- ``study``, ``study_report``: ``rftfem study`` (refinement studies, accuracy
  against cost);
- ``optimize``, ``optimize_evaluations``, ``optimize_report``, ``objective``:
  ``rftfem optimize`` (the design loop);
- ``sensitivity``, ``sensitivity_request``: exact gradients by the adjoint;
- ``batch``: many runs in one process.
"""
