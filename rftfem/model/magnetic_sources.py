"""Where the magnetic field and the magnetization come from (docs/model.md §5.5).

- :class:`UniformField`: ``b(t)``, the same everywhere: the rotating protocol,
  formulas of ``t``, or a table of rows ``t, Bx, By, Bz`` (linear or cubic);
- :class:`NonuniformField`: ``B(x, t)`` at the current position ``x``: formulas
  of ``x, y, z, t``, or a point dipole, fixed or moving along a path;
- :func:`profile_values`: a magnetization profile file, interpolated to points;
- :func:`check_field`: the checks of ``[magnetic.field]`` by kind.

Numbers (numpy) for outputs and checks, UFL for the forms; the forms themselves
are in :mod:`rftfem.forms.magnetic`.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from rftfem.errors import SceneError
from rftfem.model.triad import rotate
from rftfem.scene.expressions import parse
from rftfem.scene.schema import fmt, unit_vector

if TYPE_CHECKING:
    from collections.abc import Callable

    import dolfinx.fem
    import dolfinx.mesh
    from mpi4py import MPI
    from ufl.core.expr import Expr

#: μ₀/(4π) in N/A²: with lengths in mm, moments in A·mm² give B in N/(A·mm)
MU0_OVER_4PI = 1e-7

FIELD_KEY = "magnetic.field"


#: the keys of each kind of [magnetic.field]
FIELD_KINDS = {
    "rotating": ("strength", "ramp_time", "direction", "frequency", "rotation_axis"),
    "expression": ("B",),
    "table": ("values", "interpolation"),
    "dipole": ("moment", "position", "path"),
}
_ROTATING_DEFAULTS = {
    "strength": 0.0,
    "ramp_time": 0.0,
    "direction": [1.0, 0.0, 0.0],
    "frequency": 0.0,
    "rotation_axis": [0.0, 0.0, 1.0],
}


def check_field(field: dict) -> None:
    """Checks of ``[magnetic.field]`` after the schema: the keys of its kind only, the
    rotating protocol's defaults filled in, what each kind requires."""
    kind = field["kind"]
    _check_kind_keys(field, kind)
    if kind == "rotating":
        _check_rotating(field)
    elif kind == "expression" and field["B"] is None:
        raise SceneError(
            "missing required key 'magnetic.field.B' (three numbers or "
            "formulas of x, y, z, t, because magnetic.field.kind = "
            '"expression")'
        )
    elif kind == "table":
        if field["values"] is None:
            raise SceneError(
                "missing required key 'magnetic.field.values' (rows [t, Bx, "
                'By, Bz], because magnetic.field.kind = "table")'
            )
        field["interpolation"] = field["interpolation"] or "linear"
        if field["interpolation"] == "cubic" and len(field["values"]) < 4:
            raise SceneError(
                f"magnetic.field.values: a cubic table needs four rows at "
                f"least, found {len(field['values'])}"
            )
    elif kind == "dipole":
        if field["moment"] is None:
            raise SceneError(
                "missing required key 'magnetic.field.moment' (the source's "
                'dipole moment, because magnetic.field.kind = "dipole")'
            )
        if (field["position"] is None) == (field["path"] is None):
            raise SceneError(
                "magnetic.field: a dipole takes one of 'position' (fixed) and "
                "'path' (rows [t, x, y, z]), found "
                + ("both" if field["position"] is not None else "neither")
            )


def _check_kind_keys(field: dict, kind: str) -> None:
    """No key of another kind of ``[magnetic.field]`` is given."""
    for other, keys in FIELD_KINDS.items():
        for key in keys:
            if other != kind and key not in FIELD_KINDS[kind] and field[key] is not None:
                users = [k for k, ks in FIELD_KINDS.items() if key in ks]
                raise SceneError(
                    f"magnetic.field.{key}: only used with kind = "
                    + " or ".join(f'"{k}"' for k in users)
                    + f", found kind = {fmt(kind)}"
                )


def _check_rotating(field: dict) -> None:
    """The rotating protocol's defaults filled in; a rotating field's axis across it."""
    for key, value in _ROTATING_DEFAULTS.items():
        if field[key] is None:
            field[key] = list(value) if isinstance(value, list) else value
    if field["frequency"] != 0.0:  # a rotating field needs an axis across it
        b, a = unit_vector(field["direction"]), unit_vector(field["rotation_axis"])
        cross = (
            b[1] * a[2] - b[2] * a[1],
            b[2] * a[0] - b[0] * a[2],
            b[0] * a[1] - b[1] * a[0],
        )
        if math.hypot(*cross) <= 1e-9:
            raise SceneError(
                f"magnetic.field.rotation_axis: expected an axis not parallel to "
                f"magnetic.field.direction = {fmt(field['direction'])} (the field "
                f"would not rotate at frequency = {fmt(field['frequency'])}), found "
                f"{fmt(field['rotation_axis'])}"
            )


