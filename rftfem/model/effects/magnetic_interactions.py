"""The magnetized parts acting on each other (``[magnetic] interactions = true``).

The magnetized volume is a sum of point dipoles, one per point of a quadrature rule
over each cell (``q × q`` points on a quadrilateral) and through the thickness
(``L`` Gauss layers ``ζ_l``, weights ``w_l``): the dipole of point ``p`` in layer
``l`` has the moment ``m = w_p (w_l/2) t F M`` (the magnetization as the material
carries it, rftfem/model/effects/magnetic.py; ``w_p`` the point's area weight) and
sits at ``x_l = x + ζ_l (t/2) d``.  One point per cell and one layer is the cell's
dipole at its mid-surface.  Dipoles of different groups (a part of a body; two
bodies, or two parts of one) interact with the energy ``E`` of
rftfem/model/dipoles.py; within one part they do not (the near-singular field of a
thin sheet on itself is its shape anisotropy).  ``[magnetic] interaction_points``
gives ``[q, L]``, or by default :func:`rule` picks them from how close the parts are
(docs/bodies.md).

With ``G = ∂E/∂m`` and ``H = ∂E/∂x`` at the iterate, held as values at the points,
the work

    W[G, H̃] = Σ_l ∫ (G_l·(w_l/2) t F M + H̃_l·x_l) dA₀,      H̃ = H / w_p,

integrated with the points' rule, has ``δW = δE`` exactly: the residual is ``δW``
with ``G, H̃`` held, mapped from the directors ``z`` to the unknowns ``w`` (``Pᵀ``).
The exact tangent is

    Pᵀ [∂²W/∂z² (G, H̃ held) + Lᵀ ∇²E L] P  +  Σ r_z · ∂²z/∂w²,

``L`` the map from a direction of ``z`` to the dipoles' ``(dm, dx)``; its
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
from rftfem.model.effects.interaction_rule import rule, rule_of_cells  # noqa: F401 (rule, as before)
from rftfem.model.ranks import gather_rows

if TYPE_CHECKING:
    from dolfinx.fem import FunctionSpace

    from rftfem.model.effects.magnetic import Magnetic
    from rftfem.model.shell_model import Model


#: "auto" sums the pairs by multipoles from this many dipoles on: below it the compiled
#: direct sums are faster at the precision the tangent needs (on the project's 2-core
#: machine, benchmarks/magnetic_interactions_cost.py: the multipoles' gradient at 1e-12
#: costs 21.7 s for 64 000 dipoles, the direct one 16.4 s)
FMM_FROM = 100_000


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
        from rftfem import compat
        from rftfem.model.magnetic_sources import MU0_OVER_4PI

        m = self.model
        mag = m["magnetic"]
        given = m.scene["magnetic"].get("interaction_points", "auto")
        self.points = tuple(given) if given != "auto" else self._auto_rule(mag)
        V, S, dx = self._compile_forms(mag)
        groups = self._gather_points(mag, V, S, dx)
        im = m.W.dofmap.index_map
        local = np.arange(im.size_local + im.num_ghosts, dtype=np.int32)
        self._nodes = compat.local_to_global(im, local)  # rows of a gathered direction
        self._n_owned = im.size_local
        self._k = MU0_OVER_4PI
        self._sums = self._chosen_sums(len(groups))
        self._ready = True

    def _compile_forms(self, mag: Magnetic) -> tuple[FunctionSpace, FunctionSpace, ufl.Measure]:
        """The quadrature spaces of the points (vector ``V``, scalar ``S``), their
        measure, and the compiled forms: the dipoles' moments and positions, their
        derivatives along ``dz``, the work's residual, its transpose and its second
        derivative."""
        from rftfem import compat

        m = self.model
        q, layers = self.points
        degree = 2 * q - 1
        mesh, k = m.mesh, m.kinematics()
        z, z_test = m.z, k.w_test
        V = compat.quadrature_space(mesh, degree, (3,))
        S = compat.quadrature_space(mesh, degree)
        psi = ufl.TestFunction(V)
        dx = mag.dx.reconstruct(metadata={"quadrature_degree": degree})
        zeta, weights = np.polynomial.legendre.leggauss(layers)
        t = m.material["t"]
        mu = [float(w) / 2 * t * (mag.F * mag.M) for w in weights]
        x = [ufl.SpatialCoordinate(mesh) + k.u + float(c) * t / 2 * k.d for c in zeta]
        self.G, self.H, self.dG, self.dH = ([_function(V) for _ in x] for _ in range(4))
        self.dz = _function(m.Z)

        def work(G, H):
            return sum((ufl.dot(G[i], mu[i]) + ufl.dot(H[i], x[i])) * dx for i in range(layers))

        compile_ = m.compile

        def per_layer(field):
            return [compile_(ufl.dot(f, psi) * dx) for f in field]

        self._forms = {
            "moments": per_layer(mu),
            "positions": per_layer(x),
            "d_moments": per_layer([ufl.derivative(f, z, self.dz) for f in mu]),
            "d_positions": per_layer([ufl.derivative(f, z, self.dz) for f in x]),
            "residual": compile_(ufl.derivative(work(self.G, self.H), z, z_test)),
            "transposed": compile_(ufl.derivative(work(self.dG, self.dH), z, z_test)),
            "second": compile_(
                ufl.derivative(ufl.derivative(work(self.G, self.H), z, z_test), z, self.dz)
            ),
        }
        self._V = V
        self._vec = compat.create_vector(self._forms["moments"][0], V)
        self._zvec = compat.petsc_vec(m.z).duplicate()
        self._wvec = compat.petsc_vec(m.w).duplicate()
        return V, S, dx

    def _gather_points(
        self, mag: Magnetic, V: FunctionSpace, S: FunctionSpace, dx: ufl.Measure
    ) -> np.ndarray:
        """This process's magnetized points (their weights and groups, its rows
        ``lo:hi`` of the gathered dipoles) and every process's points' groups."""
        m = self.model
        layers = self.points[1]
        weight = _point_values(m.compile(ufl.TestFunction(S) * dx), S)
        self._mine = np.flatnonzero(weight > 0.0)  # this process's magnetized points
        self._weight = np.tile(weight[self._mine], layers)
        group = np.tile(self._groups(mag, V)[self._mine], layers)
        groups = gather_rows(group[:, None].astype(float), m.comm)[:, 0]
        if len(np.unique(groups)) < 2:
            raise SceneError(
                "magnetic.interactions: the magnetized cells are all of one part; "
                "interactions act between parts or bodies"
            )
        self._groups_all = groups.astype(np.int64)
        counts = m.comm.allgather(len(group))
        self._lo = int(sum(counts[: m.comm.rank]))
        self._hi = self._lo + len(group)
        return groups

    def _chosen_sums(self, count: int):
        """The module that sums the pairs: the compiled direct sums, or the multipoles
        (``interaction_sums``; "auto": the multipoles from ``FMM_FROM`` dipoles on)."""
        from rftfem.model import dipoles, dipoles_fmm

        sums = self.scene["magnetic"].get("interaction_sums", "auto")
        if sums == "fmm" or (sums == "auto" and count >= FMM_FROM):
            return dipoles_fmm
        dipoles.warm()
        return dipoles

    def _groups(self, mag, V) -> np.ndarray:
        """The group of each owned point of the quadrature space ``V`` (a block of
        it): its cell's part times the bodies, plus its body."""
        from rftfem import compat
        from rftfem.scene.selectors import cells_of

        m = self.model
        dofs = compat.cell_dofs(V)  # cell → its points (blocks)
        bodies = m.scene["mesh"].get("bodies") or []
        body_of = np.zeros(len(dofs), dtype=np.int64)
        for b, body in enumerate(bodies):
            body_of[cells_of(m.body, [body["name"]], f"body.{b}")] = b
        group = np.full(len(dofs), -1, dtype=np.int64)
        for i, part_cells in mag.part_cells.items():
            group[part_cells] = i * max(len(bodies), 1) + body_of[part_cells]
        im = V.dofmap.index_map
        by_dof = np.full(im.size_local + im.num_ghosts, -1)
        by_dof[dofs] = group[:, None]
        return by_dof[: im.size_local]

    def _auto_rule(self, mag) -> tuple[int, int]:
        """The points per cell and the layers :func:`rule` picks for the reference
        state: from the cells' size, the thickness and the nearest two cell centres
        of different groups."""
        from rftfem import compat

        m = self.model
        S = compat.quadrature_space(m.mesh, 1)
        one = ufl.TestFunction(S)
        dx = mag.dx.reconstruct(metadata={"quadrature_degree": 1})
        X = ufl.SpatialCoordinate(m.mesh)
        area = _point_values(m.compile(one * dx), S)
        mine = area > 0.0
        centres = np.stack(
            [_point_values(m.compile(X[i] * one * dx), S)[mine] for i in range(3)], axis=1
        )
        centres /= area[mine][:, None]
        group = self._groups(mag, compat.quadrature_space(m.mesh, 1, (3,)))[mine]
        rows = gather_rows(np.column_stack([centres, group, area[mine]]), m.comm)
        return rule_of_cells(rows, m.material_value("thickness", "max"))

    # --- the dipoles and the energy's gradient at the iterate ----------------------

    def _point_rows(self, forms) -> np.ndarray:
        """Each layer's vector of the points' values (``forms``, one per layer),
        this process's magnetized points of every layer stacked."""
        from rftfem import compat

        vec, out = self._vec, []
        for form in forms:
            with vec.localForm() as local:
                local.set(0.0)
            compat.assemble_vector(vec, form)
            vec.ghostUpdate(addv=_add(), mode=_reverse())
            out.append(vec.array_r.reshape(-1, 3)[self._mine].copy())
        return np.concatenate(out)

    def _set_points(self, functions, values: np.ndarray) -> None:
        for f, block in zip(functions, np.split(values, len(functions))):
            f.x.array[:] = 0.0
            f.x.array.reshape(-1, 3)[self._mine] = block
            f.x.scatter_forward()

    def _update(self) -> None:
        """The dipoles at the model's iterate, ``G`` and ``H̃`` set, the energy kept."""
        self._setup()
        m = self.model
        m.directors.sync(derivatives=True)
        moments = self._point_rows(self._forms["moments"])
        positions = self._point_rows(self._forms["positions"]) / self._weight[:, None]
        self._m = gather_rows(moments, m.comm)
        self._x = gather_rows(positions, m.comm)
        n = self._hi - self._lo
        G, H, half = np.empty((n, 3)), np.empty((n, 3)), np.empty(n)
        self._sums.gradient(
            self._m, self._x, self._groups_all, self._lo, self._hi, self._k, G, H, half
        )
        self._H = H
        self._set_points(self.G, G)
        self._set_points(self.H, H / self._weight[:, None])
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
        m = self.model
        w_local = np.asarray(dx)[self._nodes].ravel()
        self.dz.x.array[:] = m.directors.apply(w_local)
        dm = gather_rows(self._point_rows(self._forms["d_moments"]), m.comm)
        dp = self._point_rows(self._forms["d_positions"]) / self._weight[:, None]
        dp = gather_rows(dp, m.comm)
        n = self._hi - self._lo
        dG, dH = np.empty((n, 3)), np.empty((n, 3))
        self._sums.hessian_product(
            self._m, self._x, self._groups_all, dm, dp, self._lo, self._hi, self._k, dG, dH
        )
        self._set_points(self.dG, dG)
        self._set_points(self.dH, dH / self._weight[:, None])
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
        H = gather_rows(self._H, self.model.comm)
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


def _function(V):
    from dolfinx import fem

    return fem.Function(V)


def _point_values(form, S) -> np.ndarray:
    """The owned values of an assembled vector of the scalar quadrature space ``S``."""
    from rftfem import compat

    vec = compat.create_vector(form, S)
    compat.assemble_vector(vec, form)
    vec.ghostUpdate(addv=_add(), mode=_reverse())
    return vec.array_r[: S.dofmap.index_map.size_local].copy()
