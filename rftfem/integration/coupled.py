"""The Newton operator of a step with nonlocal effects (the Stokes flow).

The assembled tangent ``A`` holds every UFL term.  A nonlocal effect
(:class:`~rftfem.model.effects.base.NonlocalEffect`) adds a dense block on the
unknowns it acts on (its ``unknowns``: the displacement's three components for the
Stokes flow) that is never assembled: the operator the Krylov solver sees is the
PETSc shell matrix

    J x = A x + Σ_effects (T x − D x)          (free rows and columns only)

where ``T x`` is the effect's ``tangent_product`` and ``D`` its lumped nodal
blocks, which are added into ``A`` itself.  ``A + D`` is then the preconditioner's
matrix (factorised like any tangent), a local drag standing in for the nonlocal
one, and ``J`` is the exact tangent.  Rows and columns of Dirichlet dofs are left
to ``A`` (identity), as the assembly leaves them.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from petsc4py import PETSc

from rftfem.integration.weak_callbacks import WeakContext
from rftfem.model.ranks import gather_rows

if TYPE_CHECKING:
    from rftfem.model.effects.base import NonlocalEffect
    from rftfem.model.shell_model import Model


class CoupledTangent:
    """PETSc python-matrix context: ``J = A + Σ (T − D)`` (see the module)."""

    def __init__(self, model: Model, A: PETSc.Mat, components: list[NonlocalEffect]):
        self.model, self.A, self.components = model, A, components
        self.block = model.block
        im = model.W.dofmap.index_map
        self.n_owned = im.size_local
        self.first = im.local_range[0]
        #: the owned nodes' unknowns that no Dirichlet condition holds (n_owned, block)
        self.free = np.ones((self.n_owned, self.block), dtype=bool)
        for bc in model.bcs:
            dofs = np.asarray(bc.dof_indices()[0])
            dofs = dofs[dofs < self.n_owned * self.block]
            node, comp = np.divmod(dofs, self.block)
            self.free[node, comp] = False
        self.unknowns = [np.asarray(c.unknowns) for c in components]
        self.lumped = [np.zeros((self.n_owned, len(k), len(k))) for k in self.unknowns]
        sizes = A.getSizes()
        self.J = PETSc.Mat().createPython(sizes, WeakContext(self), comm=A.getComm())
        self.J.setUp()

    def update(self, exact: bool = False) -> None:
        """After ``A`` is assembled: each effect's tangent at the current iterate, and
        its lumped blocks added into ``A`` (the preconditioner's matrix).  Without
        ``exact`` an effect may give an older tangent (a Newton update's: the Stokes
        layer's kept factors)."""
        scale = 1.0 - float(self.model.coef["alpha_f"].value)
        base = (self.first + np.arange(self.n_owned)) * self.block
        for k, (comp, cols) in enumerate(zip(self.components, self.unknowns)):
            f = self.free[:, cols].astype(float)
            self.lumped[k] = comp.prepare_tangent(scale, exact) * f[:, :, None] * f[:, None, :]
            for i in np.flatnonzero(self.lumped[k].any(axis=(1, 2))):
                rows = (base[i] + cols).astype(PETSc.IntType)
                self.A.setValues(rows, rows, self.lumped[k][i], addv=PETSc.InsertMode.ADD)
        self.A.assemble()

    def lift(self, b: PETSc.Vec, x0: PETSc.Vec, scale: float) -> None:
        """``b −= scale · T (g − x0)`` on the free rows: the nonlocal tangent's part of
        the lifting of the Dirichlet values ``g`` (the assembled part is dolfinx's
        ``apply_lifting``), at the current iterate, with the exact tangent (kept
        Stokes factors there cost the first update its reach: 24 updates instead of 18
        in tests/test_stokes.py::test_lifting_carries_the_liquid)."""
        from rftfem import compat

        d = b.duplicate()
        with d.localForm() as local:
            local.set(0.0)
        compat.set_bc(d, self.model.bcs, x0, 1.0)  # g − x0 on the Dirichlet rows
        held = d.getArray(readonly=True).reshape(-1, self.block) * ~self.free
        d.destroy()
        if not self.model.comm.allreduce(bool(np.any(held))):
            return
        scale_f = 1.0 - float(self.model.coef["alpha_f"].value)
        y = b.getArray().reshape(-1, self.block)
        for comp, cols in zip(self.components, self.unknowns):
            comp.prepare_tangent(scale_f, exact=True)
            extra = comp.tangent_product(self._gather(held[:, cols]))
            y[:, cols] -= scale * extra * self.free[:, cols]

    def _gather(self, owned):
        """Every process's rows of ``owned`` (n_owned, k), in rank order."""
        return gather_rows(owned, self.model.comm)

    def mult(self, mat: PETSc.Mat, X: PETSc.Vec, Y: PETSc.Vec) -> None:
        self.A.mult(X, Y)
        x = X.getArray(readonly=True).reshape(-1, self.block) * self.free
        y = Y.getArray().reshape(-1, self.block)
        for comp, cols, lumped in zip(self.components, self.unknowns, self.lumped):
            xk = x[:, cols]
            z = comp.tangent_product(self._gather(xk))
            y[:, cols] += (z - np.einsum("nij,nj->ni", lumped, xk)) * self.free[:, cols]


def tangent_for(model: Model, A: PETSc.Mat) -> CoupledTangent | None:
    """The coupled operator of ``model``'s nonlocal effects, or None if it has none."""
    from rftfem.model.effects.base import NonlocalEffect

    comps = [c for c in model.components if isinstance(c, NonlocalEffect)]
    return CoupledTangent(model, A, comps) if comps else None
