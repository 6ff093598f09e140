"""The model's sum of terms: what every active effect contributes, added into the
stored energy, the forces, the inertia and the step's Jacobian, and compiled on the
forms' unknowns ``z`` for assembly into ``w``'s vectors and matrices (directors.py).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import ufl

from rftfem.model.mapped_forms import MappedForm, step_residual_z

if TYPE_CHECKING:
    from rftfem.model.shell_model import Model


def sum_terms(model: Model) -> None:
    """Set ``model``'s stored energy, forces ``F(w)`` (every non-inertial effect, and
    per component in ``effects``), inertia, end forces, the step's Jacobian
    ``∂/∂w [(1 − α_f) F + inertia]`` with the mixed-point correction (docs/model.md §5,
    §6, §7.4), and their compiled forms when the model compiles."""
    w_test = model.kinematics().w_test
    energies = [c.energy() for c in model.components]
    model.energy = sum((e for e in energies if e is not None), 0)
    #: virtual work of every non-inertial effect, by component name
    model.effects = {}
    for c, energy in zip(model.components, energies):
        terms = [ufl.derivative(energy, model.z, w_test)] if energy is not None else []
        terms += [work for work in [c.forces()] if work is not None]
        if terms:
            model.effects[c.name] = sum(terms[1:], terms[0])
    inertia = [c.inertia() for c in model.components if c.inertia() is not None]
    model.inertia = sum(inertia[1:], inertia[0]) if inertia else None
    ends = [c.end_forces() for c in model.components if c.end_forces() is not None]
    #: forces taken in full at the step's end (contact), or None
    model.end_forces = sum(ends[1:], ends[0]) if ends else None
    terms = list(model.effects.values())
    model.forces_ufl = sum(terms[1:], terms[0])
    residual = (1 - model.coef["alpha_f"]) * model.forces_ufl + (model.inertia or 0)
    if model.end_forces is not None:
        residual += model.coef["end_weight"] * model.end_forces
    trial = ufl.TrialFunction(model.Z)
    model.jacobian_ufl = ufl.derivative(residual, model.z, trial)
    corrections = [c.tangent_correction() for c in model.components] if model.mixed_point else []
    #: the corrections' gradient: the mixed-point tangent in w is its Hessian in z
    #: mapped by P plus this gradient on the directors' curvature (directors.py G)
    gradients = [ufl.derivative(corr, model.z, w_test) for corr in corrections if corr is not None]
    for gradient in gradients:
        model.jacobian_ufl += (1 - model.coef["alpha_f"]) * ufl.derivative(gradient, model.z, trial)
    model.correction_ufl = sum(gradients[1:], gradients[0]) if gradients else None
    model.correction_form = None
    model.forces_form = model.inertia_form = model.jacobian_form = model.end_form = None
    if model.compile_forms:
        # compiled on z, assembled into w's vectors and matrices (directors.py)
        model.forces_form = model.mapped(model.forces_ufl)
        if model.inertia is not None:
            model.inertia_form = model.mapped(model.inertia)
        if model.end_forces is not None:
            model.end_form = model.mapped(model.end_forces)
        model.jacobian_form = MappedForm(
            model.compile(model.jacobian_ufl),
            model.directors,
            residual=lambda: step_residual_z(model),
        )
        if model.correction_ufl is not None:
            model.correction_form = model.compile(model.correction_ufl)
