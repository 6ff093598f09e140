"""A scene turned into unknowns, state and the sum of its effects' forms.

Newton's unknowns of a step are ``w = (u, θ)``: total displacement ``u`` in [P2]³
and, at every node, the two components ``(θ¹, θ²)`` of its director's rotation
increment in the node's tangent basis ``(a₁, a₂)`` of the last converged step
(docs/model.md §4).  All of them are second-order Lagrange fields on the same
nodes, held as one blocked field ``w`` in [P2]^(3+2c) (c the number of panel
colours, below).  The forms see ``z = (u, d)`` in [P2]^(3+3c) instead: the nodal
directors ``d_I``, each its node's last director turned exactly by its θ, and
interpolated between the nodes (rftfem/model/directors.py), so that what the forms
integrate does not depend on the nodal bases and a rigid motion strains nothing.
The triads ``(a₁, a₂, dₙ)`` are kept as three [P2]³ functions, rotated node by
node after each converged step, and ``a₁`` turned about dₙ onto the convected
material axis where it has a tangent part (``update_triad``).  Hinge lines cut
the body into panels of several colours, each with its own θ, director and triad
(rftfem/model/hinges.py).

Everything else is an effect component (rftfem/model/effects): the Model builds the
ones the scene asks for, in the registry's order, and adds up their terms
(docs/model.md §5).
"""

from __future__ import annotations

import time as _time
from types import SimpleNamespace
from typing import TYPE_CHECKING, Any

import numpy as np
import ufl
from dolfinx import fem
from petsc4py import PETSc

from rftfem import compat
from rftfem.errors import SceneError
from rftfem.forms import hinge, kinematics
from rftfem.model import effects, hinges, terms
from rftfem.model.directors import DirectorMap
from rftfem.model.dirichlet import DirichletSpaces
from rftfem.model.dof_layout import block_dofs, check_node_numbering
from rftfem.model.effects.base import FluidModel
from rftfem.model.mapped_forms import MappedForm
from rftfem.model.measures import BodyMeasures
from rftfem.model.rates import scheme_velocity
from rftfem.model.step_state import StepStart
from rftfem.model.triad import Triads
from rftfem.scene.schema import unit_vector

if TYPE_CHECKING:
    from rftfem.model.effects.base import Effect


