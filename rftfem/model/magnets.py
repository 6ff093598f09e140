"""Permanent magnets as field sources, the scene's ``[[magnetic.source]]``
(docs/magnetic_actuation.md, "Permanent magnets").

The fields of the shapes in closed form are :mod:`rftfem.model.magnet_fields`'s
(:func:`cuboid_field`, :func:`cylinder_field`, :func:`sphere_field`): they give
numbers (numpy) and UFL, so the outputs and the forms agree; the forms differentiate the UFL
exactly (``ufl.derivative``).  The magnet's position and orientation (numbers or
formulas of ``t``) are Constants that :meth:`Magnet.set_time` sets.  Units: N, mm, A
(docs/model.md): 1 T is 1e-3 N/(A·mm).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from rftfem.errors import SceneError
from rftfem.model.magnet_fields import (
    _Numpy,
    _Ufl,
    cuboid_field,
    cylinder_field,
    sphere_field,
)
from rftfem.scene.expressions import parse
from rftfem.scene.schema import Array, Formulas, Leaf, Str, Table, Validator, Vec, err, fmt

if TYPE_CHECKING:
    from collections.abc import Sequence

    import dolfinx.mesh
    from mpi4py import MPI
    from ufl.core.expr import Expr

    from rftfem.model.magnetic_sources import NonuniformField, UniformField

#: the project's field unit, N/(A·mm), per tesla
TESLA = 1e-3
KEY = "magnetic.source"
#: how many numbers each kind's ``dimension`` takes, and what they are
KINDS = {
    "cuboid": (3, "the three sides"),
    "cylinder": (2, "[diameter, height]"),
    "sphere": (1, "[diameter]"),
}


class Dimension(Validator):
    """One to three positive numbers (how many the kind takes: :func:`check_sources`)."""

    expected = "a list of 1 to 3 positive numbers"

    def __call__(self, value: Any, path: str) -> list[float]:
        if (
            not isinstance(value, list)
            or not 1 <= len(value) <= 3
            or any(
                isinstance(v, bool)
                or not isinstance(v, (int, float))
                or not v > 0
                or not math.isfinite(v)
                for v in value
            )
        ):
            raise err(path, self.expected, value)
        return [float(v) for v in value]


SOURCE_SCHEMA = Array(
    Table(
        {
            "kind": Leaf(
                Str(choices=tuple(KINDS)),
                required=True,
                doc='The magnet\'s shape: "cuboid", "cylinder" (its axis along its own '
                'Z; polarized along it only, for now) or "sphere"; each field in '
                "closed form.",
            ),
            "dimension": Leaf(
                Dimension(),
                required=True,
                unit="length",
                doc="cuboid: its three sides along its own X, Y, Z; cylinder: "
                "[diameter, height]; sphere: [diameter].",
            ),
            "polarization": Leaf(
                Vec(nonzero=True),
                required=True,
                unit="tesla",
                doc="The uniform polarization J = μ₀M in the magnet's own frame, in "
                "tesla (1 T is 1e-3 N/(A·mm), the project's units N, mm, A); "
                "about 1.3 T for NdFeB.",
            ),
            "position": Leaf(
                Formulas(("t",)),
                required=True,
                unit="length",
                doc="The magnet's centre: numbers, or formulas of t (it moves).",
            ),
            "orientation": Leaf(
                Formulas(("t",)),
                [0.0, 0.0, 0.0],
                unit="degree",
                doc="Turns of the magnet's frame from the scene's axes: degrees "
                "about X, then Y, then Z (fixed axes); numbers or formulas of "
                "t.",
            ),
        }
    ),
    doc="Permanent magnets whose field adds to `[magnetic.field]` (a nonuniform field: it "
    "pulls the magnetized parts along its gradient).",
)


def check_sources(sources: list) -> None:
    """Each source's kind is supported and its ``dimension`` has that kind's count."""
    for i, s in enumerate(sources):
        where = f"{KEY}.{i}"
        if s["kind"] == "cylinder" and any(s["polarization"][:2]):
            raise SceneError(
                f"{where}.polarization: a cylinder polarized across its axis is "
                f"not supported yet, found {fmt(s['polarization'])}; give [0, 0, J] "
                f"(along its own Z axis, turned by `orientation`), or use a cuboid"
            )
        n, what = KINDS[s["kind"]]
        if len(s["dimension"]) != n:
            raise SceneError(
                f"{where}.dimension: expected {n} number{'s' * (n > 1)} "
                f"({what}) for kind = {fmt(s['kind'])}, found {fmt(s['dimension'])}"
            )


def rotation(angles_deg: Sequence[float] | np.ndarray) -> np.ndarray:
    """``Rz Ry Rx``: turns about the fixed X, then Y, then Z axes (degrees)."""
    a, b, c = np.radians(np.asarray(angles_deg, dtype=float))
    Rx = np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])
    Ry = np.array([[np.cos(b), 0, np.sin(b)], [0, 1, 0], [-np.sin(b), 0, np.cos(b)]])
    Rz = np.array([[np.cos(c), -np.sin(c), 0], [np.sin(c), np.cos(c), 0], [0, 0, 1]])
    return Rz @ Ry @ Rx


class Magnet:
    """One ``[[magnetic.source]]``: its field in numbers and in UFL."""

    def __init__(self, source: dict, index: int):
        self.source, self.where = source, f"{KEY}.{index}"
        self.kind = source["kind"]
        self.dimension = np.array(source["dimension"], dtype=float)
        self.J = TESLA * np.array(source["polarization"], dtype=float)
        self.formulas = {
            key: [
                parse(v, f"{self.where}.{key}.{c}", ("t",)) if isinstance(v, str) else float(v)
                for c, v in enumerate(source[key])
            ]
            for key in ("position", "orientation")
        }
        self._p = self._R = None

    def _values(self, key, t):
        return np.array(
            [f if isinstance(f, float) else float(f.numbers({"t": t})) for f in self.formulas[key]]
        )

    def position(self, t: float) -> np.ndarray:
        return self._values("position", t)

    def rotation(self, t: float) -> np.ndarray:
        return rotation(self._values("orientation", t))

    def _local_field(self, x, J, ops):
        if self.kind == "sphere":
            return sphere_field(x, self.dimension[0], J, ops)
        if self.kind == "cylinder":
            return cylinder_field(x, self.dimension[0], self.dimension[1], J[2], ops)
        return cuboid_field(
            x, 0.5 * self.dimension, J, ops, axes=[k for k in range(3) if self.J[k] != 0.0]
        )

    def at(self, points: np.ndarray, t: float) -> np.ndarray:
        """``B`` at ``points`` (n, 3) at ``t`` (n, 3)."""
        R = self.rotation(t)
        local = (np.atleast_2d(points) - self.position(t)) @ R  # Rᵀ (x − p), row-wise
        with np.errstate(divide="ignore", invalid="ignore"):
            B = np.stack(self._local_field(local.T, self.J, _Numpy), axis=1)
        return B @ R.T

    def ufl(self, mesh: dolfinx.mesh.Mesh, x: Expr) -> Expr:
        """``R B_local(Rᵀ (x − p))`` with ``p``, ``R`` and ``J`` Constants."""
        import ufl
        from dolfinx import fem
        from petsc4py import PETSc

        self._p = fem.Constant(mesh, np.zeros(3, dtype=PETSc.ScalarType))
        self._R = fem.Constant(mesh, np.eye(3, dtype=PETSc.ScalarType))
        J = fem.Constant(mesh, np.asarray(self.J, dtype=PETSc.ScalarType))
        local = ufl.dot(ufl.transpose(self._R), x - self._p)
        B = self._local_field([local[c] for c in range(3)], [J[c] for c in range(3)], _Ufl())
        return ufl.dot(self._R, ufl.as_vector(B))

    def set_time(self, t: float) -> None:
        if self._p is not None:
            self._p.value[:] = self.position(t)
            self._R.value[:] = self.rotation(t)

    def distance(self, points: np.ndarray, t: float = 0.0) -> np.ndarray:
        """Distance of each point from the magnet's solid (0 inside)."""
        local = (np.atleast_2d(points) - self.position(t)) @ self.rotation(t)
        if self.kind == "sphere":
            return np.maximum(np.linalg.norm(local, axis=1) - 0.5 * self.dimension[0], 0.0)
        if self.kind == "cylinder":
            radial = np.maximum(np.hypot(local[:, 0], local[:, 1]) - 0.5 * self.dimension[0], 0)
            return np.hypot(radial, np.maximum(np.abs(local[:, 2]) - 0.5 * self.dimension[1], 0))
        return np.linalg.norm(np.maximum(np.abs(local) - 0.5 * self.dimension, 0.0), axis=1)


