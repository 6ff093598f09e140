"""Nodal triads: the frames the director's rotation increments are measured in.

Each colour of panels has a nodal triad ``(a₁, a₂, dₙ)`` in [P2]³, the frame of
its rotation increment θ = (θ¹, θ²) (docs/model.md §4).  :class:`Triads` makes
them from the reference normal and the material axis, rotates them by each
converged θ (Rodrigues, :func:`rotate`) and turns ``(a₁, a₂)`` about ``dₙ`` onto
the convected material axis (:func:`in_plane_frame`), with an L2 projection
onto the nodes whose mass matrix is factorised once.  :func:`rotate` serves the
magnetic field too, so dolfinx is imported only where the triads are built.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import ufl

from rftfem.forms import kinematics

if TYPE_CHECKING:
    from collections.abc import Callable

    import dolfinx.fem

    from rftfem.model.shell_model import Model


def rotate(v: np.ndarray, rot: np.ndarray) -> np.ndarray:
    """Rodrigues: rotate rows of ``v`` by the rotation vectors in the rows of ``rot``."""
    angle = np.linalg.norm(rot, axis=1)
    small = angle < 1e-8
    safe = np.where(small, 1.0, angle)
    c = np.cos(angle)
    s = np.where(small, 1 - angle**2 / 6, np.sin(angle) / safe)
    k = np.where(small, 0.5 - angle**2 / 24, (1 - np.cos(angle)) / safe**2)
    cross = np.cross(rot, v)
    dot = np.sum(rot * v, axis=1)
    return c[:, None] * v + s[:, None] * cross + k[:, None] * dot[:, None] * rot


def in_plane_frame(t: np.ndarray, dn: np.ndarray, fallback: np.ndarray) -> np.ndarray:
    """Rows of ``t`` projected onto the planes normal to the rows of ``dn`` and
    normalised; where ``t`` lies (almost) along ``dn`` the row of ``fallback``."""
    p = t - np.sum(t * dn, axis=1)[:, None] * dn
    size = np.linalg.norm(p, axis=1)
    ok = size > 1e-3 * np.linalg.norm(t, axis=1)
    out = np.array(fallback, dtype=float)
    out[ok] = p[ok] / size[ok, None]
    return out


class Triads:
    """The nodal triads of every colour, their reference director and their update."""

    def __init__(self, model: Model, axis: np.ndarray):
        """``axis``: the unit material axis E₁*; ``model`` gives the spaces, the θ dofs
        of each colour and the colours' indicators."""
        from dolfinx import fem
        from petsc4py import PETSc

        self.model, self.comm = model, model.comm
        Vu = model.Vu
        #: per colour: for each θ node (Model.theta_dofs_of, in pairs), its node of the
        #: u space; ``w`` holds every field node by node in the u space's order
        nodes = Vu.dofmap.index_map.size_local + Vu.dofmap.index_map.num_ghosts
        self.node_maps = [np.arange(nodes) for _ in range(model.n_colours)]
        #: the reference director D, and (a1, a2, dn) per colour
        self.D = fem.Function(Vu, name="reference_director")
        self.frames = [
            tuple(
                fem.Function(Vu, name=f"{n}{'' if c == 0 else f'_{c}'}")
                for n in ("a1", "a2", "director")
            )
            for c in range(model.n_colours)
        ]
        #: E₁* as a Constant: the convected axis the frames follow (and the drag frame)
        self.material_axis = fem.Constant(model.mesh, axis.astype(PETSc.ScalarType))
        self.nodal = NodalProjection(Vu, model.compile)
        self._start(axis)
        self.convected = self._convected_axis_forms() if model.compile_forms else None
        self._director_out = None

    def _start(self, axis: np.ndarray):
        """D: L2 projection of the cell normal, normalised; a₁: the axis in the plane."""
        G1, G2 = kinematics.covariant_basis(self.model.mesh)
        D = self.nodal.project(
            self.model.compile(
                ufl.inner(kinematics.unit_normal(G1, G2), self.nodal.test) * self.nodal.dx
            )
        )
        D /= np.linalg.norm(D, axis=1)[:, None]
        self.D.x.array[:] = D.ravel()
        a1 = axis[None, :] - (D @ axis)[:, None] * D
        bad = np.linalg.norm(a1, axis=1) < 1e-6
        #: nodes (global count) where the material axis lies along the normal
        self.axis_along_normal = self.comm.allreduce(int(bad.sum()))
        #: the reference position of one such node (the lowest rank's first), or None
        X = self.model.Vu.tabulate_dof_coordinates()
        points = self.comm.allgather(X[np.flatnonzero(bad)[0]] if bad.any() else None)
        self.axis_normal_point = next((p for p in points if p is not None), None)
        if bad.any():  # material axis along the normal: take any tangent
            other = np.where(np.abs(D[bad, 0:1]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]])
            a1[bad] = other - np.sum(other * D[bad], axis=1)[:, None] * D[bad]
        a1 /= np.linalg.norm(a1, axis=1)[:, None]
        for t1, t2, dn in self.frames:
            dn.x.array[:] = D.ravel()
            t1.x.array[:] = a1.ravel()
            t2.x.array[:] = np.cross(D, a1).ravel()

    def _convected_axis_forms(self) -> list:
        """Compiled L2 right-hand sides of the convected material axis at the converged
        displacement, one per colour, each from its own cells only: at a hinge node
        the axis carried by the two sides differs once the hinge folds, and a frame
        averaged over both is consistent with neither (an oblique crease then folded
        0.68 rad instead of π/2).  Only the direction is used, so one mass matrix
        serves every colour."""
        m = self.model
        G1, G2 = kinematics.covariant_basis(m.mesh)
        F_s = kinematics.surface_deformation_gradient(m.u_n)
        t = kinematics.convected_axis(F_s, self.material_axis, G1, G2)
        return [
            m.compile(ufl.inner(chi * t, self.nodal.test) * self.nodal.dx)
            for chi in m.colour_indicators or [1]
        ]

    def update(self, w: np.ndarray, theta_dofs_of: list) -> None:
        """Rotate every triad by the exact Rodrigues rotation of its θ (read from the
        array of ``w``), then turn ``(a₁, a₂)`` about ``dₙ`` onto the convected
        material axis.

        The rotations have no drilling part, so a triad carried through many turns
        picks up an in-plane twist that depends on the path its director took
        (holonomy): after ~14 turns of the strip in a 64 Hz field, neighbouring
        nodes of one cell had ``a₁`` up to 180° apart, which makes the componentwise
        interpolated θ meaningless.  Choosing ``a₁`` along the projected convected
        axis ``F_s A`` keeps the frames as smooth as the deformation; ``dₙ``, and
        with θ = 0 the whole current state, is unchanged by that choice.

        Done on owned and ghost nodes alike from ghost-updated values, so every
        copy of a node gets the identical triad without further communication.
        """
        for c, (dofs, idx, (t1, t2, tn)) in enumerate(
            zip(theta_dofs_of, self.node_maps, self.frames)
        ):
            theta = w[dofs].reshape(-1, 2)
            a1, a2, dn = (f.x.array.reshape(-1, 3) for f in (t1, t2, tn))
            rot = theta[:, 0:1] * a1[idx] + theta[:, 1:2] * a2[idx]
            for triad_vector in (a1, a2, dn):
                triad_vector[idx] = rotate(triad_vector[idx], rot)
            if self.convected is not None:
                along = self.nodal.project(self.convected[c])
                a1[:] = in_plane_frame(along, dn, a1)
                a2[:] = np.cross(dn, a1)

    def unit_error(self) -> float:
        """``max | |d| − 1 |`` over all nodal directors of every colour (global)."""
        from mpi4py import MPI

        d = np.concatenate([dn.x.array.reshape(-1, 3) for _, _, dn in self.frames])
        local = float(np.abs(np.linalg.norm(d, axis=1) - 1).max()) if len(d) else 0.0
        return self.comm.allreduce(local, op=MPI.MAX)

    def nodal_director(self) -> dolfinx.fem.Function:
        """The nodal directors as one [P2]³ Function (for output).  On a hinged body a
        node on a hinge has one director per side; there the highest colour's is shown."""
        from dolfinx import fem

        from rftfem import compat
        from rftfem.model import hinges

        m = self.model
        if m.n_colours == 1:
            return self.frames[0][2]
        if self._director_out is None:
            self._director_out = fem.Function(m.Vu, name="director")
            dofs = compat.cell_dofs(m.Vu)
            self._colour_nodes = [
                np.unique(dofs[hinges.cells_of_colour(m.colours, c)]) for c in range(m.n_colours)
            ]
        out = self._director_out.x.array.reshape(-1, 3)
        for (_, _, dn), nodes in zip(self.frames, self._colour_nodes):
            out[nodes] = dn.x.array.reshape(-1, 3)[nodes]
        return self._director_out

    def destroy(self) -> None:
        self.nodal.destroy()
        self.convected = None


