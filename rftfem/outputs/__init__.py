"""What a run leaves behind, and reading it again.

- ``writers``: probes.csv, body.csv, steps.csv, the fields (XDMF) and the
  progress line; ``field_mesh``: the mesh the fields are written on;
- ``checkpoint``: what a checkpoint holds and what a restart reads (the run's
  side of both is in ``rftfem.integration``: ``run_outputs``, ``restart``);
- ``quantities``: the quantity language over a results folder; ``collect``:
  tables of many folders;
- ``render``, ``render_body``, ``render_view``, ``render_cli``: pictures and
  films (pyvista, never dolfinx; ``compat_render`` says why).
"""
