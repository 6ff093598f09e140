"""The remanent magnetization of the ``[magnetic]`` parts: numbers stored cellwise, or
formulas and profiles of the reference coordinates, and the measure of the magnetized cells."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import ufl

from rftfem.model.effects.magnetic_keys import REFERENCE
from rftfem.model.magnetic_sources import constant_maker, profile_values, read_profile
from rftfem.scene.expressions import parse

if TYPE_CHECKING:
    import dolfinx.fem
    import dolfinx.mesh
    from ufl.core.expr import Expr


def varies(part: dict) -> bool:
    """Whether a part's magnetization varies over it (formulas or a profile file)."""
    return (
        part["profile"] is not None
        or isinstance(part["magnetization"], str)
        or any(isinstance(v, str) for v in part["direction"])
    )


def _ufl_of(value, key: str, env: dict, number):
    """A number or formula of the reference coordinates as UFL, its numbers Constants."""
    if isinstance(value, str):
        return parse(value, key, REFERENCE).ufl(env, number)
    return number(float(value))


def cellwise_remanence(
    mesh: dolfinx.mesh.Mesh, parts: list[dict], owner: dict[int, np.ndarray]
) -> tuple[dolfinx.fem.Function, list[np.ndarray]]:
    """``M`` of plain numbers as a DG0 vector (each part's on its cells ``owner[i]``),
    and the cells of the parts that are on."""
    from dolfinx import fem

    from rftfem import compat

    # today's forms, to the last bit: M cellwise, parts switched off (0, e.g. in
    # a sweep) left out of the measure, q = F q₀ with q₀ = M/|M|
    V = compat.function_space(mesh, "DG", 0, (3,))
    remanence = fem.Function(V, name="remanent_magnetization")
    dofs = compat.cell_dofs(V)[:, 0]
    for i, part in enumerate(parts):
        q0 = np.asarray(part["direction"], dtype=float)
        remanence.x.array.reshape(-1, 3)[dofs[owner[i]]] = (
            part["magnetization"] * q0 / np.linalg.norm(q0)
        )
    remanence.x.scatter_forward()
    on = [owner[i] for i, part in enumerate(parts) if part["magnetization"] > 0]
    return remanence, on


def remanence_expression(
    mesh: dolfinx.mesh.Mesh, scene: dict, parts: list[dict], part_cells: dict[int, np.ndarray]
) -> tuple[Expr, dict[int, tuple[dolfinx.fem.Function, np.ndarray]]]:
    """``Σ χ_p M_p(X)``: each part's magnetization (numbers, formulas of the reference
    coordinates, or its profile interpolated to P1) on its cells; and each profile's
    P1 field and grid points, by part."""
    from dolfinx import fem

    from rftfem import compat

    X = ufl.SpatialCoordinate(mesh)
    env = {"X": X[0], "Y": X[1], "Z": X[2]}
    profile_fields = {}
    number = constant_maker(mesh)
    chi_space = compat.function_space(mesh, "DG", 0)
    chi_dofs = compat.cell_dofs(chi_space)[:, 0]
    total = None
    for i, part in enumerate(parts):
        where = f"magnetic.parts.{i}"
        chi = fem.Function(chi_space, name=f"part_{i}")
        chi.x.array[chi_dofs[part_cells[i]]] = 1.0
        chi.x.scatter_forward()
        if part["profile"] is not None:
            path = (
                Path(scene.get("_folder") or Path(scene["_path"]).parent)
                / Path(part["profile"]).expanduser()
            )
            points, values = read_profile(path, f"{where}.profile")
            V1 = compat.function_space(mesh, "Lagrange", 1, (3,))
            Mp = fem.Function(V1, name=f"profile_{i}")
            nodes = np.unique(compat.cell_dofs(V1)[part_cells[i]])
            at = V1.tabulate_dof_coordinates()[nodes]
            Mp.x.array.reshape(-1, 3)[nodes] = profile_values(
                points, values, at, f"{where}.profile"
            )
            Mp.x.scatter_forward()
            #: a profile's P1 field and grid points, for gradients by its values
            profile_fields[i] = (Mp, points)
        else:
            m = _ufl_of(part["magnetization"], f"{where}.magnetization", env, number)
            d = [
                _ufl_of(v, f"{where}.direction.{c}", env, number)
                for c, v in enumerate(part["direction"])
            ]
            d = ufl.as_vector(d)
            Mp = m * d / ufl.sqrt(ufl.dot(d, d))
        total = chi * Mp if total is None else total + chi * Mp
    return total, profile_fields


def magnetized_measure(mesh: dolfinx.mesh.Mesh, on: list[np.ndarray]) -> ufl.Measure:
    """``dx`` over the magnetized cells ``on`` (tagged 1), at quadrature degree 4."""
    from rftfem import compat

    cells = np.unique(np.concatenate(on or [np.empty(0, np.int32)])).astype(np.int32)
    tags = compat.create_meshtags(
        mesh, mesh.topology.dim, cells, np.ones(len(cells), dtype=np.int32)
    )
    return ufl.Measure("dx", domain=mesh, subdomain_data=tags, metadata={"quadrature_degree": 4})(1)
