"""Forms on the nodal directors assembled as forms on Newton's unknowns (docs/model.md
§4.2): :class:`MappedForm` is a compiled form on ``z = (u, d)`` whose vectors are
``Pᵀ b_z`` and whose matrices are ``Pᵀ A_z P + G`` in ``w = (u, θ)``
(rftfem/model/directors.py has the map); compat's assembly calls hand such a form
its own methods.  :func:`step_residual_z` is the residual ``G`` contracts.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from collections.abc import Callable

    import dolfinx.fem
    from petsc4py import PETSc

    from rftfem.model.directors import DirectorMap
    from rftfem.model.shell_model import Model


def step_residual_z(model: Model) -> np.ndarray:
    """The z rows of what the step's tangent differentiates, ``(1 − α_f) (F + the
    mixed-point corrections' gradient) + inertia + end forces``, summed over
    processes (local array; owned rows valid): the tangent in ``w`` contracts it with
    the directors' second derivatives.  (Without the corrections' part the thin
    roll-up took 77 load steps instead of 39: the stress predictor lost its director
    terms.)"""
    from petsc4py import PETSc

    from rftfem import compat

    m = model
    if getattr(m, "_rz", None) is None:
        m._rz = (compat.petsc_vec(m.z).duplicate(), compat.petsc_vec(m.z).duplicate())
    total, part = m._rz
    with total.localForm() as local:
        local.set(0.0)
    af = 1.0 - float(m.coef["alpha_f"].value)
    weights = [
        (m.forces_form, af),
        (m.inertia_form, 1.0),
        (m.end_form, float(m.coef["end_weight"].value)),
        (m.correction_form, af),
    ]
    for form, weight in weights:
        if form is None or weight == 0.0:
            continue
        with part.localForm() as local:
            local.set(0.0)
        compat.assemble_vector(part, getattr(form, "form", form))
        with total.localForm() as t_local, part.localForm() as p_local:
            t_local.axpy(weight, p_local)
    total.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    return total.array_r


class MappedForm:
    """A compiled form on ``z`` whose vectors (rank 1) and matrices (rank 2) are
    assembled in ``w``: ``Pᵀ b_z`` and ``Pᵀ A_z P + G``.  compat's assembly calls
    hand such a form its own methods, so callers treat it as a form on ``w``.

    ``residual`` (rank 2): a callable giving the local z array, ghost rows summed, of
    the residual whose tangent the form is (for ``G``); None leaves ``G`` out.
    """

    def __init__(
        self,
        form: dolfinx.fem.Form,
        directors: DirectorMap,
        residual: Callable[[], np.ndarray] | None = None,
    ):
        self.form, self.directors, self.residual = form, directors, residual
        self.rank = form.rank
        self._z_vector = self._Az = self._C = None
        self._blocks = None  # the node-block pattern of A_z (_BlockPattern)

    def create_vector(self) -> PETSc.Vec:
        from rftfem import compat

        return compat.petsc_vec(self.directors.model.w).duplicate()

    def assemble_vector(self, b: PETSc.Vec) -> None:
        """``b += Pᵀ b_z`` (local rows, unsummed, as dolfinx's own assembly leaves them)."""
        from rftfem import compat

        self.directors.sync(derivatives=True)
        if self._z_vector is None:
            self._z_vector = compat.petsc_vec(self.directors.z).duplicate()
        zvec = self._z_vector
        with zvec.localForm() as zl:
            zl.set(0.0)
        compat.assemble_vector(zvec, self.form)
        with zvec.localForm() as zl, b.localForm() as bl:
            self.directors.add_transposed(zl.array_r, bl.array)

    def tangent(self) -> PETSc.Mat:
        """``Pᵀ A_z P + G`` at the model's iterate, without conditions (kept; AIJ)."""
        from petsc4py import PETSc

        from rftfem import compat

        dm = self.directors
        dm.sync(derivatives=True)
        if self._Az is None:  # blocked: dolfinx inserts a node pair's block at once
            self._Az = compat.create_matrix(self.form, "baij")
        self._Az.zeroEntries()
        compat.assemble_matrix(self._Az, self.form, [])
        self._Az.assemble()
        dm.update_P()
        if self._C is None:  # PETSc's PtAP takes AIJ: the blocked matrix converted
            self._Az_aij = self._Az.convert("aij", out=PETSc.Mat())
            self._C = self._Az_aij.PtAP(dm.P)
        else:
            self._Az.convert("aij", out=self._Az_aij)
            self._Az_aij.PtAP(dm.P, result=self._C)
        if self.residual is not None:
            dm.update_G(self.residual())
            self._C.axpy(1.0, dm.G, structure=PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)
        return self._C

    def create_matrix(self, kind: str | None = None) -> PETSc.Mat:
        from petsc4py import PETSc

        """A zero matrix of ``w`` with the tangent's pattern (as dolfinx's own)."""
        C = self.tangent()  # blocked as P's columns: a node's unknowns of w
        if kind is None or "aij" in kind and "baij" not in kind:
            A = C.duplicate()  # (duplicate copies no values)
        else:
            A = C.convert(kind, out=PETSc.Mat())  # (without ``out``: C itself, converted)
        A.zeroEntries()
        return A

    def assemble_matrix(self, A: PETSc.Mat, bcs: list[dolfinx.fem.DirichletBC]) -> None:
        """``A += Pᵀ A_z P + G``, then the rows and columns of ``bcs``' dofs zero with
        1 on the diagonal (as dolfinx's own assembly with conditions).

        ``P`` is block-diagonal by node, so ``Pᵀ A_z P`` is computed block by block in
        numpy from ``A_z``'s values (each node pair's (3+3c)² block turned into a
        (3+2c)² one) and inserted into ``A`` a block at a time: for the sheet's 369
        nodes a third of the time of PETSc's conversion and product."""
        from petsc4py import PETSc

        from rftfem import compat

        dm = self.directors
        dm.sync(derivatives=True)
        if self._Az is None:
            self._Az = compat.create_matrix(self.form, "baij")
        self._Az.zeroEntries()
        compat.assemble_matrix(self._Az, self.form, [])
        self._Az.assemble()
        if self._blocks is None:
            self._blocks = _BlockPattern(self._Az, dm)
        bp = self._blocks
        if not bp.complete:  # a node's B is on another process: PETSc's product
            A.assemble()
            A.axpy(1.0, self.tangent(), structure=PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)
            A.assemble()
            A.zeroRowsColumns(self._owned_rows(bcs), diag=1.0)
            return
        _, _, values = self._Az.getValuesCSR()
        P = dm.node_matrices()
        blocks = values[bp.positions]  # (blocks, bz, bz)
        out = np.matmul(
            np.transpose(P[bp.row_nodes], (0, 2, 1)), np.matmul(blocks, P[bp.col_nodes])
        )
        if self.residual is not None:
            out[bp.diagonal] += dm.node_curvatures(self.residual())
        A.assemble()
        A.setValuesBlockedCSR(
            bp.indptr, bp.col_global, out.ravel(), addv=PETSc.InsertMode.ADD_VALUES
        )
        A.assemble()
        A.zeroRowsColumns(self._owned_rows(bcs), diag=1.0)

    def apply_lifting(
        self, b: PETSc.Vec, bcs: list[dolfinx.fem.DirichletBC], x0: PETSc.Vec, scale: float
    ) -> None:
        """``b −= scale · K (g − x0)`` for the columns of ``bcs``' dofs (owned rows)."""
        from rftfem import compat

        K = self.tangent()
        v = b.duplicate()
        with v.localForm() as local:
            local.set(0.0)
        compat.set_bc(v, bcs, x0, 1.0)
        y = K.createVecLeft()
        K.mult(v, y)
        with b.localForm() as bl:
            bl.array[: len(y.array_r)] -= scale * y.array_r
        for obj in (v, y):
            obj.destroy()

    def _owned_rows(self, bcs) -> np.ndarray:
        """Global numbers of the owned dofs of ``w`` that ``bcs`` hold."""
        from petsc4py import PETSc

        from rftfem import compat

        dm = self.directors
        bw, owned = dm.bw, dm.owned * dm.bw
        local = [bc.dof_indices()[0] for bc in bcs]
        local = np.unique(np.concatenate(local)) if local else np.zeros(0, dtype=np.int64)
        local = local[local < owned]
        im = dm.model.W.dofmap.index_map
        nodes = compat.local_to_global(im, local // bw)
        return (nodes * bw + local % bw).astype(PETSc.IntType)

    def destroy(self) -> None:
        for obj in (self._z_vector, self._Az, self._C, getattr(self, "_Az_aij", None)):
            if obj is not None:
                obj.destroy()


def _mpi_and():
    from mpi4py import MPI

    return MPI.LAND


class _BlockPattern:
    """Where each node pair's block of a blocked matrix on ``z`` sits in its point
    CSR values (owned rows; each row holds whole node blocks, sorted by node), and
    the block CSR of the matrix on ``w`` that the transformed blocks go into."""

    def __init__(self, Az, dm):
        from petsc4py import PETSc

        from rftfem import compat

        bz, owned = dm.bz, dm.owned
        indptr, cols, _ = Az.getValuesCSR()
        starts = np.asarray(indptr[:-1]).reshape(owned, bz)
        # a node's bz rows hold bz × (its neighbour nodes × bz) entries
        neighbours = (np.asarray(indptr[bz::bz]) - np.asarray(indptr[0:-1:bz])) // bz**2
        self.row_nodes = np.repeat(np.arange(owned), neighbours)
        k = np.arange(int(neighbours.sum())) - np.repeat(
            np.cumsum(neighbours) - neighbours, neighbours
        )
        #: positions in the values of each block's entries, (blocks, bz, bz)
        self.positions = (
            starts[self.row_nodes][:, :, None]
            + (k * bz)[:, None, None]
            + np.arange(bz)[None, None, :]
        )
        col_global = np.asarray(cols)[starts[self.row_nodes, 0] + k * bz] // bz
        im = dm.model.W.dofmap.index_map
        first = im.local_range[0]
        ghosts = compat.local_to_global(im, np.arange(owned, dm.nodes))
        local = np.where(
            (col_global >= first) & (col_global < first + owned), col_global - first, -1
        )
        off = local < 0
        #: whether every column node is on this process (owned or ghost); a node of a
        #: cell of another process only, coupled to an owned one, is not, and its ``B``
        #: is not here: then PETSc's product serves (``complete`` is global)
        found = True
        if off.any():
            order = np.argsort(ghosts)
            at = np.minimum(np.searchsorted(ghosts[order], col_global[off]), len(order) - 1)
            found = bool(len(order)) and bool(np.all(ghosts[order][at] == col_global[off]))
            local[off] = owned + order[at] if len(order) else 0
        self.complete = dm.model.comm.allreduce(found, op=_mpi_and())
        self.col_nodes = local
        self.col_global = col_global.astype(PETSc.IntType)
        self.diagonal = np.flatnonzero(self.row_nodes == local)
        self.indptr = np.concatenate([[0], np.cumsum(neighbours)]).astype(PETSc.IntType)
