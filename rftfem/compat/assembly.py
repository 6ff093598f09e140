"""PETSc vectors and matrices of forms: a Function's vector, creation, assembly,
lifting and boundary values."""

from __future__ import annotations

from typing import Any

import dolfinx
import dolfinx.fem
import dolfinx.fem.petsc
from petsc4py import PETSc

from rftfem.compat.compilation import _keyword

ScalarType = PETSc.ScalarType


def petsc_vec(f: dolfinx.fem.Function) -> PETSc.Vec:
    """The PETSc vector wrapping a Function's (owned + ghost) values."""
    x = f.x
    if hasattr(x, "petsc_vec"):
        return x.petsc_vec
    return f.vector


def scatter_add(f: dolfinx.fem.Function) -> None:
    """Sum a Function's ghost entries into their owners, then copy the sums back to
    the ghosts (a nodal sum over cells of several processes)."""
    vec = petsc_vec(f)
    vec.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    vec.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)


def create_vector(L: Any, V: dolfinx.fem.FunctionSpace) -> PETSc.Vec:
    """A ghosted PETSc vector for the linear form ``L`` on space ``V``.

    Here and in the assembly calls below, a form that maps its own unknowns
    (rftfem/model/directors.py, ``MappedForm``) is handed its own method."""
    if hasattr(L, "create_vector"):
        return L.create_vector()
    try:
        return dolfinx.fem.petsc.create_vector(V)
    except (TypeError, AttributeError, RuntimeError):
        return dolfinx.fem.petsc.create_vector(L)


def create_matrix(a: Any, kind: str | None = None) -> PETSc.Mat:
    """A PETSc matrix for the bilinear form ``a``; ``kind`` a PETSc matrix type
    (``"baij"``, ...; None: dolfinx's default), named ``mat_type`` in dolfinx 0.5."""
    if hasattr(a, "create_matrix"):
        return a.create_matrix(kind)
    if kind is None:
        return dolfinx.fem.petsc.create_matrix(a)
    create = dolfinx.fem.petsc.create_matrix
    return create(a, **{_keyword(create, "kind", "mat_type"): kind})


def assemble_vector(b: PETSc.Vec, L: Any) -> None:
    if hasattr(L, "assemble_vector"):
        return L.assemble_vector(b)
    dolfinx.fem.petsc.assemble_vector(b, L)


def assemble_matrix(A: PETSc.Mat, a: Any, bcs: list[dolfinx.fem.DirichletBC]) -> None:
    if hasattr(a, "assemble_matrix"):
        return a.assemble_matrix(A, bcs)
    dolfinx.fem.petsc.assemble_matrix(A, a, bcs=bcs)


def apply_lifting(
    b: PETSc.Vec, a: Any, bcs: list[dolfinx.fem.DirichletBC], x0: PETSc.Vec, scale: float
) -> None:
    """``b -= scale * A (g - x0)`` on the rows coupled to Dirichlet dofs."""
    if hasattr(a, "apply_lifting"):
        return a.apply_lifting(b, bcs, x0, scale)
    dolfinx.fem.petsc.apply_lifting(b, [a], bcs=[bcs], x0=[x0], **{_LIFTING_KEY: scale})


def set_bc(
    b: PETSc.Vec,
    bcs: list[dolfinx.fem.DirichletBC],
    x0: PETSc.Vec | None = None,
    scale: float = 1.0,
) -> None:
    dolfinx.fem.petsc.set_bc(b, bcs, x0, scale)


# an argument renamed between dolfinx versions, detected once: scale → alpha
_LIFTING_KEY = _keyword(dolfinx.fem.petsc.apply_lifting, "alpha", "scale")
