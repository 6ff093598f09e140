"""A scene turned into unknowns, state and UFL forms.

The unknowns of a step are ``w = (u, θ)``: total displacement ``u`` in [P2]³ and
the rotation increment ``θ = (θ¹, θ²)`` in [P2]² about the nodal triad
``(a₁, a₂, dₙ)`` of the last converged step (docs/model.md §4).  The triad is kept as
three [P2]³ functions, rotated node by node after each converged step, and its
in-plane pair turned about dₙ onto the convected material axis (``update_triad``).

Only the effects a scene asks for are built (docs/model.md §5): ``Model.effects``
names them, and each maps to its UFL virtual-work term.
"""

from __future__ import annotations

import time as _time

import numpy as np
import ufl
from dolfinx import fem, mesh as dmesh
from mpi4py import MPI
from petsc4py import PETSc

from rftfem.forms import drag, elasticity, hinge, inertia, kinematics, loads, magnetic

from . import compat, hinges, petsc_options
from . import scene as scene_rules
from .errors import SceneError

EDGE_SELECTORS = ("x=0", "x=L", "y=0", "y=W")
DISPLACEMENT_COMPONENTS = {"ux": 0, "uy": 1, "uz": 2}


def ramp_scale(load: dict, t: float, end: float) -> float:
    """Scale factor of a ``[[load]]`` at time ``t`` (docs/scenes.md: linear, constant, table)."""
    kind = load.get("ramp", "linear")
    if kind == "linear":
        return t / end
    if kind == "constant":
        return 1.0
    table = np.asarray(load["table"], dtype=float)
    return float(np.interp(t, table[:, 0], table[:, 1]))


