"""The magnetized parts acting on each other (``[magnetic] interactions = true``).

Each magnetized cell ``c`` is a point dipole: its moment ``m_c = ∫_c t F M dA₀`` (the
magnetization as the material carries it, rftfem/model/effects/magnetic.py) at its
mean position ``x_c = ∫_c x dA₀ / A_c``.  Dipoles of different groups (a part of a
body; two bodies, or two parts of one) interact with the energy ``E`` of
rftfem/model/dipoles.py; within one part they do not (the near-singular field of a
thin sheet on itself is its shape anisotropy, which cell dipoles cannot resolve).

With ``G_c = ∂E/∂m_c`` and ``H_c = ∂E/∂x_c`` at the iterate, the work

    W[G, H̃] = ∫ (G·(t F M) + H̃·x) dA₀,      H̃ = H_c / A_c on cell c,

has ``δW = δE`` exactly: the residual is ``δW`` with ``G, H̃`` held, mapped from the
directors ``z`` to the unknowns ``w`` (``Pᵀ``).  The exact tangent is

    Pᵀ [∂²W/∂z² (G, H̃ held) + Lᵀ ∇²E L] P  +  Σ r_z · ∂²z/∂w²,

``L`` the map from a direction of ``z`` to the cells' ``(dm_c, dx_c)``; its
transpose is ``δW`` with ``(dG, dH̃)`` in place of ``(G, H̃)``.  It is never
assembled: the Newton operator applies it by products (a nonlocal effect,
rftfem/integration/coupled.py), every UFL piece by ``ufl.derivative``, the dense
``∇²E`` by the compiled sums.  Every process sums its own cells as targets over all.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import ufl

from rftfem.errors import SceneError
from rftfem.model.effects.base import NonlocalEffect
from rftfem.model.ranks import gather_rows

if TYPE_CHECKING:
    from rftfem.model.shell_model import Model


class MagneticInteractions(NonlocalEffect):
    name = "magnetic interactions"
    columns = ["magnetic_interaction_energy"]
    #: off, with the applied field, while a run in time finds its start (docs/model.md §6.7)
    is_load = True

    @classmethod
    def active(cls, scene: dict) -> bool:
        return bool(scene.get("magnetic")) and bool(scene["magnetic"].get("interactions"))

    @classmethod
    def check(cls, scene: dict) -> None:
        if not cls.active(scene):
            return
        parts = scene["magnetic"]["parts"]
        bodies = len(scene["mesh"].get("bodies") or [None])
        on_all = any(p.get("body") is None for p in parts) and bodies > 1
        if len(parts) < 2 and not on_all:
            raise SceneError(
                "magnetic.interactions: needs two magnetized parts (or a part on two "
                "bodies): a part does not act on itself, its own field is not modelled"
            )

    def __init__(self, model: Model):
        super().__init__(model)
        self.unknowns = tuple(range(model.block))
        self._ready = False
        self.energy_value = 0.0
        self._scale = 1.0

    # --- set-up (after every component exists: the magnetization is Magnetic's) ----

    def _setup(self) -> None:
        if self._ready:
            return
        from dolfinx import fem

        from rftfem import compat
        from rftfem.model import dipoles
        from rftfem.model.magnetic_sources import MU0_OVER_4PI

        m = self.model
        mag = m["magnetic"]
        mesh = m.mesh
        k = m.kinematics()
        z, z_test = m.z, k.w_test
        V = compat.function_space(mesh, "DG", 0, (3,))
        S = compat.function_space(mesh, "DG", 0)
        psi, q = ufl.TestFunction(V), ufl.TestFunction(S)
        dx = mag.dx
        mu = m.material["t"] * (mag.F * mag.M)
        x = ufl.SpatialCoordinate(mesh) + k.u
        self.G, self.H, self.dG, self.dH = (fem.Function(V) for _ in range(4))
        self.dz = fem.Function(m.Z)

        def work(G, H):
            return (ufl.dot(G, mu) + ufl.dot(H, x)) * dx

        compile_ = m.compile
        self._forms = {
            "moments": compile_(ufl.dot(mu, psi) * dx),
            "positions": compile_(ufl.dot(x, psi) * dx),
            "d_moments": compile_(ufl.dot(ufl.derivative(mu, z, self.dz), psi) * dx),
            "d_positions": compile_(ufl.dot(ufl.derivative(x, z, self.dz), psi) * dx),
            "residual": compile_(ufl.derivative(work(self.G, self.H), z, z_test)),
            "transposed": compile_(ufl.derivative(work(self.dG, self.dH), z, z_test)),
            "second": compile_(
                ufl.derivative(ufl.derivative(work(self.G, self.H), z, z_test), z, self.dz)
            ),
        }
        self._V = V
        self._vec = compat.create_vector(self._forms["moments"], V)
        self._zvec = compat.petsc_vec(m.z).duplicate()
        self._wvec = compat.petsc_vec(m.w).duplicate()
        cells = V.dofmap.index_map.size_local
        area_vec = compat.create_vector(compile_(q * dx), S)
        compat.assemble_vector(area_vec, compile_(q * dx))
        area_vec.ghostUpdate(addv=_add(), mode=_reverse())
        areas = area_vec.array_r[:cells].copy()
        self._mine = np.flatnonzero(areas > 0.0)  # this process's magnetized cells
        self._area = areas[self._mine]
        self._group = self._groups(mag, cells)[self._mine]
        groups = gather_rows(self._group[:, None].astype(float), m.comm)[:, 0]
        if len(np.unique(groups)) < 2:
            raise SceneError(
                "magnetic.interactions: the magnetized cells are all of one part; "
                "interactions act between parts or bodies"
            )
        self._groups_all = groups.astype(np.int64)
        counts = m.comm.allgather(len(self._mine))
        self._lo = int(sum(counts[: m.comm.rank]))
        self._hi = self._lo + len(self._mine)
        im = m.W.dofmap.index_map
        local = np.arange(im.size_local + im.num_ghosts, dtype=np.int32)
        self._nodes = compat.local_to_global(im, local)  # rows of a gathered direction
        self._n_owned = im.size_local
        self._k = MU0_OVER_4PI
        dipoles.warm()
        self._ready = True

    def _groups(self, mag, cells: int) -> np.ndarray:
        """Each owned cell's group (by its dof of the DG0 space): its part times the
        bodies, plus its body."""
        from rftfem import compat
        from rftfem.scene.selectors import cells_of

        m = self.model
        dofs = compat.cell_dofs(self._V)[:, 0]  # cell → its block of the DG0 space
        bodies = m.scene["mesh"].get("bodies") or []
        body_of = np.zeros(len(dofs), dtype=np.int64)
        for b, body in enumerate(bodies):
            body_of[cells_of(m.body, [body["name"]], f"body.{b}")] = b
        group = np.full(len(dofs), -1, dtype=np.int64)
        for i, part_cells in mag.part_cells.items():
            group[part_cells] = i * max(len(bodies), 1) + body_of[part_cells]
        by_dof = np.full(
            self._V.dofmap.index_map.size_local + self._V.dofmap.index_map.num_ghosts, -1
        )
        by_dof[dofs] = group
        return by_dof[:cells]

    # --- the cells' dipoles and the energy's gradient at the iterate --------------

    def _cell_values(self, form) -> np.ndarray:
        from rftfem import compat

        vec = self._vec
        with vec.localForm() as local:
            local.set(0.0)
        compat.assemble_vector(vec, form)
        vec.ghostUpdate(addv=_add(), mode=_reverse())
        return vec.array_r.reshape(-1, 3)[self._mine].copy()

    def _set_cells(self, f, values: np.ndarray) -> None:
        f.x.array[:] = 0.0
        f.x.array.reshape(-1, 3)[self._mine] = values
        f.x.scatter_forward()

    def _update(self) -> None:
        """The dipoles at the model's iterate, ``G`` and ``H̃`` set, the energy kept."""
        from rftfem.model import dipoles

        self._setup()
        m = self.model
        m.directors.sync(derivatives=True)
        moments = self._cell_values(self._forms["moments"])
        positions = self._cell_values(self._forms["positions"]) / self._area[:, None]
        self._m = gather_rows(moments, m.comm)
        self._x = gather_rows(positions, m.comm)
        n = self._hi - self._lo
        G, H, half = np.empty((n, 3)), np.empty((n, 3)), np.empty(n)
        dipoles.gradient(
            self._m, self._x, self._groups_all, self._lo, self._hi, self._k, G, H, half
        )
        self._set_cells(self.G, G)
        self._set_cells(self.H, H / self._area[:, None])
        self.energy_value = m.comm.allreduce(float(half.sum()))

    def _z_rows(self, *forms) -> np.ndarray:
        """The local (unsummed) z vector of the sum of ``forms``."""
        from rftfem import compat

        zvec = self._zvec
        with zvec.localForm() as local:
            local.set(0.0)
            for form in forms:
                compat.assemble_vector(zvec, form)
            return local.array.copy()

    # --- the nonlocal effect -------------------------------------------------------

    def add_nodal_forces(self, F: np.ndarray) -> None:
        self._update()
        if not self.model.loads_on:
            return
        self.model.directors.add_transposed(self._z_rows(self._forms["residual"]), F)

    def prepare_tangent(self, scale: float, exact: bool = False) -> np.ndarray:
        self._update()
        self._scale = scale if self.model.loads_on else 0.0
        zvec = self._zvec
        with zvec.localForm() as local:
            local.set(0.0)
        from rftfem import compat

        compat.assemble_vector(zvec, self._forms["residual"])
        zvec.ghostUpdate(addv=_add(), mode=_reverse())
        self._curvature = self.model.directors.node_curvatures(zvec.array_r)
        return self._scale * self._curvature

    def tangent_product(self, dx: np.ndarray) -> np.ndarray:
        from rftfem.model import dipoles

        m = self.model
        w_local = np.asarray(dx)[self._nodes].ravel()
        self.dz.x.array[:] = m.directors.apply(w_local)
        dm = gather_rows(self._cell_values(self._forms["d_moments"]), m.comm)
        dp = self._cell_values(self._forms["d_positions"]) / self._area[:, None]
        dp = gather_rows(dp, m.comm)
        n = self._hi - self._lo
        dG, dH = np.empty((n, 3)), np.empty((n, 3))
        dipoles.hessian_product(
            self._m, self._x, self._groups_all, dm, dp, self._lo, self._hi, self._k, dG, dH
        )
        self._set_cells(self.dG, dG)
        self._set_cells(self.dH, dH / self._area[:, None])
        z_rows = self._z_rows(self._forms["transposed"], self._forms["second"])
        wvec = self._wvec
        with wvec.localForm() as local:
            local.set(0.0)
            m.directors.add_transposed(z_rows, local.array)
        wvec.ghostUpdate(addv=_add(), mode=_reverse())
        n_owned, bw = self._n_owned, m.block
        out = wvec.array_r.reshape(-1, bw)[:n_owned].copy()
        out += np.einsum("nij,nj->ni", self._curvature, np.asarray(dx)[self._nodes[:n_owned]])
        return self._scale * out

    # --- outputs -------------------------------------------------------------------

    def force_scales(self) -> list[float]:
        self._update()
        H = gather_rows(
            self.H.x.array.reshape(-1, 3)[self._mine] * self._area[:, None], self.model.comm
        )
        return [float(np.linalg.norm(H, axis=1).sum())]

    def values(self, t: float) -> list[float]:
        self._update()
        return [self.energy_value]


def _add():
    from petsc4py import PETSc

    return PETSc.InsertMode.ADD


def _reverse():
    from petsc4py import PETSc

    return PETSc.ScatterMode.REVERSE
