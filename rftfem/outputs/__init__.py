"""What a run leaves behind, and reading it again.

- ``writers``: probes.csv, body.csv, steps.csv and the fields (XDMF);
  ``field_mesh``: the mesh the fields are written on; ``progress``: the progress
  line and warnings while a run runs; ``console``: what the command line prints;
- ``checkpoint``: what a checkpoint holds and what a restart reads (the run's
  side of both is in ``rftfem.integration``: ``run_outputs``, ``restart``);
- ``run_folder``: a results folder as read again; ``quantities``: the quantity
  language over it; ``formulas``: arithmetic of quantities and scene values
  (every command's ``--quantity``, optimize's objective); ``collect``: tables of
  many folders;
- ``render``, ``render_picture``, ``render_body``, ``render_view``,
  ``render_cli``: pictures and films (pyvista, never dolfinx; ``compat_render``
  says why); ``xdmf_repair``: fields.xdmf as VTK reads it; ``rigid_fit``: the
  best-fit rigid motion ``render --scale`` keeps true (numpy only).
"""