class Model:
    """Function spaces, state, material fields and forms of one scene."""

    def __init__(self, scene: dict, body, compile_forms: bool = True):
        self.scene = scene
        self.compile_forms = compile_forms
        self.body = body
        self.mesh = body.mesh
        self.comm = self.mesh.comm
        tdim = self.mesh.topology.dim
        self.mesh.topology.create_connectivity(tdim - 1, tdim)
        self.timings = {"compile": 0.0}

        # hinges cut the body into panels; panels that touch get different colours,
        # and each colour has its own rotation field and triad (forms/hinge.py)
        self.hinges = hinges.resolve(self, scene)
        self.n_colours, self.colours = 1, None
        if self.hinges:
            cut = np.unique(np.concatenate([h.facets for h in self.hinges]))
            labels = hinges.panel_labels(self.mesh, cut)
            self.colours, self.n_colours = hinges.colour_panels(self.mesh, labels, cut,
                                                                self.hinges)
        #: χ_c, 1 on the cells of colour c (DG0), when there is more than one colour
        self.colour_indicators = (hinges.indicators(self.mesh, self.colours, self.n_colours)
                                  if self.n_colours > 1 else None)

        # unknowns and spaces: u, then one θ per colour
        self.W = compat.mixed_space(self.mesh, [("Lagrange", 2, (3,))]
                                    + [("Lagrange", 2, (2,))] * self.n_colours)
        self.Vu, self.u_dofs = self.W.sub(0).collapse()
        self.u_dofs = np.asarray(self.u_dofs, dtype=np.int64)
        self.Vt, self.theta_dofs_of, self._node_maps = None, [], []
        for c in range(self.n_colours):
            Vt, dofs = self.W.sub(1 + c).collapse()
            if c == 0:
                self.Vt = Vt
            self.theta_dofs_of.append(np.asarray(dofs, dtype=np.int64))
            self._node_maps.append(self._theta_to_u_nodes(Vt))
        #: every rotation dof of the mixed space, in (θ¹, θ²) pairs
        self.theta_dofs = np.concatenate(self.theta_dofs_of)
        self.w = fem.Function(self.W, name="w")

        # stored state: displacement, velocity, acceleration of the last step
        self.u_n = fem.Function(self.Vu, name="u_n")
        self.v_n = fem.Function(self.Vu, name="v_n")
        self.a_n = fem.Function(self.Vu, name="a_n")

        # reference director D and a nodal triad (a1, a2, dn) per colour
        self.D = fem.Function(self.Vu, name="reference_director")
        self.triads = [tuple(fem.Function(self.Vu, name=f"{n}{'' if c == 0 else f'_{c}'}")
                             for n in ("a1", "a2", "director"))
                       for c in range(self.n_colours)]
        self.a1, self.a2, self.dn = self.triads[0]
        #: the unit material axis E₁* (shell.axis): the triad's a₁ and the drag frame
        self.axis = np.array(scene_rules.unit_vector(scene["shell"]["axis"]))
        self.material_axis = fem.Constant(self.mesh, self.axis.astype(PETSc.ScalarType))
        self._nodal = NodalProjection(self.Vu, self._compile)
        self._init_triad(self.axis)
        self._convected_axis = self._convected_axis_form() if compile_forms else None

        self._init_materials()
        self.coef = {k: fem.Constant(self.mesh, PETSc.ScalarType(0.0))
                     for k in ("cv", "cv_v", "cv_a", "ca", "ca_v", "ca_a", "alpha_f")}
        self._build_effects()
        fixed = self._build_bcs() + self._inactive_rotation_bcs()
        self.motions = self._build_motions()  # checks clashes with the fixed dofs
        self.bcs = fixed + [m.bc for m in self.motions]

    # --- set-up -----------------------------------------------------------

    def _theta_to_u_nodes(self, Vt) -> np.ndarray:
        """For each node of the θ space ``Vt``, the matching node of the u space.

        Both collapsed spaces come from the same scalar P2 layout, so the k-th
        node of a cell is the same point in both.
        """
        cu, ct = compat.cell_dofs(self.Vu), compat.cell_dofs(Vt)
        bs_u, bs_t = self.Vu.dofmap.index_map_bs, Vt.dofmap.index_map_bs
        assert bs_u == 3 and bs_t == 2 and cu.shape == ct.shape, "unexpected dof layout"
        n_t = Vt.dofmap.index_map.size_local + Vt.dofmap.index_map.num_ghosts
        node_map = np.full(n_t, -1, dtype=np.int64)
        node_map[ct.ravel()] = cu.ravel()
        assert (node_map >= 0).all()
        return node_map

    def _project_normal(self) -> np.ndarray:
        """Nodal unit normals: L2 projection of the cell normal onto [P2]³, normalised."""
        G1, G2 = kinematics.covariant_basis(self.mesh)
        n = self._nodal.project(self._compile(ufl.inner(kinematics.unit_normal(G1, G2),
                                                        self._nodal.test) * self._nodal.dx))
        return n / np.linalg.norm(n, axis=1)[:, None]

    def _init_triad(self, axis: np.ndarray):
        D = self._project_normal()
        self.D.x.array[:] = D.ravel()
        a1 = axis[None, :] - (D @ axis)[:, None] * D
        bad = np.linalg.norm(a1, axis=1) < 1e-6
        if self.scene.get("fluid") and self.comm.allreduce(int(bad.sum())):
            raise SceneError(f"shell.axis: expected a direction not along the shell normal (the "
                             f"drag frame needs a tangent axis), found {self.scene['shell']['axis']}, along the "
                             f"normal at {self.comm.allreduce(int(bad.sum()))} nodes")
        if bad.any():  # material axis along the normal: take any tangent
            other = np.where(np.abs(D[bad, 0:1]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]])
            a1[bad] = other - np.sum(other * D[bad], axis=1)[:, None] * D[bad]
        a1 /= np.linalg.norm(a1, axis=1)[:, None]
        for t1, t2, dn in self.triads:
            dn.x.array[:] = D.ravel()
            t1.x.array[:] = a1.ravel()
            t2.x.array[:] = np.cross(D, a1).ravel()

    def _convected_axis_form(self) -> list:
        """Compiled L2 right-hand sides of the convected material axis (kinematics.
        convected_axis) at the converged displacement, one per colour: the in-plane
        reference for each colour's nodal triads (``update_triad``).

        On a hinged body each colour takes the axis from its own cells only: at a
        hinge node the axis carried by the two sides differs once the hinge folds
        (unless it runs along the hinge), and a frame averaged over both sides
        is consistent with neither.  Mixed frames within a cell make the
        component-wise interpolated θ a distorted rotation, which resisted the
        fold of an oblique crease (a free-edge moment folded it 0.68 rad instead
        of π/2).  Only the direction of the projection is used, so the global
        mass matrix serves every colour."""
        G1, G2 = kinematics.covariant_basis(self.mesh)
        F_s = kinematics.surface_deformation_gradient(self.u_n)
        t = kinematics.convected_axis(F_s, self.material_axis, G1, G2)
        weights = self.colour_indicators or [1]
        return [self._compile(ufl.inner(chi * t, self._nodal.test) * self._nodal.dx)
                for chi in weights]

    def _cells_of(self, names, key: str = "region") -> np.ndarray:
        """Local cells of the named regions; an unknown name is a SceneError at ``key``."""
        for n in names:
            if n not in self.body.regions:
                known = ", ".join(sorted(self.body.regions)) or "none"
                raise SceneError(f"{key}: unknown region '{n}'; the mesh's regions are: {known}")
        tags = [t for n in names for t in self.body.regions[n]]
        ct = self.body.cell_tags
        return np.unique(ct.indices[np.isin(ct.values, tags)]).astype(np.int32)

    def _init_materials(self):
        """Cellwise (DG0) E, ν, t, ρ: one compiled form serves every scene."""
        V0 = compat.function_space(self.mesh, "DG", 0)
        shell = self.scene["shell"]
        dofs = compat.cell_dofs(V0)[:, 0]
        self.material = {}
        for key, name in (("E", "E"), ("nu", "nu"), ("thickness", "t"), ("density", "rho")):
            f = fem.Function(V0, name=name)
            f.x.array[:] = float(shell[key])
            for i, part in enumerate(shell.get("parts", [])):
                if key in part:
                    cells = self._cells_of([part["region"]], f"shell.parts.{i}.region")
                    f.x.array[dofs[cells]] = float(part[key])
            f.x.scatter_forward()
            self.material[name] = f

    # --- forms --------------------------------------------------------------

    def _compile(self, ufl_form):
        t0 = _time.perf_counter()
        form = compat.form(ufl_form)
        self.timings["compile"] += _time.perf_counter() - t0
        return form

    def kinematics(self):
        """UFL kinematics of the current iterate (u, θ, d, g₁, g₂) and reference geometry."""
        u, *thetas = ufl.split(self.w)
        G1, G2 = kinematics.covariant_basis(self.mesh)
        directors = [kinematics.director(theta, *triad)
                     for theta, triad in zip(thetas, self.triads)]
        d = directors[0]
        if self.n_colours > 1:
            d = hinge.panel_director(self.colour_indicators, directors)
        g1, g2 = kinematics.surface_basis(u, G1, G2)
        return u, thetas[0], d, g1, g2, G1, G2

    def velocity(self, u):
        c = self.coef
        return c["cv"] * (u - self.u_n) + c["cv_v"] * self.v_n + c["cv_a"] * self.a_n

    def acceleration(self, u):
        """``a_{n+1−α_m}`` as a function of the unknown displacement."""
        c = self.coef
        return c["ca"] * (u - self.u_n) + c["ca_v"] * self.v_n + c["ca_a"] * self.a_n

    def _build_effects(self):
        scene, mat = self.scene, self.material
        self.dx = ufl.Measure("dx", domain=self.mesh)
        u, theta, d, g1, g2, G1, G2 = self.kinematics()
        D = kinematics.unit(self.D)
        strains = (kinematics.membrane_strain(g1, g2, G1, G2),
                   kinematics.bending_strain(g1, g2, d, G1, G2, D),
                   kinematics.shear_strain(g1, g2, d, G1, G2, D))
        h = ufl.CellDiameter(self.mesh)
        self.energy = elasticity.stored_energy(strains, G1, G2, mat["E"], mat["nu"], mat["t"],
                                               self.dx, h)
        w_test = ufl.TestFunction(self.W)
        du = ufl.split(w_test)[0]
        self.director = d

        #: virtual work of every non-inertial effect, by name (docs/model.md §5)
        self.effects = {"elasticity": ufl.derivative(self.energy, self.w, w_test)}
        springs = [h for h in self.hinges if h.stiffness > 0]
        if springs:
            self.spring_energy = self._hinge_springs(u, d)
            self.energy = self.energy + self.spring_energy
            self.effects["hinge-spring"] = ufl.derivative(self.spring_energy, self.w, w_test)
        self.inertia = None
        if self._has_inertia():
            self.inertia = inertia.inertia_work(mat["rho"], mat["t"], self.acceleration(u), du,
                                                self.dx(metadata={"quadrature_degree": 4}))
        if self.scene.get("fluid"):
            self.effects["drag"] = self._drag(drag.drag_work, self.velocity(u), du)
        if self.scene.get("magnetic"):
            self.effects["magnetic"] = -self._build_magnetic(w_test)
        self.load_terms = self._build_loads(du, d, w_test)
        for kind in ("edge-force", "edge-moment"):
            terms = [term for k, term in self.load_terms if k == kind]
            if terms:
                self.effects[kind] = -sum(terms[1:], terms[0])

        forces = sum(list(self.effects.values())[1:], self.effects["elasticity"])
        self.forces_ufl = forces
        one_minus_af = 1 - self.coef["alpha_f"]
        residual = one_minus_af * forces + (self.inertia if self.inertia is not None else 0)
        self.jacobian_ufl = ufl.derivative(residual, self.w, ufl.TrialFunction(self.W))
        self.forces_form = self.inertia_form = self.jacobian_form = None
        if self.compile_forms:
            self.forces_form = self._compile(forces)
            if self.inertia is not None:
                self.inertia_form = self._compile(self.inertia)
            self.jacobian_form = self._compile(self.jacobian_ufl)

    def _hinge_springs(self, u, d):
        """``Σ ½ k ∫ φ² ds`` over the spring hinges (forms/hinge.py)."""
        dS = hinges.facet_measure(self.mesh, self.hinges)
        G1, G2 = kinematics.covariant_basis(self.mesh)
        N = kinematics.unit_normal(G1, G2)
        tangent = hinge.hinge_tangent(kinematics.surface_deformation_gradient(u)("+"), N("+"),
                                      ufl.FacetNormal(self.mesh)("+"))
        angle = hinge.fold_angle(d("-"), d("+"), tangent)
        self.fold_angle_ufl = (angle, dS)
        self.hinge_stiffness = [fem.Constant(self.mesh, PETSc.ScalarType(h.stiffness))
                                for h in self.hinges]
        return sum(hinge.hinge_spring_energy(k, angle, dS(i + 1))
                   for i, (h, k) in enumerate(zip(self.hinges, self.hinge_stiffness))
                   if h.stiffness > 0)

    def _drag(self, term, *args):
        """A drag form (``forms.drag``) of the current iterate with the scene's coefficients."""
        if not hasattr(self, "drag_coefficients"):
            C = np.asarray(self.scene["fluid"]["drag"], dtype=PETSc.ScalarType)
            self.drag_coefficients = fem.Constant(self.mesh, C)
        u, _, _, g1, g2, G1, G2 = self.kinematics()
        F_s = kinematics.surface_deformation_gradient(u)
        C = self.drag_coefficients
        return term([C[0], C[1], C[2]], F_s, self.material_axis, *args, g1, g2, G1, G2,
                    self.dx(metadata={"quadrature_degree": 4}))

    def drag_power(self) -> float:
        """Power dissipated by the drag, ``∫ (C̃ v)·v J dA₀`` (global), in the current
        configuration with the stored velocity ``v_n`` (after a step: its end state)."""
        if not hasattr(self, "_drag_power_form"):
            self._drag_power_form = self._compile(self._drag(drag.drag_power, self.v_n))
        return self.comm.allreduce(fem.assemble_scalar(self._drag_power_form))

    def drag_force(self) -> np.ndarray:
        """Total drag force on the body ``∫ C̃ v J dA₀`` (global), in the current
        configuration with the stored velocity ``v_n``."""
        if not hasattr(self, "_drag_force_forms"):
            self._drag_force_forms = [self._compile(f) for f in
                                      self._drag(drag.drag_force, self.v_n)]
        return np.array([self.comm.allreduce(fem.assemble_scalar(f))
                         for f in self._drag_force_forms])

    def centroid(self) -> np.ndarray:
        """Area-weighted mean of the current positions, ``∫ x dA₀ / ∫ dA₀`` (global)."""
        if not hasattr(self, "_centroid_forms"):
            x = ufl.SpatialCoordinate(self.mesh) + self.kinematics()[0]
            self._centroid_forms = [self._compile(x[i] * self.dx) for i in range(3)]
        return np.array([self.comm.allreduce(fem.assemble_scalar(f))
                         for f in self._centroid_forms]) / self.area()

    def rotational_drag(self, axis) -> float:
        """RFT drag coefficient ``ζ`` of a rigid rotation of the current shape about
        ``axis`` through the centroid: the dissipated power at unit rate,
        ``∫ (C̃ v)·v J dA₀`` with ``v = a × (x − x_c)`` (N·mm·s)."""
        if not hasattr(self, "_spin_drag_form"):
            self._spin_axis = fem.Constant(self.mesh, np.zeros(3, dtype=PETSc.ScalarType))
            self._spin_centre = fem.Constant(self.mesh, np.zeros(3, dtype=PETSc.ScalarType))
            x = ufl.SpatialCoordinate(self.mesh) + self.kinematics()[0]
            v = ufl.cross(self._spin_axis, x - self._spin_centre)
            self._spin_drag_form = self._compile(self._drag(drag.drag_power, v))
        axis = np.asarray(axis, dtype=float)
        self._spin_axis.value[:] = axis / np.linalg.norm(axis)
        self._spin_centre.value[:] = self.centroid()
        return self.comm.allreduce(fem.assemble_scalar(self._spin_drag_form))

    def _build_magnetic(self, w_test):
        """Magnetic virtual work over the magnetized cells (docs/model.md §5.5).

        The remanent magnetization ``m q₀`` of every part is stored cellwise
        (DG0 vector); the form is integrated over the parts' cells only.
        """
        mag, tdim = self.scene["magnetic"], self.mesh.topology.dim
        V = compat.function_space(self.mesh, "DG", 0, (3,))
        self.remanence = fem.Function(V, name="remanent_magnetization")
        dofs = compat.cell_dofs(V)[:, 0]
        owner = {}
        for i, part in enumerate(mag["parts"]):
            cells = self._cells_of([part["region"]], f"magnetic.parts.{i}.region")
            for j, other in owner.items():
                if self.comm.allreduce(int(np.isin(cells, other).sum())):
                    raise SceneError(f"magnetic.parts.{i}.region: '{part['region']}' overlaps "
                                     f"magnetic.parts.{j}.region; a cell has one magnetization")
            owner[i] = cells
            q0 = np.asarray(part["direction"], dtype=float)
            values = part["magnetization"] * q0 / np.linalg.norm(q0)
            array = self.remanence.x.array.reshape(-1, 3)
            array[dofs[cells]] = values
        self.remanence.x.scatter_forward()
        # parts switched off (magnetization 0, e.g. in a sweep) are left out of
        # the measure: q = F q₀ needs q₀ = M/|M|
        magnetized = [owner[i] for i, part in enumerate(mag["parts"])
                      if part["magnetization"] > 0]
        cells = np.unique(np.concatenate(magnetized or [np.empty(0, np.int32)])).astype(np.int32)
        tags = compat.create_meshtags(self.mesh, tdim, cells, np.ones(len(cells), dtype=np.int32))
        self.dx_magnetic = ufl.Measure("dx", domain=self.mesh, subdomain_data=tags,
                                       metadata={"quadrature_degree": 4})(1)
        self.field = fem.Constant(self.mesh, np.zeros(3, dtype=PETSc.ScalarType))
        u, _, d, g1, g2, G1, G2 = self.kinematics()
        M = self.remanence
        m = ufl.sqrt(ufl.dot(M, M))
        F = kinematics.deformation_gradient(g1, g2, d, G1, G2, kinematics.unit_normal(G1, G2))
        q = magnetic.magnetization_direction(F, M / m)
        self.magnetization_ufl = magnetic.magnetization(F, M)
        dq = ufl.derivative(q, self.w, w_test)
        J = kinematics.area_ratio(g1, g2, G1, G2)
        self._moment_ufl = magnetic.magnetic_moment(self.material["t"], m, q, J, self.dx_magnetic)
        return magnetic.magnetic_work(self.material["t"], m, self.field, dq, J, self.dx_magnetic)

    def magnetic_moment(self) -> np.ndarray:
        """Total magnetic moment ``∫ t m q J dA₀`` of the current iterate (global, A·mm²).

        The field's torque on a rigid body is ``Q × b``; the field's work over a
        step is ``b·ΔQ`` to first order (the couple's virtual work is ``b·δq``).
        """
        if not hasattr(self, "_moment_forms"):
            self._moment_forms = [self._compile(c) for c in self._moment_ufl]
        return np.array([self.comm.allreduce(fem.assemble_scalar(f))
                         for f in self._moment_forms])

    def field_at(self, t: float) -> np.ndarray:
        """The applied field ``b(t)`` of ``[magnetic.field]`` (docs/scenes.md).

        Phase 1 (``t ≤ ramp_time``): strength ramps linearly from 0 along
        ``direction``.  Phase 2: full strength, rotating right-handedly about
        ``rotation_axis`` at ``frequency`` Hz from ``direction``.
        """
        f = self.scene["magnetic"]["field"]
        direction, axis = (np.array(scene_rules.unit_vector(f[key]))
                           for key in ("direction", "rotation_axis"))
        ramp = f["ramp_time"]
        if t <= ramp:
            return f["strength"] * (t / ramp if ramp > 0 else 1.0) * direction
        angle = 2 * np.pi * f["frequency"] * (t - ramp)
        return f["strength"] * rotate(direction[None, :], angle * axis[None, :])[0]

    def _has_inertia(self) -> bool:
        return scene_rules.has_inertia(self.scene)

    def active_effects(self) -> list[str]:
        """Effect names in the order of ``scene.active_effects``."""
        names = ["elasticity"]
        if self.hinges:
            names.append("hinge")
        names += [name for name in self.effects if name != "elasticity"]
        if self.inertia is not None:
            names.insert(1 + int(bool(self.hinges)) + int("hinge-spring" in names), "inertia")
        if self.motions:
            names.append("prescribed-motion")
        return names

    # --- where-selectors ----------------------------------------------------

    def facets_of(self, where: str, key: str, line: bool = False) -> np.ndarray:
        """Local facets selected by an edge selector or a named curve group; with
        ``line`` (hinges) also ``"x=c"`` / ``"y=c"``: the facets on that line."""
        tdim = self.mesh.topology.dim
        at_line = scene_rules.hinge_line(where) if line and where not in self.body.edges else None
        if at_line:
            axis, at = "xy".index(at_line[0]), at_line[1]
            tol = 1e-8 * max(self.body.length, self.body.width)
            facets = dmesh.locate_entities(self.mesh, tdim - 1,
                                           lambda x: np.abs(x[axis] - at) < tol)
            if self.comm.allreduce(len(facets)) == 0:
                raise SceneError(f"{key}: '{where}' is not a line of the mesh (no cell edge "
                                 "lies on it)")
        elif where in EDGE_SELECTORS:
            axis = 0 if where[0] == "x" else 1
            at = 0.0 if where[2] == "0" else (self.body.length if axis == 0 else self.body.width)
            tol = 1e-8 * max(self.body.length, self.body.width)
            facets = dmesh.locate_entities_boundary(
                self.mesh, tdim - 1, lambda x: np.abs(x[axis] - at) < tol)
        elif where in self.body.edges:
            ft = self.body.facet_tags
            facets = ft.indices[np.isin(ft.values, self.body.edges[where])]
        elif where in self.body.regions or where == "all":
            raise SceneError(f"{key}: '{where}' is a surface region; this needs an edge "
                             f"({', '.join(EDGE_SELECTORS + tuple(self.body.edges))})")
        else:
            raise SceneError(f"{key}: unknown selector '{where}'; expected one of "
                             f"{', '.join(self.selectors())}")
        facets = np.unique(np.asarray(facets, dtype=np.int32))
        if self.comm.allreduce(len(facets)) == 0:
            raise SceneError(f"{key}: '{where}' selects no edge of the body")
        return facets

    def selectors(self) -> list[str]:
        return ["all", *EDGE_SELECTORS, *self.body.regions, *self.body.edges]

    def entities_of(self, where: str, key: str):
        """(dim, local entities) selected by any ``where`` selector."""
        tdim = self.mesh.topology.dim
        if where == "all":
            n = self.mesh.topology.index_map(tdim).size_local
            n += self.mesh.topology.index_map(tdim).num_ghosts
            return tdim, np.arange(n, dtype=np.int32)
        if where in self.body.regions:
            cells = self._cells_of([where])
            if self.comm.allreduce(len(cells)) == 0:
                raise SceneError(f"{key}: region '{where}' selects no cell")
            return tdim, cells
        return tdim - 1, self.facets_of(where, key)

    # --- loads ----------------------------------------------------------------

    def _build_loads(self, du, d, w_test):
        """Edge forces and moments, per unit reference length of their edge."""
        loads_ = self.scene.get("load", [])
        self.load_values = []
        if not loads_:
            return []
        tdim = self.mesh.topology.dim
        wheres = sorted({ld["where"] for ld in loads_})
        facet_sets = {w: self.facets_of(w, f"load.{[ld['where'] for ld in loads_].index(w)}.where")
                      for w in wheres}
        boundary = dmesh.exterior_facet_indices(self.mesh.topology)
        for w, facets in facet_sets.items():
            if self.comm.allreduce(int((~np.isin(facets, boundary)).sum())):
                k = [ld["where"] for ld in loads_].index(w)
                raise SceneError(f"load.{k}.where: '{w}' runs inside the body (a hinge or an "
                                 "interior curve); edge loads act on the body's boundary edges")
        all_facets = np.concatenate(list(facet_sets.values()))
        if len(np.unique(all_facets)) != len(all_facets):
            raise SceneError("load: edge loads on overlapping edges must use the same 'where'")
        tags = np.concatenate([np.full(len(facet_sets[w]), i + 1) for i, w in enumerate(wheres)])
        ft = compat.create_meshtags(self.mesh, tdim - 1, all_facets, tags)
        ds = ufl.Measure("ds", domain=self.mesh, subdomain_data=ft,
                         metadata={"quadrature_degree": 4})
        dd = ufl.derivative(d, self.w, w_test)
        terms = []
        for k, ld in enumerate(loads_):
            tag = wheres.index(ld["where"]) + 1
            length = self.comm.allreduce(fem.assemble_scalar(self._compile(
                fem.Constant(self.mesh, PETSc.ScalarType(1.0)) * ds(tag))))
            value = fem.Constant(self.mesh, np.zeros(3, dtype=PETSc.ScalarType))
            self.load_values.append((ld, value, np.asarray(ld["value"], dtype=float) / length))
            if ld["kind"] == "edge-force":
                terms.append(("edge-force", loads.edge_force_work(value, du, ds(tag))))
            else:
                terms.append(("edge-moment", loads.edge_moment_work(value, d, dd, ds(tag))))
        return terms

    # --- boundary conditions -----------------------------------------------

    def _build_bcs(self):
        tdim = self.mesh.topology.dim
        self._bc_functions = {}
        self._fixed_dofs = []
        bcs = []
        for k, bnd in enumerate(self.scene.get("boundary", [])):
            key = f"boundary.{k}.where"
            dim, entities = self.entities_of(bnd["where"], key)
            fix = set(bnd["fix"])
            if "clamped" in fix:
                fix = {"ux", "uy", "uz", "rotation"}
            # (component, sub-space, its name, entities)
            subs = [(c, self.W.sub(0).sub(DISPLACEMENT_COMPONENTS[c]), c, entities)
                    for c in sorted(fix) if c in DISPLACEMENT_COMPONENTS]
            if "rotation" in fix:
                # each colour's rotation on the selected entities of its own panels:
                # a clamped link leaves the director across its hinge free
                for c in range(self.n_colours):
                    own = self._entities_of_colour(dim, entities, c)
                    subs += [(f"theta{i + 1}", self.W.sub(1 + c).sub(i), f"theta{i + 1}_{c}",
                              own) for i in range(2)]
            counts = {}
            for component, sub, name, ents in subs:
                bc, n = self._zero_bc(sub, dim, ents, name)
                counts[component] = counts.get(component, 0) + n
                bcs.append(bc)
            for n in counts.values():
                if self.comm.allreduce(n) == 0:
                    raise SceneError(f"{key}: '{bnd['where']}' matches no degree of freedom")
        return bcs

    def _entities_of_colour(self, dim, entities, c):
        """The cells (dim = tdim) of colour ``c`` among ``entities``, or the facets
        among them that touch a local cell of colour ``c``."""
        if self.n_colours == 1:
            return entities
        tdim = self.mesh.topology.dim
        if dim == tdim:
            return entities[self.colours[entities] == c]
        f2c = self.mesh.topology.connectivity(tdim - 1, tdim)
        keep = [f for f in entities if (self.colours[f2c.links(f)] == c).any()]
        return np.asarray(keep, dtype=np.int32)

    def _inactive_rotation_bcs(self):
        """θ_c = 0 away from the cells of colour c: there it does not enter any form."""
        if self.n_colours == 1:
            return []
        tdim = self.mesh.topology.dim
        bcs = []
        for c in range(self.n_colours):
            for i in range(2):
                sub = self.W.sub(1 + c).sub(i)
                V, zero = self._component_space(sub, f"theta{i + 1}_{c}")
                own = fem.locate_dofs_topological((sub, V), tdim,
                                                  hinges.cells_of_colour(self.colours, c))
                other = fem.locate_dofs_topological(
                    (sub, V), tdim, np.nonzero(self.colours != c)[0].astype(np.int32))
                keep = ~np.isin(other[0], own[0])
                dofs = [np.asarray(other[0])[keep], np.asarray(other[1])[keep]]
                bcs.append(fem.dirichletbc(zero, dofs, sub))
        return bcs

    def _zero_bc(self, sub, dim, entities, name):
        V, zero = self._component_space(sub, name)
        dofs = fem.locate_dofs_topological((sub, V), dim, entities)
        self._fixed_dofs.append((np.asarray(dofs[0]), name))
        return fem.dirichletbc(zero, dofs, sub), len(dofs[0])

    # --- prescribed motion ----------------------------------------------------

    def _build_motions(self) -> list["Motion"]:
        """One time-dependent Dirichlet condition per ``[[motion]]`` (docs/model.md §5.7).

        The value lives in a Function on the collapsed component space and is
        interpolated at every time the solver visits (:meth:`set_time`).
        """
        motions = []
        fixed = {}  # component -> [(who holds them, dofs)]
        for bc_dofs, name in self._fixed_dofs:
            fixed.setdefault(name, []).append(("a [[boundary]]", bc_dofs))
        for k, spec in enumerate(self.scene.get("motion", [])):
            key = f"motion.{k}"
            dim, entities = self.entities_of(spec["where"], key + ".where")
            component = spec["component"]
            sub = self.W.sub(0).sub(DISPLACEMENT_COMPONENTS[component])
            V, _ = self._component_space(sub, component)
            dofs = fem.locate_dofs_topological((sub, V), dim, entities)
            if self.comm.allreduce(len(dofs[0])) == 0:
                raise SceneError(f"{key}.where: '{spec['where']}' matches no degree of freedom")
            for holder, other in fixed.get(component, []):
                clash = self.comm.allreduce(int(np.isin(dofs[0], other).sum()))
                if clash:
                    how = "fixed by" if holder.startswith("a ") else "already prescribed by"
                    raise SceneError(f"{key}: {component} is both prescribed here and {how} "
                                     f"{holder} at {clash} dofs; a dof takes one condition")
            fixed.setdefault(component, []).append((key, np.asarray(dofs[0])))
            value = fem.Function(V, name=f"motion_{k}")
            X = V.tabulate_dof_coordinates()[np.asarray(dofs[1]), 0]
            motions.append(Motion(spec, value, np.asarray(dofs[1]), X,
                                  fem.dirichletbc(value, dofs, sub)))
        return motions

    def _component_space(self, sub, name):
        if name not in self._bc_functions:
            V, _ = sub.collapse()
            self._bc_functions[name] = (V, fem.Function(V))
        return self._bc_functions[name]

    # --- per-step updates ---------------------------------------------------

    def set_coefficients(self, c):
        for key in self.coef:
            self.coef[key].value = getattr(c, key)

    def set_time(self, t: float):
        end = self.scene["time"]["end"]
        for ld, const, per_length in self.load_values:
            const.value[:] = per_length * ramp_scale(ld, t, end)
        for motion in self.motions:
            motion.set(t)
        if self.scene.get("magnetic"):
            self.field.value[:] = self.field_at(t)

    def reference_force(self) -> float:
        """A force scale of the scene, for absolute Newton tolerances (docs/model.md §7).

        The largest of: the bending force ``D W / L²`` that bends the body by
        order one, each total edge force, each edge moment over the length.
        """
        shell, L, W = self.scene["shell"], self.body.length, max(self.body.width, 1e-300)
        E = max([shell["E"]] + [p["E"] for p in shell.get("parts", []) if "E" in p])
        D = E * shell["thickness"] ** 3 / (12 * (1 - shell["nu"] ** 2))
        scales = [D * W / L**2]
        for ld, _, per_length in self.load_values:
            total = float(np.linalg.norm(ld["value"]))
            scales.append(total if ld["kind"] == "edge-force" else total / L)
        if self.scene.get("magnetic"):
            # the largest couple of one part, t m B A, as a force over the length
            f = self.scene["magnetic"]["field"]
            for part in self.scene["magnetic"]["parts"]:
                area = self.area(self._cells_of([part["region"]]))
                scales.append(shell["thickness"] * part["magnetization"] * f["strength"]
                              * area / L)
        if self.scene.get("fluid") and self.motions:
            # drag on the whole body moving at the fastest prescribed speed
            speed = max(m.speed_scale(self.scene["time"]["end"]) for m in self.motions)
            scales.append(max(self.scene["fluid"]["drag"]) * self.area() * speed)
        return max(scales)

    def area(self, cells=None) -> float:
        """Reference area ``∫ dA₀`` of the body, or of the given local cells."""
        one = fem.Constant(self.mesh, PETSc.ScalarType(1.0))
        if cells is None:
            if not hasattr(self, "_area"):  # a reference quantity: computed once
                self._area = self.comm.allreduce(
                    fem.assemble_scalar(self._compile(one * self.dx)))
            return self._area
        n = self.mesh.topology.index_map(self.mesh.topology.dim).size_local
        cells = np.asarray(cells)[np.asarray(cells) < n].astype(np.int32)  # owned only
        tags = compat.create_meshtags(self.mesh, self.mesh.topology.dim, cells,
                                      np.ones(len(cells), dtype=np.int32))
        dx = ufl.Measure("dx", domain=self.mesh, subdomain_data=tags)
        return self.comm.allreduce(fem.assemble_scalar(self._compile(one * dx(1))))

    def director_unit_error(self) -> float:
        """``max | |d| − 1 |`` over all nodal directors of every colour (global)."""
        d = np.concatenate([dn.x.array.reshape(-1, 3) for _, _, dn in self.triads])
        local = float(np.abs(np.linalg.norm(d, axis=1) - 1).max()) if len(d) else 0.0
        return self.comm.allreduce(local, op=MPI.MAX)

    def nodal_director(self):
        """The nodal directors as one [P2]³ Function (for output).  On a hinged body a
        node on a hinge has one director per side; there the highest colour's is shown."""
        if self.n_colours == 1:
            return self.dn
        if not hasattr(self, "_director_out"):
            self._director_out = fem.Function(self.Vu, name="director")
            dofs = compat.cell_dofs(self.Vu)
            self._colour_nodes = [np.unique(dofs[hinges.cells_of_colour(self.colours, c)])
                                  for c in range(self.n_colours)]
        out = self._director_out.x.array.reshape(-1, 3)
        for (_, _, dn), nodes in zip(self.triads, self._colour_nodes):
            out[nodes] = dn.x.array.reshape(-1, 3)[nodes]
        return self._director_out

    def elastic_energy(self) -> float:
        """Stored energy ``Π`` of the current iterate (compiled on first use)."""
        if not hasattr(self, "_energy_form"):
            self._energy_form = self._compile(self.energy)
        return self.comm.allreduce(fem.assemble_scalar(self._energy_form))

    def kinetic_energy(self) -> float:
        """``½ ∫ ρ t v·v dA₀`` of the stored velocity ``v_n``."""
        if not hasattr(self, "_kinetic_form"):
            self._kinetic_form = self._compile(inertia.kinetic_energy(
                self.material["rho"], self.material["t"], self.v_n, self.dx))
        return self.comm.allreduce(fem.assemble_scalar(self._kinetic_form))

    def restore(self):
        """Reset the iterate to the last converged state (θ = 0)."""
        self.w.x.array[self.u_dofs] = self.u_n.x.array
        self.w.x.array[self.theta_dofs] = 0.0

    def largest_rotation_increment(self) -> float:
        """The largest nodal rotation increment ``|θ|`` of the iterate, in radians
        (over all processes and colours; ``a₁, a₂`` are orthonormal, so
        ``|θ|² = θ¹² + θ²²``)."""
        theta = self.w.x.array[self.theta_dofs].reshape(-1, 2)
        local = float(np.sqrt((theta**2).sum(axis=1)).max()) if len(theta) else 0.0
        return self.comm.allreduce(local, op=MPI.MAX)

    def update_triad(self):
        """Rotate every nodal triad by the exact Rodrigues rotation of its θ; reset θ;
        then turn ``(a₁, a₂)`` about ``dₙ`` onto the convected material axis.

        The rotations have no drilling part, so a triad carried through many turns
        picks up an in-plane twist that depends on the path its director took
        (holonomy): after ~14 turns of the strip in a 64 Hz field, neighbouring
        nodes of one cell had ``a₁`` up to 180° apart.  ``θ¹, θ²`` are interpolated
        between nodes as components, so such frames make the interpolated
        rotation meaningless and leave θ almost free at single nodes.  Choosing
        ``a₁`` along the projected convected axis ``F_s A`` keeps the frames as
        smooth as the deformation; ``dₙ``, and with θ = 0 the whole current state,
        is unchanged by that choice.  A hinged body has one triad per colour.

        Done on owned and ghost nodes alike from ghost-updated values, so every
        copy of a node gets the identical triad without further communication.
        """
        for c, (dofs, idx, (t1, t2, tn)) in enumerate(zip(self.theta_dofs_of, self._node_maps,
                                                           self.triads)):
            theta = self.w.x.array[dofs].reshape(-1, 2)
            a1, a2, dn = (f.x.array.reshape(-1, 3) for f in (t1, t2, tn))
            rot = theta[:, 0:1] * a1[idx] + theta[:, 1:2] * a2[idx]
            for triad_vector in (a1, a2, dn):
                triad_vector[idx] = rotate(triad_vector[idx], rot)
            if self._convected_axis is not None:
                along = self._nodal.project(self._convected_axis[c])
                a1[:] = in_plane_frame(along, dn, a1)
                a2[:] = np.cross(dn, a1)
        self.w.x.array[self.theta_dofs] = 0.0

    @property
    def displacement(self):
        """The displacement of the last converged step (the Function ``u_n``)."""
        return self.u_n

    def destroy(self):
        """Free the model's own PETSc objects (the nodal projection's matrix and
        factorisation).  Forms and functions stay usable for inspection; a triad
        update after this rotates the triads but no longer realigns them."""
        self._nodal.destroy()
        self._convected_axis = None

    def accept(self, scheme, dt: float):
        """After convergence: update the state (u_n, v_n, a_n) and the triad."""
        u = self.w.x.array[self.u_dofs]
        du = u - self.u_n.x.array
        v, a = scheme.update(du, self.v_n.x.array, self.a_n.x.array, dt)
        self.v_n.x.array[:] = v
        self.a_n.x.array[:] = a
        self.u_n.x.array[:] = u
        self.update_triad()


