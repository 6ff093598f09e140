"""The mesh the fields are written on: the solution's own second-order nodes.

The displacement and the directors are P2, but a straight strip's mesh has only
its vertices as geometry nodes; fields written there are drawn as flat facets
between vertices (a roll-up's turn on eight cells is an octagon).  So the fields
are written on a mesh of their own whose geometry *is* the P2 space: one
9-node (quadrilateral) or 6-node (triangle) cell per cell of the body, nodes at
the P2 dofs.  ParaView and ``rftfem render`` draw these cells curved, and the
values written are the solution's dof values, nothing interpolated.

The mesh lives on rank 0 alone (``COMM_SELF``): every rank sends its owned dofs
there at each output (they are few: a shell is a surface), so the field file is
written by one process and needs no parallel HDF5.  dolfinx numbers a rank's
owned dofs contiguously after the lower ranks', so the gathered arrays are in
global dof order.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from rftfem import compat

if TYPE_CHECKING:
    from dolfinx import fem

#: dolfinx's cell names by number of P2 nodes per cell
_CELLS = {9: "quadrilateral", 6: "triangle"}


class FieldMesh:
    """The P2 nodes of ``V`` (a [P2]³ space on the body's mesh) as a mesh on rank 0.

    ``mesh`` and ``space`` (the [P2]³ space on it) exist on rank 0 only;
    :meth:`gather` fills a Function of ``space`` from a Function of ``V``."""

    def __init__(self, V: fem.FunctionSpace):
        self.V = V
        self.comm = V.mesh.comm
        imap = V.dofmap.index_map
        self.n_owned = imap.size_local
        tdim = V.mesh.topology.dim
        n_cells = V.mesh.topology.index_map(tdim).size_local
        dofs = compat.cell_dofs(V)[:n_cells]
        cells = compat.local_to_global(imap, dofs.ravel()).reshape(dofs.shape)
        x = V.tabulate_dof_coordinates()[: self.n_owned]
        cells = self.comm.gather(cells, root=0)
        x = self.comm.gather(x, root=0)
        self.mesh = self.space = None
        if self.comm.rank != 0:
            return
        cells, x = np.concatenate(cells), np.concatenate(x)
        self.mesh = compat.serial_lagrange_mesh(_CELLS[cells.shape[1]], 2, cells, x)
        self.space = compat.function_space(self.mesh, "Lagrange", 2, (3,))
        # each dof of ``space`` is a geometry node of ``mesh``, which remembers the
        # global P2 dof it was made from
        nodes = compat.geometry_cells(self.mesh)[0]
        source = np.asarray(self.mesh.geometry.input_global_indices, dtype=np.int64)
        order = np.empty(self.space.dofmap.index_map.size_local, dtype=np.int64)
        order[compat.cell_dofs(self.space).ravel()] = source[nodes.ravel()]
        self._order = order

    def gather(self, f: fem.Function, out: fem.Function | None) -> None:
        """Put the values of ``f`` (a Function of ``V``) into ``out`` (a Function of
        ``space``; ``None`` on the other ranks).  Collective."""
        mine = f.x.array[: 3 * self.n_owned].reshape(-1, 3)
        parts = self.comm.gather(mine, root=0)
        if self.comm.rank == 0:
            values = np.concatenate(parts)
            out.x.array[:] = values[self._order].ravel()
