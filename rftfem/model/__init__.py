"""The model: a scene turned into unknowns, state and the sum of its effects' forms.

- ``shell_model``: :class:`Model`, the unknowns (u, θ), the state a step starts
  from, and the residual and tangent forms of the active effects; ``terms``: the
  sum of the effects' terms; ``mapped_forms``: forms on the nodal directors
  assembled on Newton's unknowns;
- ``effects``: one component per effect (elasticity, inertia, drag, Stokes flow,
  magnetic couples, loads, boundaries, motions, hinges, contact), each with its
  scene keys and its UFL terms (the forms themselves are in ``rftfem.forms``);
- the model's parts: ``triad`` (nodal frames), ``directors`` (Newton's unknowns
  mapped to the nodal directors), ``dof_layout`` (where the unknowns sit),
  ``hinges``, ``dirichlet``, ``measures``, ``step_state``, ``reactions``,
  ``materials`` (material fields), ``body_parts`` (several bodies), ``rates`` (the
  scheme's velocity), ``ranks`` (rows of every process put together);
- magnetism: ``magnetic_sources`` (fields, waveforms), ``magnets`` and
  ``magnet_fields`` (permanent magnets and their closed-form fields),
  ``dipoles``, ``dipoles_fmm`` (interactions between magnetized parts);
- the Stokes flow (not UFL): ``stokeslets`` and ``blob_radial`` (the regularized
  kernel; ``stokes_rows`` its dense rows compiled), ``stokes_body`` (the body as
  the operators see it), the integrated layer (``stokes_layer``, ``layer_rules``,
  ``edge_weight``, ``layer_resistance``, ``stokes_kernels``, ``stokes_images``),
  the direct sums (``stokes_direct``, ``stokes_direct_derivative``,
  ``stokes_pairs``), the matrix-free path
  (``stokes_fmm`` with ``stokes_fmm_wall``, ``stokes_matrix_free``), ``dense_factors`` (the dense
  operators' factors, ScaLAPACK's under MPI) and ``stokes_report`` (its cost and
  error).
"""
