"""Every difference between the FEniCSx stacks rftfem runs on, in one place.

The reference stack is Debian 12's dolfinx 0.5.2 (UFL 2022.2, PETSc 3.18); the
current stack is dolfinx >= 0.10 (the ``dolfinx-solver-real`` wheel, conda-forge,
FEniCS images). Differences are detected by feature (``hasattr``, ``try``), never
by comparing version strings, so a stack in between works if its features do.

Nothing outside this package imports ``basix.ufl``, ``dolfinx.io.gmsh(io)`` or
touches ``Function.vector`` / ``x.petsc_vec``. Its names are all here
(``from rftfem.compat import form``), from one module per concern: ``spaces``
(function spaces and their dof tables), ``compilation`` (the C compiler flags of
the forms), ``assembly`` (PETSc vectors and matrices of forms), ``geometry``
(points on a mesh), ``mesh`` (meshes from gmsh, on one process, their tags),
``stack`` (the versions of the stack and what its PETSc offers) and ``xdmf`` (XDMF
files as ParaView reads them).
"""

from __future__ import annotations

try:  # the dolfinx-solver-real wheel must be imported before dolfinx
    import dolfinx_solver  # noqa: F401
except ImportError:
    pass

import dolfinx  # noqa: F401  (rftfem.compat.dolfinx: the one imported after the wheel)

from rftfem.compat.assembly import (
    ScalarType,
    apply_lifting,
    assemble_matrix,
    assemble_vector,
    create_matrix,
    create_vector,
    petsc_vec,
    scatter_add,
    set_bc,
)
from rftfem.compat.compilation import (
    COMPILE_FLAGS,
    COMPILE_WAIT,
    FLAGS_FROM_ENVIRONMENT,
    form,
    vector_flags,
)
from rftfem.compat.geometry import colliding_cells, nearest_cells
from rftfem.compat.mesh import (
    create_meshtags,
    gmsh_model_to_mesh,
    local_to_global,
    serial_lagrange_mesh,
)
from rftfem.compat.spaces import (
    cell_dofs,
    collapse,
    expression,
    function_space,
    geometry_cells,
    interpolation_points,
    quadrature_space,
)
from rftfem.compat.stack import (
    SNES_NOT_FINITE,
    has_mumps,
    has_scalapack,
    petsc_unlimited,
    versions,
)
from rftfem.compat.xdmf import repair_xdmf_namespace

__all__ = [
    "ScalarType",
    "function_space",
    "quadrature_space",
    "geometry_cells",
    "collapse",
    "cell_dofs",
    "interpolation_points",
    "expression",
    "vector_flags",
    "FLAGS_FROM_ENVIRONMENT",
    "COMPILE_FLAGS",
    "COMPILE_WAIT",
    "SNES_NOT_FINITE",
    "form",
    "petsc_vec",
    "scatter_add",
    "create_vector",
    "create_matrix",
    "assemble_vector",
    "assemble_matrix",
    "apply_lifting",
    "set_bc",
    "colliding_cells",
    "nearest_cells",
    "gmsh_model_to_mesh",
    "serial_lagrange_mesh",
    "local_to_global",
    "create_meshtags",
    "versions",
    "petsc_unlimited",
    "has_mumps",
    "has_scalapack",
    "repair_xdmf_namespace",
]
