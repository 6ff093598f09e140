"""The shell's material as fields over the body (docs/model.md §3, docs/scenes.md
"Material fields"): the moduli of its law, thickness and density.

A key whose values on [shell] and every part are plain numbers is a cellwise
(DG0) Function, as it always was, so a sweep over it compiles nothing new.  A key
given anywhere as a formula of X, Y, Z or a profile is a discontinuous field of
the displacement's degree (DG2 / DQ2), its values set at the field's nodes of
each cell from the formula, profile or number that owns the cell: continuous in
the forms wherever the formula is, with jumps only at the edges of parts.  The
values are checked at those nodes (a thickness or modulus ≤ 0 names the point).

``build(model)`` returns ``(fields, ranges)``: the fields by their form name
(``E, nu, t, rho`` or ``E1, E2, G12, nu12, G13, G23, t, rho``, and ``fibre`` of
an orthotropic shell) and the (min, max, mean) of each scene key's nodal values
over the body, for scales and messages.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from rftfem.errors import SceneError
from rftfem.scene.fields import describe, field_values, is_field
from rftfem.scene.material_keys import material_keys
from rftfem.scene.schema import fmt

if TYPE_CHECKING:
    import dolfinx.fem
    import dolfinx.mesh

    from rftfem.model.shell_model import Model

#: scene key -> the name of its field in the forms
FORM_NAMES = {
    "E": "E",
    "nu": "nu",
    "thickness": "t",
    "density": "rho",
    "E1": "E1",
    "E2": "E2",
    "G12": "G12",
    "nu12": "nu12",
    "G13": "G13",
    "G23": "G23",
}
#: the degree of a field given by formulas or profiles (that of the displacement)
FIELD_DEGREE = 2
#: what each key must be at every node, for the message: (test, words)
_ADMISSIBLE = {
    "E": (lambda v: v > 0, "> 0"),
    "thickness": (lambda v: v > 0, "> 0"),
    "density": (lambda v: v >= 0, ">= 0"),
    "nu": (lambda v: (v > -1) & (v < 0.5), "within (-1, 0.5)"),
    "E1": (lambda v: v > 0, "> 0"),
    "E2": (lambda v: v > 0, "> 0"),
    "G12": (lambda v: v > 0, "> 0"),
    "G13": (lambda v: v > 0, "> 0"),
    "G23": (lambda v: v > 0, "> 0"),
    "nu12": (lambda v: v > -1, "> -1"),
    # E1 − ν12² E2 at the nodes (_check_poisson_field)
    "ν12² < E1/E2": (lambda v: v > 0, "> 0 (ν12² < E1/E2)"),
}

__all__ = ["build", "FORM_NAMES", "owners", "field_space"]


def owners(model: Model, key: str) -> list[tuple[str, object, np.ndarray | None]]:
    """``(scene key, value, cells)`` that set ``key``: [shell] on every cell (None),
    then each part that sets it on its own cells (later parts win, as before)."""
    from rftfem.scene.selectors import cells_of

    shell = model.scene["shell"]
    out = [(f"shell.{key}", shell[key], None)]
    for i, part in enumerate(shell.get("parts", [])):
        if part.get(key) is not None:
            cells = cells_of(model.body, [part["region"]], f"shell.parts.{i}.region")
            out.append((f"shell.parts.{i}.{key}", part[key], cells))
    return out


def field_space(
    mesh: dolfinx.mesh.Mesh, varies: bool, shape: tuple[int, ...] = ()
) -> dolfinx.fem.FunctionSpace:
    """DG0 for a value that is constant on each cell, else DG of FIELD_DEGREE."""
    from rftfem import compat

    return compat.function_space(mesh, "DG", FIELD_DEGREE if varies else 0, shape)


def build(model: Model) -> tuple[dict, dict]:
    from dolfinx import fem

    shell, mesh = model.scene["shell"], model.mesh
    fields, ranges = {}, {}
    for key in material_keys(shell):
        V = field_space(mesh, any(is_field(v) for _, v, _ in owners(model, key)))
        f = fem.Function(V, name=FORM_NAMES[key])
        f.x.array[:] = nodal_values(model, key, V)
        f.x.scatter_forward()
        fields[FORM_NAMES[key]] = f
        ranges[key] = _range(model.comm, f)
    if shell.get("material") == "orthotropic":
        fields["fibre"] = _fibre(model)
        _check_poisson_field(model)
    _check_stiffness_finite(ranges)
    return fields, ranges


def _check_stiffness_finite(ranges: dict) -> None:
    """The largest modulus and thickness give a finite bending stiffness ``E t³``
    (docs/model.md §3.3): past double precision's 1.8e308 the tangent holds inf and
    Newton fails without naming the cause."""
    E = max(ranges[k][1] for k in ("E", "E1", "E2") if k in ranges)
    t = ranges["thickness"][1]
    try:
        stiffness = E * t**3  # (floats: ** raises where * gives inf)
    except OverflowError:
        stiffness = math.inf
    if not math.isfinite(stiffness):
        raise SceneError(
            f"shell: the bending stiffness E t³ overflows double precision (E up to "
            f"{E:.4g}, thickness up to {t:.4g}); check the units of E and thickness"
        )


def nodal_values(model: Model, key: str, V: dolfinx.fem.FunctionSpace) -> np.ndarray:
    """The key's values at the dofs of the scalar space ``V`` (each cell's from the
    number, formula or profile that owns it), checked."""
    from rftfem import compat

    dofs = compat.cell_dofs(V)
    at = V.tabulate_dof_coordinates()
    out = np.zeros(len(at))
    for where, value, cells in owners(model, key):
        nodes = np.unique(dofs if cells is None else dofs[cells])
        if not is_field(value):
            out[nodes] = float(value)
            continue
        values = field_values(model.scene, value, at[nodes], where)
        _check_admissible(model.comm, key, where, value, values, at[nodes])
        out[nodes] = values
    return out


def _check_admissible(comm, key, where, value, values, at, what=None):
    """Every rank raises when a node of any rank is bad (the first such rank's point)."""
    test, words = _ADMISSIBLE[key]
    bad = ~test(values)
    first = comm.allreduce(comm.rank if bad.any() else comm.size, op=_mpi_min())
    if first < comm.size:
        line = None
        if comm.rank == first:
            i = int(np.argmax(bad))
            line = (
                f"{where}: {what or describe(value)} is {values[i]:.4g} at "
                f"{fmt([round(float(v), 9) + 0.0 for v in at[i]])} on the body; "
                f"expected {words} everywhere"
            )
        raise SceneError(comm.bcast(line, root=first))


def _mpi_min():
    from mpi4py import MPI

    return MPI.MIN


def _range(comm, f) -> tuple[float, float, float]:
    from mpi4py import MPI

    n = f.function_space.dofmap.index_map.size_local * f.function_space.dofmap.index_map_bs
    a = f.x.array[:n]
    lo = comm.allreduce(float(a.min()) if n else np.inf, op=MPI.MIN)
    hi = comm.allreduce(float(a.max()) if n else -np.inf, op=MPI.MAX)
    mean = comm.allreduce(float(a.sum()), op=MPI.SUM) / max(comm.allreduce(n, op=MPI.SUM), 1)
    return lo, hi, mean


def _fibre(model):
    """The fibre direction as a vector field (DG0 for numbers, else DG2); projected
    on the surface and normalised in the forms (forms.elasticity.fibre_frame)."""
    from dolfinx import fem

    fibre = model.scene["shell"]["fibre"]
    varies = any(isinstance(v, str) for v in fibre)
    V = field_space(model.mesh, varies, (3,))
    f = fem.Function(V, name="fibre")
    if varies:
        scalar = field_space(model.mesh, True)
        at = scalar.tabulate_dof_coordinates()
        values = np.stack(
            [field_values(model.scene, v, at, f"shell.fibre.{i}") for i, v in enumerate(fibre)],
            axis=1,
        )
    else:
        values = np.broadcast_to(np.asarray(fibre, dtype=float), (len(f.x.array) // 3, 3))
    f.x.array[:] = np.asarray(values).ravel()
    _check_fibre(model, f)
    f.x.scatter_forward()
    return f


def _check_fibre(model, f):
    """At every node of the fibre field (a cell's centre for numbers) the fibre must
    not vanish nor lie along the normal: its tangential part at least a tenth of it
    (a one-line SceneError naming the point)."""
    from rftfem import compat

    cells, _ = compat.geometry_cells(model.mesh)
    x = model.mesh.geometry.x[cells[:, :3]]  # three vertices of each cell
    normals = np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0])
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    dofs = compat.cell_dofs(f.function_space)[: len(cells)]  # (cells, nodes)
    values = f.x.array.reshape(-1, 3)[dofs]
    size = np.linalg.norm(values, axis=2)
    along = np.abs(np.einsum("cnj,cj->cn", values, normals))
    zero = size <= 1e-12 * max(float(size.max()) if size.size else 0.0, 1e-300)
    bad = zero | (along > np.sqrt(1 - 0.01) * size)
    first = model.comm.allreduce(model.comm.rank if bad.any() else model.comm.size, op=_mpi_min())
    if first < model.comm.size:
        line = None
        if model.comm.rank == first:
            c, n = np.unravel_index(int(np.argmax(bad)), bad.shape)
            at = f.function_space.tabulate_dof_coordinates()[dofs[c, n]]
            point = fmt([round(float(v), 9) + 0.0 for v in at])
            line = (
                f"shell.fibre: the fibre is zero at {point}"
                if zero[c, n]
                else f"shell.fibre: the fibre is along the surface's normal at {point}"
            )
            line += " (it must lie in the surface, where it is projected)"
        raise SceneError(model.comm.bcast(line, root=first))


def _check_poisson_field(model):
    """ν12² < E1/E2 at every node of the fields, where any of them varies (numbers are
    checked when the scene is read)."""
    keys = ("E1", "E2", "nu12")
    if not any(is_field(v) for k in keys for _, v, _ in owners(model, k)):
        return
    V = field_space(model.mesh, True)
    E1, E2, nu12 = (nodal_values(model, k, V) for k in keys)
    _check_admissible(
        model.comm,
        "ν12² < E1/E2",
        "shell.nu12",
        None,
        E1 - nu12**2 * E2,
        V.tabulate_dof_coordinates(),
        what="E1 − ν12² E2",
    )


def material_value(
    model: Model, key: str, how: str = "max", value: float | str | dict[str, str] | None = None
) -> float:
    """A material key's largest (``how = "max"``), smallest (``"min"``) or mean value
    over the body, or ``"shell"``: [shell]'s own number (its mean if a field), for
    scales and tolerances.  ``value``: a part's value, itself if a number.  ``E`` and
    ``nu`` of an orthotropic shell: the larger in-plane modulus, ``nu12``."""
    if value is not None and not is_field(value):
        return float(value)
    ranges = model.material_ranges
    if key not in ranges:
        key = {"E": "E1", "nu": "nu12"}[key]
        if key == "E1":
            return max(material_value(model, "E1", how), material_value(model, "E2", how))
    if how == "shell":
        own = model.scene["shell"][key]
        return float(own) if not is_field(own) else ranges[key][2]
    return ranges[key][("min", "max", "mean").index(how)]
