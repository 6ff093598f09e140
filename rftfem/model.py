"""A scene turned into unknowns, state and the sum of its effects' forms.

The unknowns of a step are ``w = (u, θ)``: total displacement ``u`` in [P2]³ and
the rotation increment ``θ = (θ¹, θ²)`` in [P2]² about the nodal triad
``(a₁, a₂, dₙ)`` of the last converged step (docs/model.md §4).  The triad is kept as
three [P2]³ functions, rotated node by node after each converged step, and its
in-plane pair turned about dₙ onto the convected material axis (``update_triad``).
Hinge lines cut the body into panels of several colours, each with its own θ
and triad (rftfem/hinges.py).

Everything else is an effect component (rftfem/effects): the Model builds the
ones the scene asks for, in the registry's order, and adds up their terms
(docs/model.md §5).
"""

from __future__ import annotations

import time as _time
from types import SimpleNamespace

import numpy as np
import ufl
from dolfinx import fem
from mpi4py import MPI
from petsc4py import PETSc

from rftfem.forms import hinge, kinematics

from . import compat, effects, hinges
from .dirichlet import DirichletSpaces
from .errors import SceneError
from .schema import unit_vector
from .selectors import cells_of
from .triad import Triads
from .triad import rotate as triad_rotate


class Model:
    """Function spaces, state, material fields and the active effects of one scene."""

    def __init__(self, scene: dict, body, compile_forms: bool = True,
                 tangent: str = "mixed-point"):
        self.scene, self.body, self.compile_forms = scene, body, compile_forms
        self.mesh = body.mesh
        self.comm = self.mesh.comm
        tdim = self.mesh.topology.dim
        self.mesh.topology.create_connectivity(tdim - 1, tdim)
        self.timings = {"compile": 0.0}
        self.dx = ufl.Measure("dx", domain=self.mesh)
        self._kinematics = None

        # hinges cut the body into panels; panels that touch get different colours,
        # and each colour has its own rotation field and triad (forms/hinge.py)
        self.hinges = hinges.resolve(self, scene)
        self.n_colours, self.colours, self.colour_indicators = 1, None, None
        if self.hinges:
            cut = np.unique(np.concatenate([h.facets for h in self.hinges]))
            labels = hinges.panel_labels(self.mesh, cut)
            self.colours, self.n_colours = hinges.colour_panels(self.mesh, labels, cut,
                                                                self.hinges)
        if self.n_colours > 1:  # χ_c, 1 on the cells of colour c (DG0)
            self.colour_indicators = hinges.indicators(self.mesh, self.colours, self.n_colours)

        # unknowns: u, then one θ per colour; the state of the last step
        self.W = compat.mixed_space(self.mesh, [("Lagrange", 2, (3,))]
                                    + [("Lagrange", 2, (2,))] * self.n_colours)
        self.Vu, self.u_dofs = compat.collapse(self.W.sub(0))
        self.theta_dofs_of = [compat.collapse(self.W.sub(1 + c))[1]
                              for c in range(self.n_colours)]
        #: every rotation dof of the mixed space, in (θ¹, θ²) pairs
        self.theta_dofs = np.concatenate(self.theta_dofs_of)
        self.w = fem.Function(self.W, name="w")
        self.u_n, self.v_n, self.a_n = (fem.Function(self.Vu, name=n)
                                        for n in ("u_n", "v_n", "a_n"))
        #: the last two accepted steps' (Δu, θ, dt), newest first: the next step's prediction
        self.increments = []
        #: the largest displacement increment of the last prediction (0: none made)
        self.predicted_step = 0.0
        #: the last predictions {past steps used: (u, θ)}, or None; made only when
        #: ``keep_predictions`` (error-controlled steps)
        self.prediction = None
        self.keep_predictions = False

        #: the previous and the current Newton iterate and their difference: the data of
        #: the mixed-integration-point tangent (docs/model.md §7.4), set by the solver
        self.newton_previous, self.newton_current, self.newton_update = (
            fem.Function(self.W, name=n) for n in ("w_previous", "w_current", "w_update"))
        self.mixed_point = tangent == "mixed-point"
        self._newton_last = None  # the iterate of the last tangent (tangent_at_iterate)
        #: whether a solve's first mixed-point tangent carries the stress resultants of
        #: the last converged state (time steps) or those of its own start (static
        #: load steps); set by the Simulation from its scheme (docs/model.md §7.4)
        self.first_tangent_converged = False

        # the nodal triads (a1, a2, dn) of each colour and the reference director D
        self.triad = Triads(self, np.array(unit_vector(scene["shell"]["axis"])))
        self.triads, self.D = self.triad.frames, self.triad.D
        self.dn, self.material_axis = self.triads[0][2], self.triad.material_axis
        self._init_materials()
        #: the time scheme's coefficients of velocity and acceleration (rftfem/timeint.py)
        self.coef = {k: fem.Constant(self.mesh, PETSc.ScalarType(0.0))
                     for k in ("cv", "cv_v", "cv_a", "ca", "ca_v", "ca_a", "alpha_f")}
        self.coefficients = None  # the last ones set (timeint.Coefficients)
        #: prescribed motions in a second-order scheme: corrections to the velocity and
        #: acceleration that make them the motion's own on the driven dofs (motion.py)
        self.drive = None
        if effects.Motions.active(scene) and effects.Inertia.active(scene):
            self.drive = (fem.Function(self.Vu, name="v_drive"),
                          fem.Function(self.Vu, name="a_drive"))

        # the effects, then their sum; Dirichlet values are kept per component space
        self.dirichlet = DirichletSpaces()
        self.components = [cls(self) for cls in effects.REGISTRY if cls.active(scene)]
        self._sum_terms()
        self.bcs = [bc for comp in self.components for bc in comp.bcs()]
        self.bcs += hinges.inactive_rotation_bcs(self)
        self.has_moving_bcs = any(comp.moving for comp in self.components)

    def get(self, name: str):
        """The active component called ``name`` (``"drag"``, ``"magnetic"``, ...) or None."""
        return next((c for c in self.components if c.name == name), None)

    def __getitem__(self, name: str):
        comp = self.get(name)
        if comp is None:
            raise KeyError(f"the scene has no active effect '{name}'")
        return comp

    def active_effects(self) -> list[str]:
        """The active effect names, as ``rftfem check`` lists them."""
        return effects.active_effects(self.scene)

    # --- set-up -----------------------------------------------------------

    def axis_error(self, why: str) -> SceneError:
        """The error of a ``shell.axis`` along the normal, for an effect that needs it."""
        return SceneError(f"shell.axis: expected a direction not along the shell normal ({why}),"
                          f" found {self.scene['shell']['axis']}, along the normal at "
                          f"{self.triad.axis_along_normal} nodes")

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
                    cells = cells_of(self.body, [part["region"]], f"shell.parts.{i}.region")
                    f.x.array[dofs[cells]] = float(part[key])
            f.x.scatter_forward()
            self.material[name] = f

    # --- forms --------------------------------------------------------------

    def compile(self, ufl_form):
        """A UFL form compiled for assembly (its time counted in ``timings``)."""
        t0 = _time.perf_counter()
        form = compat.form(ufl_form)
        self.timings["compile"] += _time.perf_counter() - t0
        return form

    def assemble_scalar(self, form) -> float:
        """A compiled scalar form, summed over all processes."""
        return self.comm.allreduce(fem.assemble_scalar(form))

    def kinematics(self) -> SimpleNamespace:
        """UFL kinematics of the current iterate (built once): ``u``, the rotations
        ``thetas``, the director ``d``, ``g₁, g₂``, ``F_s``, the reference ``G₁, G₂``, and
        the test functions ``w_test`` (all unknowns) and ``du`` (its displacement part)."""
        if self._kinematics is None:
            w_test = ufl.TestFunction(self.W)
            self._kinematics = self.kinematics_of(self.w)
            self._kinematics.w_test, self._kinematics.du = w_test, ufl.split(w_test)[0]
        return self._kinematics

    def kinematics_of(self, w) -> SimpleNamespace:
        """The kinematics of ``kinematics()`` for any function ``w`` of the mixed space
        (its rotations measured in the step's triads), without test functions."""
        u, *thetas = ufl.split(w)
        G1, G2 = kinematics.covariant_basis(self.mesh)
        directors = [kinematics.director(theta, *triad)
                     for theta, triad in zip(thetas, self.triads)]
        d = (hinge.panel_director(self.colour_indicators, directors) if self.n_colours > 1
             else directors[0])
        g1, g2 = kinematics.surface_basis(u, G1, G2)
        return SimpleNamespace(u=u, thetas=thetas, d=d, g1=g1, g2=g2, G1=G1, G2=G2,
                               F_s=kinematics.surface_deformation_gradient(u))

    def velocity(self, u):
        """``v_{n+1}`` (or its scheme's blend) as a function of the unknown displacement."""
        c = self.coef
        v = c["cv"] * (u - self.u_n) + c["cv_v"] * self.v_n + c["cv_a"] * self.a_n
        return v + self.drive[0] if self.drive else v

    def acceleration(self, u):
        """``a_{n+1−α_m}`` as a function of the unknown displacement."""
        c = self.coef
        a = c["ca"] * (u - self.u_n) + c["ca_v"] * self.v_n + c["ca_a"] * self.a_n
        return a + self.drive[1] if self.drive else a

    def _sum_terms(self):
        """Stored energy, forces ``F(w)`` (every non-inertial effect), inertia, and the
        step's Jacobian ``∂/∂w [(1 − α_f) F + inertia]`` (docs/model.md §5, §6)."""
        w_test = self.kinematics().w_test
        energies = [c.energy() for c in self.components]
        self.energy = sum((e for e in energies if e is not None), 0)
        #: virtual work of every non-inertial effect, by component name
        self.effects = {}
        for c, energy in zip(self.components, energies):
            terms = [ufl.derivative(energy, self.w, w_test)] if energy is not None else []
            terms += [work for work in [c.forces()] if work is not None]
            if terms:
                self.effects[c.name] = sum(terms[1:], terms[0])
        inertia = [c.inertia() for c in self.components if c.inertia() is not None]
        self.inertia = sum(inertia[1:], inertia[0]) if inertia else None
        terms = list(self.effects.values())
        self.forces_ufl = sum(terms[1:], terms[0])
        residual = (1 - self.coef["alpha_f"]) * self.forces_ufl + (self.inertia or 0)
        trial = ufl.TrialFunction(self.W)
        self.jacobian_ufl = ufl.derivative(residual, self.w, trial)
        corrections = [c.tangent_correction() for c in self.components] if self.mixed_point \
            else []
        for corr in (c for c in corrections if c is not None):
            self.jacobian_ufl += (1 - self.coef["alpha_f"]) * ufl.derivative(
                ufl.derivative(corr, self.w, w_test), self.w, trial)
        self.forces_form = self.inertia_form = self.jacobian_form = None
        if self.compile_forms:
            self.forces_form = self.compile(self.forces_ufl)
            if self.inertia is not None:
                self.inertia_form = self.compile(self.inertia)
            self.jacobian_form = self.compile(self.jacobian_ufl)

    def add_nodal_forces(self, F: np.ndarray):
        """Add the components' nodal forces to the local array of an assembled ``F``."""
        for comp in self.components:
            comp.add_nodal_forces(F)

    # --- per-step updates ---------------------------------------------------

    def set_coefficients(self, c):
        self.coefficients = c
        for key in self.coef:
            self.coef[key].value = getattr(c, key)

    def set_time(self, t: float, scheme=None):
        """Loads and motions at ``t``; with a second-order ``scheme``, the driven dofs'
        exact rates of the step ending at ``t`` (after ``set_coefficients``)."""
        for comp in self.components:
            comp.set_time(t)
        if self.drive:
            self["prescribed-motion"].drive_step(
                t if scheme is not None and scheme.has_inertia else None, self.coefficients)

    def drive_state(self, t: float, scheme) -> None:
        """With a second-order scheme (None: the model's own), the driven dofs' stored
        rates at ``t`` (motion.py)."""
        if self.drive and (scheme is None or scheme.has_inertia):
            self["prescribed-motion"].drive_state(t)

    def reference_force(self) -> float:
        """A force scale of the scene for absolute Newton tolerances (docs/model.md §7.3):
        the largest of the forces that drive the body (loads, couples, drag at the
        prescribed speed); the bending force only where nothing else has a scale (a
        body moved by its supports alone). The elastic forces answer the drivers:
        where they dwarf them (a free link turning in drag) a tolerance in their
        units would accept states whose driving balance is not met at all."""
        drivers = [s for comp in self.components if comp.name != "elasticity"
                   for s in comp.force_scales() if s > 0]
        return max(drivers) if drivers else self.elastic_force()

    def elastic_force(self) -> float:
        """The bending force ``D W / L²`` that bends the body by order one."""
        return max(self["elasticity"].force_scales())

    def membrane_force(self) -> float:
        """The membrane force ``E t W`` that stretches the body by order one."""
        return self["elasticity"].membrane_force()

    def restore(self):
        """Reset the iterate to the last converged state (θ = 0)."""
        self.w.x.array[self.u_dofs] = self.u_n.x.array
        self.w.x.array[self.theta_dofs] = 0.0

    def prediction_error(self, past_steps: int = 2) -> tuple[float, float] | None:
        """How far the converged iterate lies from a prediction made from the last
        ``past_steps`` steps (1: the last rate carried on, 2: the last two rates
        extrapolated): the largest nodal ``|u − u^P|`` and ``|θ − θ^P|`` over all
        processes; None if the step started from the last state (no step known,
        docs/model.md §6.9).  With one step known the linear prediction
        stands in for the quadratic one (an over-estimate: the safe side)."""
        if self.prediction is None:
            return None
        u_p, theta_p = self.prediction[min(past_steps, max(self.prediction))]
        du = self.w.x.array[self.u_dofs] - u_p
        dth = (self.w.x.array[self.theta_dofs] - theta_p).reshape(-1, 2)
        local = (float(np.abs(du).max()) if len(du) else 0.0,
                 float(np.sqrt((dth**2).sum(axis=1)).max()) if len(dth) else 0.0)
        both = np.array(local)
        self.comm.Allreduce(MPI.IN_PLACE, both, op=MPI.MAX)
        return float(both[0]), float(both[1])

    def size(self) -> float:
        """Diagonal of the reference body's bounding box (global): the length that
        displacement errors are measured against."""
        if not hasattr(self, "_size"):
            x = self.mesh.geometry.x
            lo = x.min(axis=0) if len(x) else np.full(3, np.inf)
            hi = x.max(axis=0) if len(x) else np.full(3, -np.inf)
            self.comm.Allreduce(MPI.IN_PLACE, lo, op=MPI.MIN)
            self.comm.Allreduce(MPI.IN_PLACE, hi, op=MPI.MAX)
            self._size = float(np.linalg.norm(hi - lo))
        return self._size

    def largest_rotation_increment(self) -> float:
        """The largest nodal ``|θ|`` of the iterate over all processes and colours
        (``a₁, a₂`` are orthonormal, so ``|θ|² = θ¹² + θ²²``)."""
        theta = self.w.x.array[self.theta_dofs].reshape(-1, 2)
        local = float(np.sqrt((theta**2).sum(axis=1)).max()) if len(theta) else 0.0
        return self.comm.allreduce(local, op=MPI.MAX)

    def start_newton(self):
        """A Newton solve begins: its first tangent is that of ``first_tangent_converged``,
        the next ones the mixed-point tangents of the updates Newton makes (docs/model.md
        §7.4)."""
        self._newton_last = None

    def tangent_at_iterate(self):
        """Before a tangent at the iterate ``w``: the data of its correction (the last
        iterate, this one, their difference); this one is the next one's last.

        At a solve's first iterate there is no last one.  With
        ``first_tangent_converged`` the "last" is the last converged state and the
        difference is taken as zero: the defect ``ε(w) − ε(w_n)`` then replaces the
        start's membrane and shear resultants by the converged ones (the stress
        predictor of the mixed-integration-point method).  Without it the defect is
        zero: the exact tangent at the start."""
        if not self.mixed_point:
            return
        current = self.w.x.array
        if self._newton_last is None and self.first_tangent_converged:
            converged = self.newton_previous.x.array
            converged[:] = current
            converged[self.u_dofs] = self.u_n.x.array
            converged[self.theta_dofs] = 0.0
            self.newton_current.x.array[:] = current
            self.newton_update.x.array[:] = 0.0
            self._newton_last = current.copy()
            return
        if self._newton_last is None:
            self._newton_last = current.copy()
        self.newton_previous.x.array[:] = self._newton_last
        self.newton_current.x.array[:] = current
        self.newton_update.x.array[:] = current - self._newton_last
        self._newton_last = current.copy()

    def update_triad(self):
        """Rotate the nodal triads by the converged θ and realign them (triad.py); θ = 0."""
        self.triad.update(self.w.x.array, self.theta_dofs_of)
        self.w.x.array[self.theta_dofs] = 0.0

    def accept(self, scheme, dt: float, t: float | None = None):
        """After convergence at ``t``: update the state (u_n, v_n, a_n) and the triad,
        and keep the step's increment (Δu, θ) and dt for the next steps' prediction."""
        u = self.w.x.array[self.u_dofs]
        du = u - self.u_n.x.array
        v, a = scheme.update(du, self.v_n.x.array, self.a_n.x.array, dt)
        self.increments = [(du, self.w.x.array[self.theta_dofs].copy(), dt)] + self.increments[:1]
        self.v_n.x.array[:] = v
        self.a_n.x.array[:] = a
        if t is not None:
            self.drive_state(t, scheme)
        self.u_n.x.array[:] = u
        self.update_triad()

    def state(self) -> tuple[dict, list]:
        """What a checkpoint keeps of the model (checkpoint.py): this process's arrays
        of the iterate, the last state, every colour's triad and the last increments,
        and the increments' steps."""
        arrays = {"w": self.w.x.array, "u_n": self.u_n.x.array, "v_n": self.v_n.x.array,
                  "a_n": self.a_n.x.array}
        for c, frame in enumerate(self.triads):
            for k, f in enumerate(frame):
                arrays[f"triad_{c}_{k}"] = f.x.array
        for i, (du, theta, _) in enumerate(self.increments):
            arrays[f"increment_{i}_u"], arrays[f"increment_{i}_theta"] = du, theta
        return {k: v.copy() for k, v in arrays.items()}, [dt for *_, dt in self.increments]

    def set_state(self, arrays: dict, increment_steps: list):
        """The model as ``state`` returned it (a restart)."""
        for name, f in (("w", self.w), ("u_n", self.u_n), ("v_n", self.v_n), ("a_n", self.a_n)):
            f.x.array[:] = arrays[name]
        for c, frame in enumerate(self.triads):
            for k, f in enumerate(frame):
                f.x.array[:] = arrays[f"triad_{c}_{k}"]
        self.increments = [(arrays[f"increment_{i}_u"], arrays[f"increment_{i}_theta"], dt)
                           for i, dt in enumerate(increment_steps)]

    def predict(self, dt: float, extrapolate: bool = True):
        """Start a step of ``dt`` from the last state carried on at the recent rates.

        The rate of the last step, ``q₁ = Δ_n/Δt_n`` (Δ = Δu, or θ), belongs to the
        middle of that step, the one before, ``q₀``, to the middle of its own: the
        rate taken linear in time through the two and integrated over the new step
        gives ``Δ = Δt (q₁ + (q₁ − q₀) s/h)``, with ``h`` the time between the two
        middles and ``s`` from the last middle to the new one; with one step known
        ``Δ = Δt q₁``. ``θ`` is a rotation increment whose components belong to
        the triad of its step, which the update has turned since by ``θ`` itself:
        second order in it, as is a predictor's error. Without a step known, or
        not ``extrapolate``, the step starts from the last state (``θ = 0``)."""
        self.restore()
        self.predicted_step = 0.0
        self.prediction = None
        if not self.increments or not extrapolate:
            return
        u_n = self.w.x.array[self.u_dofs].copy()
        qu, qt = self._extrapolated_rates(dt)
        if self.keep_predictions:
            # the error control (time.tolerance) measures against polynomial
            # extrapolations, whose error constants its estimate assumes (§6.9)
            du, theta, dt_1 = self.increments[0]
            polynomial = self._extrapolated_rates(dt, turn=False)
            self.prediction = {1: (u_n + dt * du / dt_1, dt * theta / dt_1),
                               len(self.increments): (u_n + dt * polynomial[0], dt * qt)}
        self.w.x.array[self.u_dofs] = u_n + dt * qu
        self.w.x.array[self.theta_dofs] = dt * qt
        local = float(np.abs(qu).max()) * dt if len(qu) else 0.0
        self.predicted_step = self.comm.allreduce(local, op=MPI.MAX)

    def _extrapolated_rates(self, dt: float, turn: bool = True):
        """The rates ``(q_u, q_θ)`` of ``predict`` for a step of ``dt``.  With ``turn``,
        on a body of one colour, each node's displacement increments are first turned
        by its own rotation increment (the last step's θ, scaled to ``dt``; the one
        before turned once more): a body turning at a steady rate then moves each
        node along its circle, where a polynomial in time cuts the chord and
        stretches the body (a plate spinning 1/16 turn a step: 7.0 Newton iterations
        a step from the polynomial, 4.3 from the turned increments)."""
        du, theta, dt_1 = self.increments[0]
        rot = None
        if turn and self.n_colours == 1:
            idx = self.triad.node_maps[0]
            a1, a2, _ = (f.x.array.reshape(-1, 3) for f in self.triads[0])
            th = theta.reshape(-1, 2)
            rot = th[:, 0:1] * a1[idx] + th[:, 1:2] * a2[idx]

        def turned(v, scale):
            """``v`` with each node's vector turned by ``scale`` × its rotation increment."""
            if rot is None:
                return v
            v3 = v.reshape(-1, 3).copy()
            v3[idx] = triad_rotate(v3[idx], scale * rot)
            return v3.ravel()
        du = turned(du, dt / dt_1)
        qu, qt = du / dt_1, theta / dt_1
        if len(self.increments) == 2:
            du_0, theta_0, dt_0 = self.increments[1]
            du_0 = turned(turned(du_0, 1.0), dt / dt_1)
            weight = (0.5 * (dt_1 + dt)) / (0.5 * (dt_1 + dt_0))
            qu = qu + weight * (qu - du_0 / dt_0)
            qt = qt + weight * (qt - theta_0 / dt_0)
        return qu, qt

    # --- whole-body measures ------------------------------------------------------

    def area(self, cells=None) -> float:
        """Reference area ``∫ dA₀`` of the body, or of the given local cells (global)."""
        one = fem.Constant(self.mesh, PETSc.ScalarType(1.0))
        if cells is None:
            if not hasattr(self, "_area"):  # a reference quantity: computed once
                self._area = self.assemble_scalar(self.compile(one * self.dx))
            return self._area
        n = self.mesh.topology.index_map(self.mesh.topology.dim).size_local
        cells = np.asarray(cells)[np.asarray(cells) < n].astype(np.int32)  # owned only
        tags = compat.create_meshtags(self.mesh, self.mesh.topology.dim, cells,
                                      np.ones(len(cells), dtype=np.int32))
        dx = ufl.Measure("dx", domain=self.mesh, subdomain_data=tags)
        return self.assemble_scalar(self.compile(one * dx(1)))

    def centroid(self) -> np.ndarray:
        """Area-weighted mean of the current positions, ``∫ x dA₀ / ∫ dA₀`` (global)."""
        if not hasattr(self, "_centroid_forms"):
            x = ufl.SpatialCoordinate(self.mesh) + self.kinematics().u
            self._centroid_forms = [self.compile(x[i] * self.dx) for i in range(3)]
        return np.array([self.assemble_scalar(f) for f in self._centroid_forms]) / self.area()

    def elastic_energy(self) -> float:
        """Stored energy ``Π`` of the current iterate, springs included."""
        if not hasattr(self, "_energy_form"):
            self._energy_form = self.compile(self.energy)
        return self.assemble_scalar(self._energy_form)

    def director_unit_error(self) -> float:
        """``max | |d| − 1 |`` over all nodal directors (global)."""
        return self.triad.unit_error()

    def nodal_director(self):
        """The nodal directors as one [P2]³ Function (for output)."""
        return self.triad.nodal_director()

    @property
    def displacement(self):
        """The displacement of the last converged step (the Function ``u_n``)."""
        return self.u_n

    def destroy(self):
        """Free the nodal projection's PETSc objects.  Forms and functions stay usable;
        a triad update after this rotates the triads but no longer realigns them."""
        self.triad.destroy()