def is_uniform(field: dict) -> bool:
    """Whether ``[magnetic.field]`` is the same everywhere (then no gradient force)."""
    if field["kind"] == "dipole":
        return False
    if field["kind"] == "expression":
        return not any(
            parse(b, f"{FIELD_KEY}.B", ("x", "y", "z", "t")).names & {"x", "y", "z"}
            for b in field["B"]
        )
    return True


# ------------------------------------------------------------------ uniform fields


class UniformField:
    """``b(t)`` of a uniform ``[magnetic.field]``."""

    def __init__(self, field: dict):
        self.field = field
        kind = field["kind"]
        if kind == "expression":
            self.formulas = [
                parse(b, f"{FIELD_KEY}.B.{i}", ("t",)) for i, b in enumerate(field["B"])
            ]
        elif kind == "table":
            rows = np.array(field["values"], dtype=float)
            self.table = TimeTable(rows[:, 0], rows[:, 1:], field["interpolation"])

    def at(self, t: float) -> np.ndarray:
        f, kind = self.field, self.field["kind"]
        if kind == "expression":
            return np.array([float(b.numbers({"t": t})) for b in self.formulas])
        if kind == "table":
            return self.table(t)
        # rotating: ramps up along ``direction``, then turns about ``rotation_axis``
        direction = np.array(unit_vector(f["direction"]))
        axis = np.array(unit_vector(f["rotation_axis"]))
        ramp = f["ramp_time"]
        if t <= ramp:
            return f["strength"] * (t / ramp if ramp > 0 else 1.0) * direction
        angle = 2 * np.pi * f["frequency"] * (t - ramp)
        return f["strength"] * rotate(direction[None, :], angle * axis[None, :])[0]

    def scale(self, end: float) -> float:
        """The largest field strength over the run (sampled), for tolerances."""
        if self.field["kind"] == "rotating":
            return self.field["strength"]
        if self.field["kind"] == "table":
            return float(np.linalg.norm(self.table.values, axis=1).max())
        return max(float(np.linalg.norm(self.at(t))) for t in np.linspace(0.0, end, 101))


class TimeTable:
    """Rows ``t_i, v_i`` interpolated linearly or by a not-a-knot cubic spline (which
    reproduces cubic polynomials exactly); held at the end values outside."""

    def __init__(self, t: np.ndarray, values: np.ndarray, interpolation: str):
        self.t, self.values, self.cubic = t, values, interpolation == "cubic"
        if self.cubic:
            self.second = _not_a_knot_second_derivatives(t, values)

    def __call__(self, t: float) -> np.ndarray:
        ts, vs = self.t, self.values
        if t <= ts[0]:
            return vs[0].copy()
        if t >= ts[-1]:
            return vs[-1].copy()
        i = int(np.searchsorted(ts, t, side="right")) - 1
        h = ts[i + 1] - ts[i]
        a, b = (ts[i + 1] - t) / h, (t - ts[i]) / h
        out = a * vs[i] + b * vs[i + 1]
        if self.cubic:
            M = self.second
            out = out + ((a**3 - a) * M[i] + (b**3 - b) * M[i + 1]) * h * h / 6.0
        return out


