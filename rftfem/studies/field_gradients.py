"""Exact gradients of a static scene's objective with respect to material fields:
one value per cell, and per point of a profile's grid (docs/model.md §7.6).

With λ the adjoint of the converged last step (rftfem/studies/sensitivity.py,
``Kᵀλ = ∂J/∂w``), the derivative by the field ``f`` (a Function of the Model:
the thickness, a modulus, the density; DG0 or DG2, rftfem/model/materials.py) is
the vector over the field's dofs

    dJ/df = ∂J/∂f − ∂(λ·R)/∂f,

one assembly of ``ufl.derivative(ufl.action(R, λ), f, v)`` with ``v`` the field's
test function.  Its parts:

- per cell: the derivative by a change δ of the field uniform on the cell, the sum
  of the cell's dofs' entries (the dofs of a DG field belong to one cell);
- per profile point: the field's values at its nodes are ``Wp`` (multilinear
  weights of the grid values ``p``, rftfem/scene/profiles.py), so ``dJ/dp = Wᵀ dJ/df``
  over the nodes the profile sets (not those a later part overrides);
- the magnetization of a part magnetized by a number (cellwise ``M = m q₀``): per
  cell ``dJ/dm = q₀ · dJ/dM``.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from rftfem.errors import SceneError
from rftfem.model.materials import FORM_NAMES, owners

if TYPE_CHECKING:
    import ufl
    from petsc4py import PETSc

    from rftfem.studies.sensitivity import _Adjoint

#: the keys whose field can be differentiated (and varied by ``--vary-field``)
FIELD_KEYS = ("shell.thickness", "shell.E", "shell.nu", "shell.density")
FIELDS_SUPPORTED = ", ".join(FIELD_KEYS) + " or magnetic.parts.N.magnetization"

__all__ = ["FieldGradient", "field_gradients", "check_field_keys", "FIELD_KEYS"]


@dataclass
class FieldGradient:
    """A field key's gradient: per cell (a DG0 Function, owned and ghost cells), the
    nodal vector, and per profile point ``(points, values)`` if a profile sets it."""

    key: str
    cells: object
    nodal: np.ndarray
    profile: tuple | None = None
    profile_file: str | None = None
    extra: dict = field(default_factory=dict)
    #: a nodal (P1 vector) field instead of ``cells`` (a magnetization profile's)
    nodal_field: object = None


def check_field_keys(scene: dict, keys: list[str]) -> None:
    """Each key names a differentiable field of this scene (a one-line SceneError)."""
    for key in keys:
        m = re.fullmatch(r"magnetic\.parts\.(\d+)\.magnetization", key)
        if m:
            parts = (scene.get("magnetic") or {}).get("parts") or []
            if int(m[1]) >= len(parts):
                raise SceneError(
                    f"field gradient '{key}': the scene has {len(parts)} [[magnetic.parts]]"
                )
            part = parts[int(m[1])]
            if part.get("profile") is None and (
                not isinstance(part["magnetization"], (int, float))
                or any(isinstance(v, str) for v in part["direction"])
            ):
                raise SceneError(
                    f"field gradient '{key}': the part is magnetized by a "
                    "formula; a gradient is by the values of a number (per "
                    "cell) or of a profile (per grid point)"
                )
            if part.get("profile") is None and any(
                p.get("profile") is not None
                or not isinstance(p["magnetization"], (int, float))
                or any(isinstance(v, str) for v in p["direction"])
                for p in parts
            ):
                raise SceneError(
                    f"field gradient '{key}': another part is magnetized by a "
                    "formula or profile; a cellwise gradient needs every part "
                    "magnetized by numbers"
                )
            continue
        if key not in FIELD_KEYS:
            raise SceneError(f"field gradient '{key}': expected one of {FIELDS_SUPPORTED}")
        if scene["shell"]["material"] == "orthotropic" and key in ("shell.E", "shell.nu"):
            raise SceneError(
                f"field gradient '{key}': the shell is orthotropic (E1, E2, "
                "G12, nu12); its thickness and density are fields to vary"
            )


def field_gradients(
    adj: _Adjoint, lam: PETSc.Vec, J_form: ufl.Form | None, keys: list[str]
) -> list[FieldGradient]:
    """The gradients of the objective (``J_form`` its UFL form or None; ``lam`` the
    adjoint vector) by each field key, for an ``_Adjoint`` at the converged state."""
    import ufl
    from dolfinx import fem

    m = adj.model
    # λ·R_w = (P λ)·R_z: the multiplier as a direction of the forms' unknowns z
    m.directors.sync(derivatives=True)
    lam_fn = fem.Function(m.Z, name="adjoint")
    with lam.localForm() as local:
        lam_fn.x.array[:] = m.directors.apply(local.array_r)
    work = ufl.action(m.forces_ufl, lam_fn)  # λ·R as a 0-form
    out = []
    for key in keys:
        mag = re.fullmatch(r"magnetic\.parts\.(\d+)\.magnetization", key)
        profiled = mag and int(mag[1]) in getattr(m["magnetic"], "profile_fields", {})
        if profiled:
            f = m["magnetic"].profile_fields[int(mag[1])][0]
        else:
            f = m["magnetic"].remanence if mag else m.material[FORM_NAMES[key.split(".")[-1]]]
        v = ufl.TestFunction(f.function_space)
        form = -ufl.derivative(work, f, v)
        if J_form is not None and f in J_form.coefficients():
            form = form + ufl.derivative(J_form, f, v)
        nodal = _assemble(m, form, f.function_space)
        if profiled:
            out.append(_magnetization_profile_gradient(m, key, int(mag[1]), f, nodal))
        elif mag:
            out.append(_magnetization_gradient(m, key, int(mag[1]), f, nodal))
        else:
            out.append(_material_gradient(m, key, f, nodal))
    return out


def _assemble(m, form, V) -> np.ndarray:
    """A 1-form on ``V``, ghosts summed into owners and sent back: the local array."""
    from petsc4py import PETSc

    from rftfem import compat

    compiled = m.compile(form)
    b = compat.create_vector(compiled, V)
    with b.localForm() as local:
        local.set(0.0)
    compat.assemble_vector(b, compiled)
    b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    b.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
    with b.localForm() as local:
        out = local.array_r.copy()
    b.destroy()
    return out


def _per_cell(m, V, nodal, bs: int = 1) -> object:
    """The DG0 Function of each cell's sum of its dofs' entries."""
    from dolfinx import fem

    from rftfem import compat

    V0 = compat.function_space(m.mesh, "DG", 0)
    cells = fem.Function(V0, name="gradient")
    dofs = compat.cell_dofs(V)
    per = nodal.reshape(-1, bs).sum(axis=1) if bs > 1 else nodal
    cells.x.array[compat.cell_dofs(V0)[:, 0]] = per[dofs].sum(axis=1)
    return cells


def _material_gradient(m, key, f, nodal) -> FieldGradient:
    from mpi4py import MPI

    from rftfem import compat
    from rftfem.scene.fields import is_field, profile_file
    from rftfem.scene.profiles import profile_weights, read_profile

    V = f.function_space
    grad = FieldGradient(key, _per_cell(m, V, nodal), nodal)
    totals = _totals(m, f)
    grad.extra = {name: value for name, (value, _) in totals.items()}
    sources = owners(m, key.split(".")[-1])
    profiles = [
        i for i, (_, value, _) in enumerate(sources) if is_field(value) and isinstance(value, dict)
    ]
    if not profiles:
        return grad
    # the source that sets each node: the last one that covers it
    dofs = compat.cell_dofs(V)
    owner = np.full(len(nodal), -1)
    for i, (_, _, cells) in enumerate(sources):
        owner[np.unique(dofs if cells is None else dofs[cells])] = i
    i = profiles[-1]
    where, value, _ = sources[i]
    points, _ = read_profile(
        profile_file(m.scene, value["profile"]), f"{where}.profile", columns=1, names="value"
    )
    n_owned = V.dofmap.index_map.size_local
    nodes = np.nonzero(owner[:n_owned] == i)[0]
    rows, weights = profile_weights(points, V.tabulate_dof_coordinates()[nodes], f"{where}.profile")

    def on_profile(vector):
        local = np.zeros(len(points))
        np.add.at(local, rows.ravel(), (weights * vector[nodes, None]).ravel())
        return m.comm.allreduce(local, op=MPI.SUM)

    grad.profile = (points, on_profile(nodal))
    grad.profile_file = value["profile"]
    grad.extra.update({f"d_{name}": on_profile(d) for name, (_, d) in totals.items()})
    return grad


def _totals(m, f) -> dict:
    """The body's mass ∫ρt dA and volume ∫t dA, each with its nodal derivative by the
    field ``f`` (zero if they do not depend on it)."""
    import ufl

    rho, t = m.material["rho"], m.material["t"]
    v = ufl.TestFunction(f.function_space)
    out = {}
    for name, integrand in (("mass", rho * t), ("volume", t)):
        form = integrand * m.dx
        value = m.assemble_scalar(m.compile(form))
        d = (
            _assemble(m, ufl.derivative(form, f, v), f.function_space)
            if f in (rho, t)
            else np.zeros(len(f.x.array))
        )
        out[name] = (value, d)
    return out


def _magnetization_profile_gradient(m, key, index, Mp, nodal) -> FieldGradient:
    """A part magnetized by a profile: its vector values at the P1 nodes are ``W p``
    (p the grid's vectors), so dJ/dp = Wᵀ dJ/dMp, (points, 3); the nodal gradient
    (a P1 vector field) is what the XDMF file shows."""
    from mpi4py import MPI

    from rftfem import compat
    from rftfem.scene.profiles import profile_weights

    _, points = m["magnetic"].profile_fields[index]
    V = Mp.function_space
    n_owned = V.dofmap.index_map.size_local
    nodes = np.unique(compat.cell_dofs(V)[m["magnetic"].part_cells[index]])
    nodes = nodes[nodes < n_owned]
    rows, weights = profile_weights(
        points, V.tabulate_dof_coordinates()[nodes], f"{key.rsplit('.', 1)[0]}.profile"
    )
    per_node = nodal.reshape(-1, 3)[nodes]
    local = np.zeros((len(points), 3))
    for k in range(rows.shape[1]):
        np.add.at(local, rows[:, k], weights[:, k, None] * per_node)
    grad = FieldGradient(key, None, nodal)
    grad.nodal_field = _nodal_field(Mp, nodal)
    grad.profile = (points, m.comm.allreduce(local, op=MPI.SUM))
    grad.profile_file = m.scene["magnetic"]["parts"][index]["profile"]
    return grad


def _nodal_field(f, nodal):
    from dolfinx import fem

    g = fem.Function(f.function_space, name="gradient")
    g.x.array[:] = nodal
    return g


def _magnetization_gradient(m, key, index, M, nodal) -> FieldGradient:
    """dJ/dm per cell of the part: q₀ · dJ/dM (M = m q₀ cellwise, DG0 vector)."""
    from dolfinx import fem

    from rftfem import compat

    V0 = compat.function_space(m.mesh, "DG", 0)
    cells = fem.Function(V0, name="gradient")
    mag = m["magnetic"]
    dofs = compat.cell_dofs(M.function_space)[:, 0]
    part = dofs[mag.part_cells[index]]
    Mc = M.x.array.reshape(-1, 3)[part]
    q0 = Mc / np.linalg.norm(Mc, axis=1)[:, None]
    g = nodal.reshape(-1, 3)[part]
    cells.x.array[compat.cell_dofs(V0)[mag.part_cells[index], 0]] = np.einsum("ij,ij->i", g, q0)
    return FieldGradient(key, cells, nodal)
