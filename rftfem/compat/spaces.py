"""Function spaces and their dof tables: elements from UFL (dolfinx 0.5) or basix
(0.10 on), the geometry's cells, collapsed sub-spaces, interpolation points."""

from __future__ import annotations

import dolfinx
import dolfinx.fem
import dolfinx.mesh
import numpy as np
import ufl

try:
    import basix.ufl as _basix_ufl

    _HAS_BASIX_UFL = hasattr(_basix_ufl, "element") and hasattr(_basix_ufl, "mixed_element")
except ImportError:  # dolfinx 0.5: elements come from UFL
    _basix_ufl = None
    _HAS_BASIX_UFL = False


def _element(mesh, family: str, degree: int, shape: tuple[int, ...] = ()):
    """A Lagrange/DG element on ``mesh``'s cell with the given value shape."""
    if _HAS_BASIX_UFL:
        kwargs = {"shape": shape} if shape else {}
        if family in ("DG", "Discontinuous Lagrange"):
            return _basix_ufl.element(
                "Lagrange", mesh.basix_cell(), degree, discontinuous=True, **kwargs
            )
        return _basix_ufl.element(family, mesh.basix_cell(), degree, **kwargs)
    cell = mesh.ufl_cell()
    if family == "DG" and cell.cellname() in ("quadrilateral", "hexahedron"):
        family = "DQ"
    if shape:
        return ufl.VectorElement(family, cell, degree, dim=shape[0])
    return ufl.FiniteElement(family, cell, degree)


def _functionspace(mesh, element):
    if hasattr(dolfinx.fem, "functionspace"):
        return dolfinx.fem.functionspace(mesh, element)
    return dolfinx.fem.FunctionSpace(mesh, element)


def function_space(
    mesh: dolfinx.mesh.Mesh, family: str, degree: int, shape: tuple[int, ...] = ()
) -> dolfinx.fem.FunctionSpace:
    """``family``/``degree`` space with value ``shape`` (``()`` scalar, ``(3,)`` vector)."""
    return _functionspace(mesh, _element(mesh, family, degree, shape))


def quadrature_space(
    mesh: dolfinx.mesh.Mesh, degree: int, shape: tuple[int, ...] = ()
) -> dolfinx.fem.FunctionSpace:
    """A space of values at the points of the cell's default quadrature rule of
    ``degree`` (a form that uses it must integrate with that rule: ``quadrature_degree``
    ``degree``); dolfinx 0.5 makes the element in UFL, 0.11 in basix."""
    if _HAS_BASIX_UFL:
        element = _basix_ufl.quadrature_element(
            mesh.basix_cell(), value_shape=shape, scheme="default", degree=degree
        )
    elif shape:
        element = ufl.VectorElement(
            "Quadrature", mesh.ufl_cell(), degree, dim=shape[0], quad_scheme="default"
        )
    else:
        element = ufl.FiniteElement("Quadrature", mesh.ufl_cell(), degree, quad_scheme="default")
    return _functionspace(mesh, element)


def geometry_cells(mesh: dolfinx.mesh.Mesh) -> tuple[np.ndarray, int]:
    """The geometry nodes of every cell as a (num_cells, nodes) array, and the
    geometry's degree (1: straight cells, 2: curved ones from a second-order gmsh
    file); dolfinx 0.5 gives an AdjacencyList, 0.11 an array (one per cell type,
    ``dofmaps``)."""
    g = mesh.geometry
    if isinstance(getattr(g, "cmaps", None), list):  # one per cell type (0.10 on)
        cmap, dm = g.cmaps[0], g.dofmaps[0]
    else:
        cmap = g.cmap() if callable(g.cmap) else g.cmap
        dm = g.dofmap
    cells = dm if isinstance(dm, np.ndarray) else dm.array.reshape(-1, dm.links(0).size)
    return cells, int(cmap.degree)


def collapse(sub: dolfinx.fem.FunctionSpace) -> tuple[dolfinx.fem.FunctionSpace, np.ndarray]:
    """``sub.collapse()`` as (space, the sub-space's dofs in the parent as one flat int64
    array): dolfinx 0.5 gives a list of ints, 0.11 a list holding one array."""
    V, dofs = sub.collapse()
    return V, np.asarray(dofs, dtype=np.int64).reshape(-1)


def cell_dofs(V: dolfinx.fem.FunctionSpace) -> np.ndarray:
    """Cell-to-(blocked)-dof table of ``V`` as a (num_cells, dofs_per_cell) array."""
    dm = V.dofmap.list
    if isinstance(dm, np.ndarray):
        return dm
    return dm.array.reshape(-1, V.dofmap.dof_layout.num_dofs)  # AdjacencyList (0.5)


def interpolation_points(V: dolfinx.fem.FunctionSpace) -> np.ndarray:
    pts = V.element.interpolation_points
    return pts() if callable(pts) else pts


def expression(expr: ufl.core.expr.Expr, V: dolfinx.fem.FunctionSpace) -> dolfinx.fem.Expression:
    """A compiled expression evaluated at ``V``'s interpolation points."""
    return dolfinx.fem.Expression(expr, interpolation_points(V))
