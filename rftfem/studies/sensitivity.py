"""Exact sensitivities of static scenes: the adjoint of the converged residual
(docs/model.md §7.6).

A static run ends with a converged Newton solve of its last load step in the
unknowns ``w = (u, θ)``, θ the rotation increment about the nodal triads ``T`` of
the step before (docs/model.md §4).  With those triads held fixed, the final
state solves

    R(w; p) = 0,            R = F(w) of docs/model.md §5.1 (static: no α_f, no inertia),

and an objective ``J(w; p)`` evaluated there has, with ``K = ∂R/∂w``,

    Kᵀ λ = ∂J/∂w           (λ = 0 on the Dirichlet dofs, whose values do not depend on p),
    dJ/dp = ∂J/∂p − λᵀ ∂R/∂p.

``K`` is the exact tangent: the model's compiled Jacobian assembled with the
mixed-point defects set to zero (``StepSolver.assemble_tangent``, the tangent a
static load step starts from, docs/model.md §7.4), so no extra Jacobian form is
compiled; it is not symmetric with magnetic couples or a follower pressure, and
the transposed system is solved by a fresh LU (MUMPS where PETSc has it).  The
parameter derivatives ``∂R/∂p`` and ``∂J/∂p`` are ``ufl.derivative`` of the
model's own residual and objective forms:

- material keys (``shell.E``, ``shell.nu``, ``shell.thickness``, ``shell.density``
  and the same of ``shell.parts.N``) along the cellwise field they set, in the
  direction of the cells whose value the key decides (a part that inherits a
  value from ``[shell]`` moves with ``shell.E``), found by loading the scene with
  the key at two values and building the fields as the Model does;
- load values (``load.N.value.I``, ``load.N.value`` of a pressure) and the
  rotating field's ``magnetic.field.strength``: the Constants of the forms at
  ``time.end`` are linear in them; their direction is what the components'
  ``set_time`` makes of a unit value (minus that of zero), and the Constant is
  differentiated through a zero DG0 shift ``c + s δc`` (UFL 2022 cannot
  differentiate by a Constant); a point force's nodal vector the same way through
  its own ``add_nodal_forces``;
- ``magnetic.parts.N.magnetization`` (a plain number > 0) along the cellwise
  remanence ``M = m q₀`` in the direction ``q₀`` on the part's cells.

Objectives: a probe's displacement component at the end (a point evaluation,
``∂J/∂w`` the shape functions of its cell at the point on the u dofs), and the
body's ``centroid_x|y|z`` and ``elastic_energy`` at the end (``ufl.derivative`` of
their forms).  They are evaluated on the converged state of the last step,
before its triad update: a probe is the last row of probes.csv; a body integral
may differ from the last row of body.csv, which is taken after the update, by the
update's interpolation error (docs/model.md §4.3).

What "exact" means.  The derivative is exact for the problem of the last step,
its starting triads held.  The triads themselves came from the earlier load steps
and depend on p through them; the equilibrium of the continuous shell does not
depend on the load path, and the discrete one only through the interpolation of
the triad update (§4.3), so the term left out, ``∂J/∂T · dT/dp``, is of the size
of the path dependence, second order in the cell size.  A run of one load step
(``time.dt = time.end``) starts from the reference triads and has no such term.

Overdamped runs (backward Euler) would need an adjoint backwards over every stored
state and the triad updates' linearisation: not here (docs/model.md).

API: ``gradient(sim, last, keys, objective)`` on a Simulation that has run
with ``last = keep_last_step(sim.model)``; ``check_request(scene, keys, objective)``;
``supports(keys, objective[, scene])``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from rftfem.studies.sensitivity_adjoint import _Adjoint

# the request (keys and objective) is checked there; re-exported for callers
from rftfem.studies.sensitivity_request import (  # noqa: F401
    KEYS_SUPPORTED,
    MATERIAL_FIELDS,
    OBJECTIVES_SUPPORTED,
    PROBE_VALUES,
    Key,
    Objective,
    check_request,
    combined_objective,
    parse_key,
    supports,
)

if TYPE_CHECKING:
    from collections.abc import Callable, Sequence

    from rftfem.integration.simulation import Simulation
    from rftfem.model.shell_model import Model
    from rftfem.studies.field_gradients import FieldGradient

# --- the state the last step converged to -------------------------------------------


def keep_last_step(model: Model) -> dict:
    """Make ``model`` keep, at every triad update, the converged iterate and the triads
    it is measured in (the update then turns them); returns the dict that holds the
    last ones (``w``, ``triads``)."""
    last = {}
    update = model.update_triad

    def update_triad():
        last["w"] = model.w.x.array.copy()
        last["triads"] = [[f.x.array.copy() for f in frame] for frame in model.triads]
        update()

    model.update_triad = update_triad
    return last


def _restore(model, last: dict) -> None:
    model.w.x.array[:] = last["w"]
    for frame, arrays in zip(model.triads, last["triads"]):
        for f, a in zip(frame, arrays):
            f.x.array[:] = a


def gradient(
    sim: Simulation,
    last: dict,
    keys: list[Key],
    objective: Objective
    | tuple[Sequence[Objective], Callable[[list[float]], tuple[float, Sequence[float]]]],
    fields: Sequence[str] = (),
) -> tuple[float, list[float]] | tuple[float, list[float], list[FieldGradient]]:
    """``(J, [dJ/dkey])`` at the state ``last`` that the run's last step converged to
    (``keep_last_step``), for a finished static Simulation whose solver and model are
    still alive (before ``sim.close()``).  With ``fields`` (field keys, e.g.
    ``shell.thickness``): ``(J, [dJ/dkey], [FieldGradient])``
    (rftfem/studies/field_gradients.py).  ``objective`` may be ``(objectives,
    combine)``: J = f(J₁, J₂, ...) with ``combine([J_i]) -> (J, [∂f/∂J_i])``, whose
    ∂J/∂w is Σ ∂f/∂J_i ∂J_i/∂w (one adjoint solve)."""
    m = sim.model
    _restore(m, last)
    m.set_time(sim.scene["time"]["end"])
    adj = _Adjoint(sim)
    if isinstance(objective, tuple):
        J, dJdw, J_form = combined_objective(adj, *objective)
    else:
        J, dJdw, J_form = adj.objective(objective)
    if not keys and not fields:
        dJdw.destroy()
        return float(J), []
    lam = adj.multiplier(dJdw)
    out = []
    for key in keys:
        pairs, nodal = adj.directions(key)
        dRdp_form = adj.derivative(m.forces_ufl, pairs)
        dRdp = adj.assemble(dRdp_form) if dRdp_form is not None else adj.vec()
        if dRdp_form is None:
            with dRdp.localForm() as local:
                local.set(0.0)
        if nodal is not None:
            adj.add_local(dRdp, nodal)
        dJdp = 0.0
        if J_form is not None:
            partial = adj.derivative(J_form, pairs)
            if partial is not None:
                dJdp = m.assemble_scalar(m.compile(partial))
        out.append(float(dJdp - lam.dot(dRdp)))
        dRdp.destroy()
    by_field = []
    if fields:
        from rftfem.studies.field_gradients import field_gradients

        by_field = field_gradients(adj, lam, J_form, list(fields))
    for v in (dJdw, lam):
        v.destroy()
    return (float(J), out, by_field) if fields else (float(J), out)


__all__ = [
    "gradient",
    "keep_last_step",
    "check_request",
    "supports",
    "parse_key",
    "KEYS_SUPPORTED",
    "OBJECTIVES_SUPPORTED",
]
