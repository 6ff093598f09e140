"""UFL forms of rftfem, one module per effect (DESIGN.md sections 3-5)."""
