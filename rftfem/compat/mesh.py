"""Meshes: from a gmsh model, on one process alone, their tags and global numbers."""

from __future__ import annotations

from typing import TYPE_CHECKING

import dolfinx
import dolfinx.mesh
import numpy as np
import ufl

from rftfem.compat.spaces import _HAS_BASIX_UFL, _basix_ufl

if TYPE_CHECKING:
    import dolfinx.common
    import gmsh
    from mpi4py import MPI


def gmsh_model_to_mesh(
    model: type[gmsh.model] | None, comm: MPI.Comm, rank: int = 0, gdim: int = 3
) -> tuple[dolfinx.mesh.Mesh, dolfinx.mesh.MeshTags, dolfinx.mesh.MeshTags]:
    """(mesh, cell_tags, facet_tags) from a gmsh model built on ``rank``."""
    try:
        from dolfinx.io import gmsh as _gmshio  # dolfinx >= 0.10
    except ImportError:
        from dolfinx.io import gmshio as _gmshio  # dolfinx 0.5 - 0.9
    out = _gmshio.model_to_mesh(model, comm, rank, gdim=gdim, **_shared_facet_partitioner())
    if hasattr(out, "mesh"):  # MeshData (>= 0.10)
        return out.mesh, out.cell_tags, out.facet_tags
    return out[0], out[1], out[2]


def _shared_facet_partitioner() -> dict:
    """``partitioner=`` keeping both cells of every facet on the processes that share
    it (ghost mode ``shared_facet``), which interior-facet integrals (``dS``, the
    spring hinges) need across a partition.  dolfinx >= 0.10 defaults to no ghost
    cells and its ``create_cell_partitioner(mode, max_facet_to_cell_links)`` takes
    the mode; 0.6-0.9 take the mode alone; 0.5 passes the mode to ``create_mesh``
    instead, and its gmsh reader already asks for ``shared_facet``."""
    make = getattr(dolfinx.mesh, "create_cell_partitioner", None)
    mode = dolfinx.mesh.GhostMode.shared_facet
    for args in ((mode, 2), (mode,)):
        try:
            return {"partitioner": make(*args)}
        except TypeError:
            continue
    return {}


def serial_lagrange_mesh(
    cell: str, degree: int, cells: np.ndarray, x: np.ndarray
) -> dolfinx.mesh.Mesh:
    """A mesh on this process alone (``COMM_SELF``) with Lagrange geometry of
    ``degree`` on ``cell`` ("quadrilateral"/"triangle") in 3D, from nodes ``x``
    and ``cells`` in dolfinx's node order.  0.5 takes ``(comm, cells, x, domain)``
    with a UFL element, 0.10 on ``(comm, cells, e, x)`` with a basix one."""
    from mpi4py import MPI

    if _HAS_BASIX_UFL:
        domain = ufl.Mesh(_basix_ufl.element("Lagrange", cell, degree, shape=(3,)))
        return dolfinx.mesh.create_mesh(MPI.COMM_SELF, cells, domain, x)
    domain = ufl.Mesh(ufl.VectorElement("Lagrange", ufl.Cell(cell, geometric_dimension=3), degree))
    return dolfinx.mesh.create_mesh(MPI.COMM_SELF, cells, x, domain)


def local_to_global(index_map: dolfinx.common.IndexMap, local: np.ndarray) -> np.ndarray:
    """Global numbers of the local indices ``local`` of ``index_map``."""
    return np.asarray(index_map.local_to_global(np.asarray(local, dtype=np.int32)), dtype=np.int64)


def create_meshtags(
    mesh: dolfinx.mesh.Mesh, dim: int, entities: np.ndarray, values: np.ndarray
) -> dolfinx.mesh.MeshTags:
    order = np.argsort(entities)
    return dolfinx.mesh.meshtags(
        mesh, dim, entities[order].astype(np.int32), values[order].astype(np.int32)
    )