class Model(StepStart, BodyMeasures):
    """Function spaces, state, material fields and the active effects of one scene;
    what a step starts from is step_state.py's, the whole-body measures measures.py's."""

    def __init__(
        self, scene: dict, body: Any, compile_forms: bool = True, tangent: str = "mixed-point"
    ):
        self.scene, self.body, self.compile_forms = scene, body, compile_forms
        self.mesh = body.mesh
        self.comm = self.mesh.comm
        tdim = self.mesh.topology.dim
        self.mesh.topology.create_connectivity(tdim - 1, tdim)
        self.timings = {"compile": 0.0}
        #: whether the applied loads (``[[load]]`` entries, the magnetic field) act: off
        #: for the solve of a run's initial state in time (docs/model.md §6.7); the
        #: components read it when their time is set
        self.loads_on = True
        self.dx = ufl.Measure("dx", domain=self.mesh)
        self._kinematics = None

        # hinges cut the body into panels; panels that touch get different colours,
        # and each colour has its own rotation field and triad (forms/hinge.py)
        self.hinges = hinges.resolve(self, scene)
        self.colours, self.n_colours, self.colour_indicators = hinges.colouring(
            self.mesh, self.hinges
        )

        self._init_unknowns()
        self._init_directors(scene, tangent)
        self._init_materials()
        self._init_scheme(scene)
        self._init_effects(scene)

    def _init_unknowns(self) -> None:
        """The unknowns ``w`` and their dofs, and the state of the last step."""
        # unknowns: u, then one θ per colour, node by node; the state of the last step
        self.block = 3 + 2 * self.n_colours
        self.W = compat.function_space(self.mesh, "Lagrange", 2, (self.block,))
        self.Vu = compat.function_space(self.mesh, "Lagrange", 2, (3,))
        check_node_numbering(self.W, self.Vu)
        self.u_dofs = block_dofs(self, range(3))
        #: per colour, its rotation dofs of ``w`` in (θ¹, θ²) pairs, node by node
        self.theta_dofs_of = [
            block_dofs(self, (3 + 2 * c, 4 + 2 * c)) for c in range(self.n_colours)
        ]
        #: every rotation dof of ``w``, in (θ¹, θ²) pairs
        self.theta_dofs = np.concatenate(self.theta_dofs_of)
        self.w = fem.Function(self.W, name="w")
        self.u_n, self.v_n, self.a_n = (
            fem.Function(self.Vu, name=n) for n in ("u_n", "v_n", "a_n")
        )
        #: the last two accepted steps' (Δu, θ, dt), newest first: the next step's prediction
        self.increments = []
        #: the largest displacement increment of the last prediction (0: none made)
        self.predicted_step = 0.0
        #: the last predictions {past steps used: (u, θ)}, or None; made only when
        #: ``keep_predictions`` (error-controlled steps)
        self.prediction = None
        self.keep_predictions = False

    def _init_directors(self, scene: dict, tangent: str) -> None:
        """The nodal triads, the directors the forms see and the Newton iterates."""
        # the nodal triads (a1, a2, dn) of each colour and the reference director D
        self.triad = Triads(self, np.array(unit_vector(scene["shell"]["axis"])))
        self.triads, self.D = self.triad.frames, self.triad.D
        self.dn, self.material_axis = self.triads[0][2], self.triad.material_axis
        #: the unknowns as the forms see them, ``z = (u, d, ...)`` (directors.py)
        self.directors = DirectorMap(self)
        self.Z, self.z = self.directors.Z, self.directors.z

        #: the previous and the current Newton iterate and their difference, as z: the
        #: data of the mixed-integration-point tangent (docs/model.md §7.4), set by the solver
        self.newton_previous, self.newton_current, self.newton_update = (
            fem.Function(self.Z, name=n) for n in ("z_previous", "z_current", "z_update")
        )
        for f in (self.newton_previous, self.newton_current):  # unit directors: no 0/0
            self.directors.map(self.w.x.array, out=f.x.array)
        self.mixed_point = tangent == "mixed-point"
        self._newton_last = None  # the iterate of the last tangent (tangent_at_iterate)
        #: whether a solve's first mixed-point tangent carries the stress resultants of
        #: the last converged state (time steps) or those of its own start (static
        #: load steps); set by the Simulation from its scheme (docs/model.md §7.4)
        self.first_tangent_converged = False

    def _init_scheme(self, scene: dict) -> None:
        """The time scheme's coefficients and the prescribed motions' corrections."""
        #: the time scheme's coefficients of velocity and acceleration (integration/schemes.py)
        self.coef = {
            k: fem.Constant(self.mesh, PETSc.ScalarType(0.0))
            for k in ("cv", "cv_v", "cv_a", "ca", "ca_v", "ca_a", "alpha_f", "end_weight")
        }
        self.coefficients = None  # the last ones set (timeint.Coefficients)
        #: prescribed motions in a second-order scheme: corrections to the velocity and
        #: acceleration that make them the motion's own on the driven dofs (motion.py)
        self.drive = _motion_drive(scene, self.Vu)

    def _init_effects(self, scene: dict) -> None:
        """The active effects, their sum and their Dirichlet conditions."""
        # the effects, then their sum; Dirichlet values are kept per component space
        self.dirichlet = DirichletSpaces()
        self.components = [cls(self) for cls in effects.REGISTRY if cls.active(scene)]
        self._sum_terms()
        self.bcs = [bc for comp in self.components for bc in comp.bcs()]
        self.bcs += hinges.inactive_rotation_bcs(self)
        self.has_moving_bcs = any(comp.moving for comp in self.components)

    def displacement_space(self, i: int) -> fem.FunctionSpace:
        """The sub-space of ``w`` holding the displacement component ``i`` (0: x)."""
        return self.W.sub(i)

    def rotation_space(self, colour: int, i: int) -> fem.FunctionSpace:
        """The sub-space of ``w`` holding ``θ^(i+1)`` of the colour ``colour``."""
        return self.W.sub(3 + 2 * colour + i)

    def split(self, z: ufl.core.expr.Expr) -> tuple[ufl.core.expr.Expr, list[ufl.core.expr.Expr]]:
        """``(u, [d of each colour])`` of a field or test function of ``Z``."""
        u = ufl.as_vector([z[i] for i in range(3)])
        directors = [
            ufl.as_vector([z[3 + 3 * c + i] for i in range(3)]) for c in range(self.n_colours)
        ]
        return u, directors

    def get(self, name: str) -> Effect | None:
        """The active component called ``name`` (``"drag"``, ``"magnetic"``, ...) or None."""
        return next((c for c in self.components if c.name == name), None)

    @property
    def fluid(self) -> FluidModel | None:
        """The liquid's component (RFT drag or Stokes flow), or None."""
        return next((c for c in self.components if isinstance(c, FluidModel)), None)

    def __getitem__(self, name: str):
        comp = self.get(name)
        if comp is None:
            raise KeyError(f"the scene has no active effect '{name}'")
        return comp

    def loads_at_start(self) -> list[str]:
        """The key paths of the loads already on at t = 0 (``load.0``, ``magnetic.field``)."""
        return [key for comp in self.components for key in comp.loads_at_start()]

    def active_effects(self) -> list[str]:
        """The active effect names, as ``rftfem check`` lists them."""
        return effects.active_effects(self.scene)

    # --- set-up -----------------------------------------------------------

    def axis_error(self, why: str) -> SceneError:
        """The error of a ``shell.axis`` along the normal, for an effect that needs it."""
        at = ", ".join(f"{v:.6g}" for v in self.triad.axis_normal_point)
        return SceneError(
            f"shell.axis: expected a direction not along the shell normal ({why}),"
            f" found {self.scene['shell']['axis']}, along the normal at "
            f"{self.triad.axis_along_normal} node(s), the first at ({at})"
        )

    def _init_materials(self):
        """The material fields (rftfem/model/materials.py): cellwise (DG0) where every
        value is a number, so one compiled form serves every such scene; DG2 where a
        formula or profile sets it.  ``material_ranges``: each key's (min, max, mean)."""
        from rftfem.model import materials

        self.material, self.material_ranges = materials.build(self)

    def material_value(
        self, key: str, how: str = "max", value: float | str | dict[str, str] | None = None
    ) -> float:
        """A material key's largest, smallest or mean value (materials.material_value)."""
        from rftfem.model import materials

        return materials.material_value(self, key, how, value)

    # --- forms --------------------------------------------------------------

    def compile(self, ufl_form: ufl.Form) -> fem.Form:
        """A UFL form compiled for assembly (its time counted in ``timings``)."""
        t0 = _time.perf_counter()
        form = compat.form(ufl_form)
        self.timings["compile"] += _time.perf_counter() - t0
        return form

    def assemble_scalar(self, form: fem.Form) -> float:
        """A compiled scalar form at the current iterate, summed over all processes."""
        self.directors.sync()
        return self.comm.allreduce(fem.assemble_scalar(form))

    def kinematics(self) -> SimpleNamespace:
        """UFL kinematics of the current iterate (built once): ``u``, the director
        ``d``, ``g₁, g₂``, ``F_s``, the reference ``G₁, G₂``, and the test functions
        ``w_test`` (of all of ``z``) and ``du`` (its displacement part).  Forms take
        derivatives with respect to ``model.z``."""
        if self._kinematics is None:
            w_test = ufl.TestFunction(self.Z)
            self._kinematics = self.kinematics_of(self.z)
            self._kinematics.w_test, self._kinematics.du = w_test, self.split(w_test)[0]
        return self._kinematics

    def kinematics_of(self, z: ufl.core.expr.Expr) -> SimpleNamespace:
        """The kinematics of ``kinematics()`` for any function ``z`` of ``Z``, without
        test functions."""
        u, nodal = self.split(z)
        G1, G2 = kinematics.covariant_basis(self.mesh)
        directors = [kinematics.interpolated_director(d) for d in nodal]
        d = (
            hinge.panel_director(self.colour_indicators, directors)
            if self.n_colours > 1
            else directors[0]
        )
        g1, g2 = kinematics.surface_basis(u, G1, G2)
        return SimpleNamespace(
            u=u, d=d, g1=g1, g2=g2, G1=G1, G2=G2, F_s=kinematics.surface_deformation_gradient(u)
        )

    def velocity(self, u: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
        """``v_{n+1}`` (or its scheme's blend) as a function of the unknown displacement."""
        c = self.coef
        v = scheme_velocity(u - self.u_n, self.v_n, self.a_n, c["cv"], c["cv_v"], c["cv_a"])
        return v + self.drive[0] if self.drive else v

    def acceleration(self, u: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
        """``a_{n+1−α_m}`` as a function of the unknown displacement."""
        c = self.coef
        a = c["ca"] * (u - self.u_n) + c["ca_v"] * self.v_n + c["ca_a"] * self.a_n
        return a + self.drive[1] if self.drive else a

    def _sum_terms(self):
        """Stored energy, forces, inertia and the step's Jacobian (model/terms.py)."""
        terms.sum_terms(self)

    def mapped(self, ufl_form: ufl.Form) -> MappedForm:
        """A rank-1 form on ``z`` compiled and assembled as one on ``w``."""
        return MappedForm(self.compile(ufl_form), self.directors)

    def add_nodal_forces(self, F: np.ndarray) -> None:
        """Add the components' nodal forces to the local array of an assembled ``F``."""
        for comp in self.components:
            comp.add_nodal_forces(F)

    # --- per-step updates ---------------------------------------------------

    def set_coefficients(self, c: Any) -> None:
        self.coefficients = c
        for key in self.coef:
            self.coef[key].value = getattr(c, key)

    def set_time(self, t: float, scheme: Any = None) -> None:
        """Loads and motions at ``t``; with a second-order ``scheme``, the driven dofs'
        exact rates of the step ending at ``t`` (after ``set_coefficients``)."""
        for comp in self.components:
            comp.set_time(t)
        if self.drive:
            self["prescribed-motion"].drive_step(
                t if scheme is not None and scheme.has_inertia else None, self.coefficients
            )

    def drive_state(self, t: float, scheme: Any) -> None:
        """With a second-order scheme (None: the model's own), the driven dofs' stored
        rates at ``t`` (motion.py)."""
        if self.drive and (scheme is None or scheme.has_inertia):
            self["prescribed-motion"].drive_state(t)

    def restore(self) -> None:
        """Reset the iterate to the last converged state (θ = 0)."""
        self.w.x.array[self.u_dofs] = self.u_n.x.array
        self.w.x.array[self.theta_dofs] = 0.0

    def update_triad(self) -> None:
        """Rotate the nodal triads by the converged θ and realign them (triad.py); θ = 0."""
        self.triad.update(self.w.x.array, self.theta_dofs_of)
        self.w.x.array[self.theta_dofs] = 0.0

    def accept(self, scheme: Any, dt: float, t: float | None = None) -> None:
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

    @property
    def displacement(self) -> fem.Function:
        """The displacement of the last converged step (the Function ``u_n``)."""
        return self.u_n

    def destroy(self) -> None:
        """Free the nodal projection's PETSc objects.  Forms and functions stay usable;
        a triad update after this rotates the triads but no longer realigns them."""
        self.triad.destroy()
        for form in (self.forces_form, self.inertia_form, self.end_form, self.jacobian_form):
            if form is not None:
                form.destroy()


def _motion_drive(scene: dict, Vu: fem.FunctionSpace) -> tuple[fem.Function, fem.Function] | None:
    """The driven dofs' velocity and acceleration corrections ``(v_drive, a_drive)``
    where prescribed motions meet inertia, else None."""
    if effects.Motions.active(scene) and effects.Inertia.active(scene):
        return (
            fem.Function(Vu, name="v_drive"),
            fem.Function(Vu, name="a_drive"),
        )
    return None