class Motion:
    """A prescribed displacement component (docs/scenes.md ``[[motion]]``) and its Dirichlet value.

    ``travelling-wave``: ``u = amplitude sin(wavenumber (X − origin) + angular_frequency t)``
    with ``X`` the reference X coordinate of each dof; ``table``: piecewise linear
    in time, the same value at every selected dof.
    """

    def __init__(self, spec, value, value_dofs, X, bc):
        """``value_dofs``: the selected dofs of ``value``; ``X``: their reference X."""
        self.spec, self.value, self.value_dofs, self.X, self.bc = spec, value, value_dofs, X, bc
        if spec["kind"] == "table":
            self.table = np.asarray(spec["values"], dtype=float)

    def at(self, t: float, X):
        s = self.spec
        if s["kind"] == "table":
            return np.full_like(X, np.interp(t, self.table[:, 0], self.table[:, 1]))
        return s["amplitude"] * np.sin(s["wavenumber"] * (X - s["origin"])
                                       + s["angular_frequency"] * t)

    def set(self, t: float):
        self.value.x.array[self.value_dofs] = self.at(t, self.X)

    def speed_scale(self, end: float) -> float:
        """The largest speed this motion prescribes (for the solver's force scale)."""
        s = self.spec
        if s["kind"] == "table":
            table = self.table
            if len(table) < 2:
                return 0.0
            rates = np.abs(np.diff(table[:, 1]) / np.maximum(np.diff(table[:, 0]), 1e-300))
            return float(rates.max())
        return abs(s["amplitude"] * s["angular_frequency"])


