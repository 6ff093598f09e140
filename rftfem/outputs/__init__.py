"""What a run leaves behind, and reading it again.

- ``writers``: probes.csv, body.csv, steps.csv and the fields (XDMF);
  ``field_mesh``: the mesh the fields are written on; ``progress``: the progress
  line and warnings while a run runs;
- ``checkpoint``: what a checkpoint holds and what a restart reads (the run's
  side of both is in ``rftfem.integration``: ``run_outputs``, ``restart``);
- ``quantities``: the quantity language over a results folder; ``formulas``:
  arithmetic of quantities and scene values (every command's ``--quantity``,
  optimize's objective); ``collect``: tables of many folders;
- ``render``, ``render_body``, ``render_view``, ``render_cli``: pictures and
  films (pyvista, never dolfinx; ``compat_render`` says why); ``rigid_fit``: the
  best-fit rigid motion ``render --scale`` keeps true (numpy only).
"""