class SourcedField:
    """``[magnetic.field]`` plus the magnets: ``B(x, t) = B_field(x, t) + Σ B_s(x, t)``,
    a nonuniform field (the interface of :class:`~rftfem.model.magnetic_sources.NonuniformField`).
    ``base``: a NonuniformField, or a UniformField whose ``b(t)`` is then a Constant."""

    def __init__(self, base: NonuniformField | UniformField, sources: list):
        self.base = base
        self.uniform_base = not hasattr(base, "check_outside")
        self.magnets = [Magnet(s, i) for i, s in enumerate(sources)]
        self._b = None

    def ufl(self, mesh: dolfinx.mesh.Mesh, x: Expr) -> Expr:
        from dolfinx import fem
        from petsc4py import PETSc

        if self.uniform_base:
            self._b = fem.Constant(mesh, np.zeros(3, dtype=PETSc.ScalarType))
            total = self._b
        else:
            total = self.base.ufl(mesh, x)
        for magnet in self.magnets:
            total = total + magnet.ufl(mesh, x)
        return total

    def set_time(self, t: float) -> None:
        if self.uniform_base:
            if self._b is not None:
                self._b.value[:] = self.base.at(t)
        else:
            self.base.set_time(t)
        for magnet in self.magnets:
            magnet.set_time(t)

    def at(self, points: np.ndarray, t: float) -> np.ndarray:
        points = np.atleast_2d(points)
        total = (
            np.tile(self.base.at(t), (len(points), 1))
            if self.uniform_base
            else self.base.at(points, t)
        )
        for magnet in self.magnets:
            total = total + magnet.at(points, t)
        return total

    def check_outside(self, nodes: np.ndarray, size: float, comm: MPI.Comm) -> None:
        """Each magnet starts outside the body, farther than half a cell (``size``)
        from every node of the reference body (a one-line SceneError)."""
        from rftfem.model.magnetic_sources import _min_op

        if not self.uniform_base:
            self.base.check_outside(nodes, size, comm)
        for magnet in self.magnets:
            near = float(magnet.distance(nodes).min()) if len(nodes) else math.inf
            near = comm.allreduce(near, op=_min_op())
            if near < 0.5 * size:
                p = [float(v) for v in magnet.position(0.0)]
                raise SceneError(
                    f"{magnet.where}.position: the {magnet.kind} at {fmt(p)} "
                    f"(t = 0) reaches into the body ({near:.3g} from its nearest "
                    f"node, less than half a cell, {0.5 * size:.3g}); place it "
                    f"outside"
                )

    def scale(self, nodes: np.ndarray, end: float, comm: MPI.Comm) -> float:
        """The largest |B| on the reference body over the run (sampled at 11 times)."""
        from rftfem.model.magnetic_sources import _max_op

        local = (
            max(
                (
                    float(np.nanmax(np.linalg.norm(self.at(nodes, t), axis=1)))
                    for t in np.linspace(0.0, end, 11)
                ),
                default=0.0,
            )
            if len(nodes)
            else 0.0
        )
        return comm.allreduce(local, op=_max_op())
