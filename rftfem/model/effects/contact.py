"""Contact with planes and Coulomb friction, the scene's ``[[contact]]`` (docs/contact.md).

Each entry is a plane the shell's lower face (the mid-surface less half the
thickness along the director) may not cross: a barrier pressure pushes it back
within a documented depth, and friction resists its slip.  Both are one UFL
work of the current iterate (``forms.contact``), so the Newton tangent is
``ufl.derivative`` of it, the friction's dependence on the pressure included.

The slip velocity is the lower face's tangential displacement over the step
divided by the step, measured from the state the step starts from.  That state
is copied when the step's time is set, so after the step is accepted the
body.csv values (the plane's force, the friction's power) are still those of
the step that ended.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import ufl

from rftfem.errors import SceneError
from rftfem.forms import contact as forms
from rftfem.forms.hinge import panel_director
from rftfem.forms.kinematics import area_ratio, unit
from rftfem.model.effects.base import Effect
from rftfem.model.effects.contact_keys import SCHEMA, triple
from rftfem.model.effects.contact_start import (  # noqa: F401 (START_DEPTH, as before)
    START_DEPTH,
    check_start,
    reference_pressure,
    time_scale,
)
from rftfem.model.effects.contact_updates import UpdateLimits
from rftfem.scene.schema import fmt

if TYPE_CHECKING:
    from rftfem.model.body_parts import BodyPart
    from rftfem.model.shell_model import Model

#: the barrier's reach δ as a share of the thinnest shell thickness
REACH_OF_THICKNESS = 0.1
#: the default slip velocity scale ε_v as a share of the body's size per time.end
SLIP_OF_SPEED = 1.0e-3
#: the creep a drive period (or the run) allows, as a share of the body's size, above
#: which a run warns that static friction is not modelled
CREEP_WARNING = 0.05
COLUMNS = [
    "contact_Fx",
    "contact_Fy",
    "contact_Fz",
    "contact_area",
    "contact_energy",
    "friction_power",
]


@dataclass
class Plane:
    """A contact plane as the run uses it: the scene's values with the defaults made
    from the body (the reach from the thickness, the slip velocity from the size and
    the drive's period, the stiffness from the body's weight or load, set after the
    forms are made)."""

    normal: np.ndarray
    point: np.ndarray
    reach: float
    stiffness: float | None
    slip_velocity: float
    #: whether it has static friction
    rubs: bool


class Contact(UpdateLimits, Effect):
    name = "contact"
    keys = {"contact": SCHEMA}
    columns = COLUMNS

    @classmethod
    def active(cls, scene: dict) -> bool:
        return bool(scene.get("contact"))

    @classmethod
    def check(cls, scene: dict) -> None:
        from rftfem.scene.time_rules import resolved_scheme

        for i, plane in enumerate(scene.get("contact") or []):
            if plane["static_friction"] is None:
                plane["static_friction"] = plane["friction"]
            kinetic, static = triple(plane["friction"]), triple(plane["static_friction"])
            for j, (k, s) in enumerate(zip(kinetic, static)):
                if s < k:
                    raise SceneError(
                        f"contact.{i}.static_friction: expected at least "
                        f"contact.{i}.friction ({fmt(plane['friction'])}), found "
                        f"{fmt(plane['static_friction'])}"
                        + (
                            f" (entry {j})"
                            if isinstance(plane["friction"], list)
                            or isinstance(plane["static_friction"], list)
                            else ""
                        )
                    )
        if scene.get("contact") and scene.get("time") and resolved_scheme(scene) == "arc-length":
            raise SceneError(
                'contact: not with time.scheme = "arc-length" (friction depends '
                "on the path a body takes, not on a load factor); use "
                '"static" load steps or a scheme in time'
            )

    def __init__(self, model: Model):
        from dolfinx import fem
        from petsc4py import PETSc

        super().__init__(model)
        m = self.model
        self.entries = list(self.scene["contact"])
        #: the state the step starts from: the displacement and each colour's director
        self.u_start = fem.Function(m.Vu, name="u_start")
        self.dn_start = [fem.Function(m.Vu, name=f"dn_start_{c}") for c in range(m.n_colours)]
        self.inv_dt = fem.Constant(m.mesh, PETSc.ScalarType(0.0))
        #: 1 in a step of a scheme with inertia (the barrier's pressure over the step,
        #: forms.step_pressure), 0 in static and first-order steps (its end value)
        self.in_time = fem.Constant(m.mesh, PETSc.ScalarType(0.0))
        #: per plane, κ as a Constant: 0 while the model's loads are off (the initial
        #: state of a run in time is found without them, docs/contact.md §1)
        self.stiffnesses = []
        self.dx = m.dx(metadata={"quadrature_degree": 4})
        #: the body's diagonal (reference)
        self.size = m.size()
        thinnest, span = m.material_value("thickness", "min"), time_scale(self.scene)
        self.planes = [self._resolved(entry, thinnest, span) for entry in self.entries]
        faces = self._faces()
        terms = [
            self._on_body(entry, self._plane_terms(entry, plane, faces))
            for entry, plane in zip(self.entries, self.planes)
        ]
        self._work = sum((t["work"] for t in terms[1:]), terms[0]["work"])
        self._outputs = {
            name: sum((t[name] for t in terms[1:]), terms[0][name])
            for name in ("force", "area", "energy", "power")
        }
        for plane, t in zip(self.planes, terms):
            if plane.stiffness is None:
                reference = reference_pressure(
                    m, self.dx, self.size, plane.normal, t["area"], t["chi"]
                )
                plane.stiffness = reference / (forms.SLOPE_ON_PLANE * plane.reach)
        for kappa, plane in zip(self.stiffnesses, self.planes):
            kappa.value = plane.stiffness
        self._compiled = None
        self._nodes = None
        #: per body (several bodies): the compiled forms of the planes' force on it
        self._on_part: dict[str, list] = {}
        check_start(m, self.entries, self.planes)

    def _resolved(self, entry: dict, thinnest: float, span: float) -> Plane:
        """A ``[[contact]]`` entry with the defaults made from the body: the reach from
        the thinnest thickness, the slip velocity from the size and the drive's time."""
        normal = np.asarray(entry["normal"], dtype=float)
        normal /= np.linalg.norm(normal)
        return Plane(
            normal,
            np.asarray(entry["point"], float),
            entry["distance"] or REACH_OF_THICKNESS * thinnest,
            entry["stiffness"],
            entry["slip_velocity"] or SLIP_OF_SPEED * self.size / span,
            max(triple(entry["static_friction"])) > 0.0,
        )

    def _faces(self):
        """The lower face now and at the step's start (its director held), and its
        variation: ``(face, face_start, face_virtual)``."""
        m = self.model
        k = m.kinematics()
        X = ufl.SpatialCoordinate(m.mesh)
        d_start = [unit(dn) for dn in self.dn_start]
        d0 = panel_director(m.colour_indicators, d_start) if m.n_colours > 1 else d_start[0]
        face = forms.lower_face(X + k.u, k.d, m.material["t"])
        face_start = forms.lower_face(X + self.u_start, d0, m.material["t"])
        return face, face_start, ufl.derivative(face, m.z, k.w_test)

    def _plane_terms(self, entry: dict, plane: Plane, faces) -> dict:
        """One plane's virtual work and its output integrands (force, area within
        reach, barrier energy, friction power); its κ joins ``self.stiffnesses``."""
        from dolfinx import fem
        from petsc4py import PETSc

        m, k = self.model, self.model.kinematics()
        face, face_start, face_virtual = faces
        const = {
            name: fem.Constant(m.mesh, PETSc.ScalarType(value))
            for name, value in (
                ("reach", plane.reach),
                ("stiffness", 0.0),
                ("v_scale", plane.slip_velocity),
            )
        }
        self.stiffnesses.append(const["stiffness"])
        n = fem.Constant(m.mesh, plane.normal.astype(PETSc.ScalarType))
        p = fem.Constant(m.mesh, np.asarray(entry["point"], dtype=PETSc.ScalarType))
        g, g_start = forms.gap(face, p, n), forms.gap(face_start, p, n)
        pressure = forms.step_pressure(
            const["stiffness"], g, g_start, const["reach"], m.coef["alpha_f"], self.in_time
        )
        v_slip = forms.slip_velocity(face, face_start, n, self.inv_dt)
        traction = self._friction(entry, pressure, v_slip, const["v_scale"], n)
        J = area_ratio(k.g1, k.g2, k.G1, k.G2)
        within = ufl.conditional(ufl.lt(g, const["reach"]), J, 0 * J)
        return {
            "work": forms.contact_work(pressure, traction, n, face_virtual, self.dx),
            "force": pressure * n + traction,
            "area": within,
            "energy": const["stiffness"] * forms.barrier(g, const["reach"]),
            "power": -ufl.dot(traction, v_slip),
        }

    def _on_body(self, entry: dict, terms: dict) -> dict:
        """A plane's terms on the one body its entry names (``body``), each times that
        body's indicator ``chi`` (in the returned terms; None: on every body)."""
        from rftfem.model.body_parts import body_part, restricted

        if entry.get("body") is None:
            return {**terms, "chi": None}
        chi = body_part(self.model, entry["body"]).chi
        on = {name: value * chi for name, value in terms.items() if name != "work"}
        return {**on, "work": restricted(terms["work"], chi), "chi": chi}

    def _friction(self, plane, pressure, v_slip, v_scale, n):
        """The friction traction of one plane's entry (forms.friction_traction), its
        coefficients as constants (a new pair needs no new compiled form)."""
        from dolfinx import fem
        from petsc4py import PETSc

        m = self.model
        kinetic, static = plane["friction"], plane["static_friction"]
        if max(triple(static)) == 0.0:
            return 0 * v_slip
        anisotropic = isinstance(kinetic, list) or isinstance(static, list)
        if anisotropic:
            mu = [
                fem.Constant(m.mesh, np.asarray(triple(c), dtype=PETSc.ScalarType))
                for c in (kinetic, static)
            ]
            frame = forms.friction_frame(m.kinematics().F_s * m.material_axis, n)
            return forms.friction_traction(
                pressure,
                v_slip,
                v_scale,
                [mu[0][i] for i in range(3)],
                [mu[1][i] for i in range(3)],
                frame,
            )
        mu = [fem.Constant(m.mesh, PETSc.ScalarType(c)) for c in (kinetic, static)]
        return forms.friction_traction(pressure, v_slip, v_scale, mu[0], mu[1])

    # --- the effect ----------------------------------------------------------------

    def end_forces(self) -> ufl.Form | None:
        return self._work

    def set_time(self, t: float) -> None:
        """The step ending at ``t`` starts from the model's last converged state: keep it,
        and the step's 1/Δt (0 where no step is set, as in the initial acceleration)."""
        m = self.model
        self.u_start.x.array[:] = m.u_n.x.array
        for dn, (_, _, frame_dn) in zip(self.dn_start, m.triads):
            dn.x.array[:] = frame_dn.x.array
        dt = getattr(m.coefficients, "dt", 0.0) if m.coefficients is not None else 0.0
        self.inv_dt.value = 1.0 / dt if dt > 0.0 else 0.0
        inertia = m.coefficients is not None and m.coefficients.ca != 0.0
        self.in_time.value = 1.0 if inertia else 0.0
        for kappa, plane in zip(self.stiffnesses, self.planes):
            kappa.value = plane.stiffness if m.loads_on else 0.0

    def values(self, t: float) -> list[float]:
        m = self.model
        if self._compiled is None:
            out = self._outputs
            self._compiled = [m.compile(out["force"][i] * self.dx) for i in range(3)] + [
                m.compile(out[name] * self.dx) for name in ("area", "energy", "power")
            ]
        return [m.assemble_scalar(f) for f in self._compiled]

    def resultant_on(self, part: BodyPart) -> list[float]:
        """The planes' force on one of several bodies (body.csv's ``NAME_contact_F*``):
        ``∫ (p n + f) χ dA₀`` over its cells."""
        m = self.model
        if part.name not in self._on_part:
            force = self._outputs["force"]
            self._on_part[part.name] = [m.compile(force[i] * part.chi * self.dx) for i in range(3)]
        return [m.assemble_scalar(f) for f in self._on_part[part.name]]

    def _contact_area(self) -> float:
        """The reference area within a barrier's reach (body.csv's ``contact_area``)."""
        return dict(zip(COLUMNS, self.values(0.0)))["contact_area"]

    def warnings(self) -> list[str]:
        """A slip velocity so large that a sticking body creeps more than 5 % of its size
        in a drive period (or the run) does not model sticking: a warning."""
        size, span = self.size, time_scale(self.scene)
        return [
            f"contact.{i}.slip_velocity = {plane.slip_velocity:.3g}: a body that "
            f"sticks may creep {plane.slip_velocity * span / size:.2g} of its size "
            f"in {span:.3g} (a drive period, or time.end), so friction acts as a drag, "
            f"not as static friction; give a smaller slip_velocity (docs/contact.md §2)"
            for i, plane in enumerate(self.planes)
            if plane.slip_velocity * span > CREEP_WARNING * size
        ]

    def holds_at_rest(self) -> bool:
        """Whether friction may hold the body at the current state: a plane with friction
        presses on it (then its acceleration at rest is not the frictionless one)."""
        rubbing = [max(triple(p["static_friction"])) > 0.0 for p in self.entries]
        return any(rubbing) and self._contact_area() > 0.0