def in_plane_frame(t: np.ndarray, dn: np.ndarray, fallback: np.ndarray) -> np.ndarray:
    """Rows of ``t`` projected onto the planes normal to the rows of ``dn`` and
    normalised; where ``t`` lies (almost) along ``dn`` the row of ``fallback``."""
    p = t - np.sum(t * dn, axis=1)[:, None] * dn
    size = np.linalg.norm(p, axis=1)
    ok = size > 1e-3 * np.linalg.norm(t, axis=1)
    out = np.array(fallback, dtype=float)
    out[ok] = p[ok] / size[ok, None]
    return out


class NodalProjection:
    """L2 projection onto a [P2]³ space with its mass matrix factorised once (LU)."""

    def __init__(self, V, compile_form):
        self.V = V
        self.test = ufl.TestFunction(V)
        self.dx = ufl.dx(domain=V.mesh, metadata={"quadrature_degree": 4})
        mass = compile_form(ufl.inner(ufl.TrialFunction(V), self.test) * self.dx)
        self.A = fem.petsc.assemble_matrix(mass)
        self.A.assemble()
        self.ksp = petsc_options.direct_solver(self.A)
        self.result = fem.Function(V)
        self.b = compat.petsc_vec(self.result).duplicate()  # ghosted like the result

    def project(self, rhs) -> np.ndarray:
        """Nodal values (owned and ghost), shape (nodes, 3), of the projection whose
        compiled right-hand side is ``rhs``."""
        with self.b.localForm() as local:
            local.set(0.0)
        compat.assemble_vector(self.b, rhs)
        self.b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        x = compat.petsc_vec(self.result)
        self.ksp.solve(self.b, x)
        x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        return self.result.x.array.reshape(-1, 3).copy()

    def destroy(self):
        for obj in (self.ksp, self.A, self.b):
            obj.destroy()


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
