"""UFL forms of rftfem, one module per effect (docs/model.md §3-5)."""
