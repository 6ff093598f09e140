"""The Newton operator of a step with a nonlocal effect (the Stokes flow).

The assembled tangent ``A`` holds every UFL term.  A nonlocal effect adds a dense
block on the displacement dofs that is never assembled: the operator the Krylov
solver sees is the PETSc shell matrix

    J x = A x + Σ_effects (T x_u − D x_u)          (free rows and columns only)

where ``T x_u`` is the effect's ``tangent_product`` and ``D`` its lumped nodal
blocks, which are added into ``A`` itself.  ``A + D`` is then the preconditioner's
matrix (factorised like any tangent), a local drag standing in for the nonlocal
one, and ``J`` is the exact tangent.  Rows and columns of Dirichlet dofs are left
to ``A`` (identity), as the assembly leaves them.
"""

from __future__ import annotations

import numpy as np
from petsc4py import PETSc


class CoupledTangent:
    """PETSc python-matrix context: ``J = A + Σ (T − D)`` (see the module)."""

    def __init__(self, model, A, components):
        self.model, self.A, self.components = model, A, components
        self.block = model.block
        im = model.W.dofmap.index_map
        self.n_owned = im.size_local
        self.first = im.local_range[0]
        self.free = np.ones((self.n_owned, 3), dtype=bool)
        for bc in model.bcs:
            dofs = np.asarray(bc.dof_indices()[0])
            dofs = dofs[dofs < self.n_owned * self.block]
            node, comp = np.divmod(dofs, self.block)
            keep = comp < 3
            self.free[node[keep], comp[keep]] = False
        self.lumped = [np.zeros((self.n_owned, 3, 3)) for _ in components]
        sizes = A.getSizes()
        self.J = PETSc.Mat().createPython(sizes, self, comm=A.getComm())
        self.J.setUp()

    def update(self, exact: bool = False):
        """After ``A`` is assembled: each effect's tangent at the current iterate, and
        its lumped blocks added into ``A`` (the preconditioner's matrix).  Without
        ``exact`` an effect may give an older tangent (a Newton update's: the Stokes
        layer's kept factors)."""
        scale = 1.0 - float(self.model.coef["alpha_f"].value)
        f = self.free.astype(float)
        mask = f[:, :, None] * f[:, None, :]
        for k, comp in enumerate(self.components):
            self.lumped[k] = comp.prepare_tangent(scale, exact) * mask
        total = sum(self.lumped)
        base = (self.first + np.arange(self.n_owned)) * self.block
        for i in range(self.n_owned):
            if total[i].any():
                rows = (base[i] + np.arange(3)).astype(PETSc.IntType)
                self.A.setValues(rows, rows, total[i], addv=PETSc.InsertMode.ADD)
        self.A.assemble()

    def lift(self, b, x0, scale: float):
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
        held = d.getArray(readonly=True).reshape(-1, self.block)[:, :3] * ~self.free
        d.destroy()
        if not self.model.comm.allreduce(bool(np.any(held))):
            return
        scale_f = 1.0 - float(self.model.coef["alpha_f"].value)
        xg = self._gather(held).ravel()
        extra = np.zeros((self.n_owned, 3))
        for comp in self.components:
            comp.prepare_tangent(scale_f, exact=True)
            extra += comp.tangent_product(xg).reshape(-1, 3)[comp.offset:comp.offset
                                                             + self.n_owned]
        y = b.getArray().reshape(-1, self.block)
        y[:, :3] -= scale * extra * self.free

    def _gather(self, owned):
        return np.concatenate(self.model.comm.allgather(np.ascontiguousarray(owned)))

    def mult(self, mat, X, Y):
        self.A.mult(X, Y)
        x = X.getArray(readonly=True).reshape(-1, self.block)[:, :3] * self.free
        xg = self._gather(x).ravel()
        extra = np.zeros((self.n_owned, 3))
        for comp, lumped in zip(self.components, self.lumped):
            z = comp.tangent_product(xg).reshape(-1, 3)[comp.offset:comp.offset + self.n_owned]
            extra += z - np.einsum("nij,nj->ni", lumped, x)
        y = Y.getArray().reshape(-1, self.block)
        y[:, :3] += extra * self.free



def tangent_for(model, A):
    """The coupled operator of ``model``'s nonlocal effects, or None if it has none."""
    comps = [c for c in model.components if getattr(c, "nonlocal_tangent", False)]
    return CoupledTangent(model, A, comps) if comps else None