def _not_a_knot_second_derivatives(t: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Second derivatives at the knots of the not-a-knot cubic spline through (t, y)
    (one column of y per component); the third derivative is continuous at the
    second and the last-but-one knot."""
    n = len(t)
    h = np.diff(t)
    A = np.zeros((n, n))
    r = np.zeros((n, y.shape[1]))
    for i in range(1, n - 1):
        A[i, i - 1 : i + 2] = h[i - 1], 2 * (h[i - 1] + h[i]), h[i]
        r[i] = 6 * ((y[i + 1] - y[i]) / h[i] - (y[i] - y[i - 1]) / h[i - 1])
    A[0, :3] = 1 / h[0], -(1 / h[0] + 1 / h[1]), 1 / h[1]
    A[-1, -3:] = 1 / h[-2], -(1 / h[-2] + 1 / h[-1]), 1 / h[-1]
    return np.linalg.solve(A, r)


# --------------------------------------------------------------- nonuniform fields


class NonuniformField:
    """``B(x, t)`` of a nonuniform ``[magnetic.field]``: formulas of ``x, y, z, t``, or
    a point dipole of moment ``m_s`` at ``p(t)``:
    ``B = μ₀/(4π) (3 r (m_s·r)/|r|⁵ − m_s/|r|³)``, ``r = x − p``."""

    def __init__(self, field: dict):
        self.field = field
        self.dipole = field["kind"] == "dipole"
        if self.dipole:
            self.moment = np.array(field["moment"], dtype=float)
            path = field["path"] if field["path"] is not None else [[0.0, *field["position"]]]
            rows = np.array(path, dtype=float)
            self.path = TimeTable(rows[:, 0], rows[:, 1:], "linear")
        else:
            self.formulas = [
                parse(b, f"{FIELD_KEY}.B.{i}", ("x", "y", "z", "t"))
                for i, b in enumerate(field["B"])
            ]
        self._time = self.position_constant = self.moment_constant = None

    def position(self, t: float) -> np.ndarray:
        """The dipole's position at ``t`` (held at the path's ends outside it)."""
        return self.path(t)

    def ufl(self, mesh: dolfinx.mesh.Mesh, x: Expr) -> Expr:
        """``B`` at the UFL position ``x``, with the time (and the dipole's position) as
        Constants that :meth:`set_time` moves."""
        import ufl
        from dolfinx import fem
        from petsc4py import PETSc

        if self.dipole:
            self.position_constant = fem.Constant(mesh, np.zeros(3, dtype=PETSc.ScalarType))
            self.moment_constant = m = fem.Constant(
                mesh, np.asarray(self.moment, dtype=PETSc.ScalarType)
            )
            r = x - self.position_constant
            rr = ufl.sqrt(ufl.dot(r, r))
            n = r / rr  # (through the unit vector: r⁵ overflows for a magnet 1e62 away)
            return MU0_OVER_4PI * (3 * n * ufl.dot(m, n) - m) / rr**3
        self._time = fem.Constant(mesh, PETSc.ScalarType(0.0))
        env = {"x": x[0], "y": x[1], "z": x[2], "t": self._time}
        return ufl.as_vector(
            [_as_ufl(b.ufl(env, number=constant_maker(mesh))) for b in self.formulas]
        )

    def set_time(self, t: float) -> None:
        if self.position_constant is not None:
            self.position_constant.value[:] = self.position(t)
        if self._time is not None:
            self._time.value = t

    def at(self, points: np.ndarray, t: float) -> np.ndarray:
        """``B`` at ``points`` (n, 3) at time ``t``, as an (n, 3) array."""
        points = np.atleast_2d(points)
        if self.dipole:
            return dipole_field(points - self.position(t), self.moment)
        env = {"x": points[:, 0], "y": points[:, 1], "z": points[:, 2], "t": t}
        return np.stack(
            [np.broadcast_to(b.numbers(env), len(points)) for b in self.formulas], axis=1
        )

    def check_outside(self, nodes: np.ndarray, size: float, comm: MPI.Comm) -> None:
        """A dipole must start outside the body: farther than half a cell (``size``)
        from every node of the reference body, where the mesh could not resolve its
        field (a one-line SceneError)."""
        if not self.dipole:
            return
        p = self.position(0.0)
        with np.errstate(over="ignore"):  # a magnet 1e154 away: inf, and outside
            near = float(np.linalg.norm(nodes - p, axis=1).min()) if len(nodes) else math.inf
        near = comm.allreduce(near, op=_min_op())
        if near < 0.5 * size:
            key = "path" if self.field["path"] is not None else "position"
            raise SceneError(
                f"{FIELD_KEY}.{key}: the dipole at {fmt([float(v) for v in p])} "
                f"(t = 0) is inside the body ({near:.3g} from its nearest node, "
                f"less than half a cell, {0.5 * size:.3g}); place it outside"
            )

    def scale(self, nodes: np.ndarray, end: float, comm: MPI.Comm) -> float:
        """The largest |B| on the reference body over the run (sampled), for tolerances."""
        times = [0.0] if self.dipole else np.linspace(0.0, end, 11)
        local = (
            max(
                (float(np.linalg.norm(self.at(nodes, t), axis=1).max()) for t in times), default=0.0
            )
            if len(nodes)
            else 0.0
        )
        return comm.allreduce(local, op=_max_op())


def dipole_field(r: np.ndarray, moment: np.ndarray) -> np.ndarray:
    """The point dipole's ``B = μ₀/4π (3 n (n·m) − m) / |r|³`` at offsets ``r`` (n, 3),
    ``n = r/|r|``: each offset scaled by its largest component first, so that a
    magnet 1e160 away gives a field of 0, not inf/inf."""
    scale = np.abs(r).max(axis=1, keepdims=True)
    with np.errstate(over="ignore", under="ignore", divide="ignore"):
        q = r / scale
        length = np.linalg.norm(q, axis=1, keepdims=True)
        n = q / length
        cube = (scale * length) ** 3  # inf past 1e102: the field is 0 there
        return MU0_OVER_4PI * (3 * n * (n @ moment)[:, None] - moment[None, :]) / cube


def constant_maker(mesh: dolfinx.mesh.Mesh) -> Callable[[float], dolfinx.fem.Constant]:
    """float -> ``fem.Constant`` on ``mesh``: a formula's numbers as coefficients, so that
    its compiled form serves every value of them (a sweep compiles once)."""
    from dolfinx import fem
    from petsc4py import PETSc

    return lambda v: fem.Constant(mesh, PETSc.ScalarType(v))


def _as_ufl(value):
    """A formula's value as UFL: a number (a constant entry) becomes a UFL constant."""
    import ufl

    return ufl.as_ufl(value) if isinstance(value, (int, float)) else value


def _min_op():
    from mpi4py import MPI

    return MPI.MIN


def _max_op():
    from mpi4py import MPI

    return MPI.MAX


# ------------------------------------------------------------------ profiles
# (rftfem/scene/profiles.py; imported here for the magnetic component)
from rftfem.scene.profiles import profile_values, read_profile  # noqa: E402,F401