class NodalProjection:
    """L2 projection onto a [P2]³ space with its mass matrix factorised once (LU)."""

    def __init__(
        self,
        V: dolfinx.fem.FunctionSpace,
        compile_form: Callable[[ufl.Form], dolfinx.fem.Form],
    ):
        from dolfinx import fem

        from rftfem import compat, petsc_options

        self.V = V
        self.test = ufl.TestFunction(V)
        self.dx = ufl.dx(domain=V.mesh, metadata={"quadrature_degree": 4})
        mass = compile_form(ufl.inner(ufl.TrialFunction(V), self.test) * self.dx)
        self.A = fem.petsc.assemble_matrix(mass)
        self.A.assemble()
        self.ksp = petsc_options.direct_solver(self.A)
        self.result = fem.Function(V)
        self.b = compat.petsc_vec(self.result).duplicate()  # ghosted like the result

    def project(self, rhs: dolfinx.fem.Form) -> np.ndarray:
        """Nodal values (owned and ghost), shape (nodes, 3), of the projection whose
        compiled right-hand side is ``rhs``."""
        from petsc4py import PETSc

        from rftfem import compat

        with self.b.localForm() as local:
            local.set(0.0)
        compat.assemble_vector(self.b, rhs)
        self.b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        x = compat.petsc_vec(self.result)
        self.ksp.solve(self.b, x)
        x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        return self.result.x.array.reshape(-1, 3).copy()

    def destroy(self) -> None:
        for obj in (self.ksp, self.A, self.b):
            obj.destroy()
