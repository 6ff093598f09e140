"""gmsh mesh builders and readers for rftfem."""
