"""Three rigid hinged links in resistive-force drag: an independent reference model.

The body
--------
Three rigid flat plates ("links") of width ``ℓ`` (across, in the YZ plane),
length ``L`` (along X) and thickness ``t`` are hinged along their long edges.
Nothing varies along X, so the motion is planar: each link is a rigid segment
in the YZ plane and every force and mass below is per unit length times ``L``.
In the reference configuration the links lie in the plane Z = 0 side by side
along Y: left on Y ∈ [0, ℓ], middle on [ℓ, 2ℓ], right on [2ℓ, 3ℓ].  The hinges
at Y = ℓ and 2ℓ are free.  The "corner" is the left link's outer edge.

Each link has mass ``m = μ ℓ L`` with ``μ = ρ t`` the mass per reference area,
and moment of inertia ``m ℓ² / 12`` about its centre (the rotary inertia of the
thickness is neglected).

Drag (resistive-force theory)
-----------------------------
A point of a link moving with velocity ``v`` (in YZ) feels the traction per
reference area

    f = −( C₂ (v·e) e + C₃ (v·n) n ),

``e = (cos θ, sin θ)`` the link's direction across its width (from +Y toward
+Z: ``θ`` is its angle about +X) and ``n = (−sin θ, cos θ)`` its normal.  The
velocity is affine along a link, so the drag is integrated exactly across the
width (a force on the link's centre and a moment) and multiplied by ``L``.

Prescribed motion
-----------------
The heights (Z) of the outer edges are prescribed, ``Z_left = w_L(t)`` and
``Z_right = w_R(t)``; their Y coordinates are free, so the constraint forces act
along Z only.  ``w`` is a piecewise-linear table ``[[t, w], ...]`` (constant
before the first and after the last entry) or a smooth ``(w, w', w'')`` triple of
callables.  Where the prescribed edge velocity jumps (a kink of a table, and
the start from rest at t = 0) the constraint acts impulsively: with ``M`` the
mass matrix and ``G`` the Jacobian of the constraints,

    M Δq̇ = Gᵀ Λ,        G q̇⁺ = ẇ⁺,

the change of least kinetic energy that meets the new edge velocities.  Its
work is ``Λ · G (q̇⁻ + q̇⁺) / 2`` (= the jump of kinetic energy).

Equations of motion
-------------------
With generalized coordinates ``q``, d'Alembert's principle gives

    M(q) q̈ + h(q, q̇) = F(q, q̇) + Gᵀ λ,     G q̈ = ẅ − Ġ q̇,

``M = ∑ ∫ μ Jᵀ J`` (J: the velocity of a point, ẋ = J q̇), ``h = ∑ ∫ μ Jᵀ b`` the
centripetal terms (``b`` the point acceleration at q̈ = 0), ``F = −R(q) q̇`` the
drag (``R = ∑ ∫ Jᵀ (C₂ e eᵀ + C₃ n nᵀ) J``), all integrals over the links times
``L``, and ``λ`` the constraint forces.  The second equation is the constraint
g(q) = w(t) differentiated twice (index reduction).  Every few steps and at
every break the state is projected back onto g(q) = w, G q̇ = ẇ (the velocity
by the least-kinetic-energy correction above, its tiny work booked with the
constraint work), so the drift stays ~1e-12.

Without density (ρ = 0, the overdamped or Stokes regime) the velocities follow
from the drag balance alone:

    R(q) q̇ = Gᵀ λ,     G q̇ = ẇ.

Energy: d/dt (½ q̇ᵀ M q̇) = λ · G q̇ − q̇ᵀ R q̇ (power of the constraint forces
minus the drag dissipation).  Momentum along Y: the constraint forces have no
Y component, so d/dt P_Y = total drag force along Y.

Two formulations
----------------
``AngleModel``: q = (Y_c, Z_c, θ_L, θ_M, θ_R), the middle link's centre and the
three link angles; two edge constraints.

``LineModel``: q = the (Y, Z) of the four edge/hinge lines P₀..P₃; three
rigid-length constraints ½(|P_{k+1} − P_k|² − ℓ²) = 0 and the two edge
constraints.  Its mass matrix is constant (a rigid segment's kinetic energy is
(m/6)(|V_a|² + V_a·V_b + |V_b|²)) and has no centripetal term: the
nonlinearity sits in the constraints instead.

Both are integrated with the classical fourth-order Runge-Kutta method between
breaks (kinks of the prescribed motion and output times) with a uniform step no
larger than ``max_step``.  Run this file to print the figures for the FE tests.

Entry points: ``simulate`` (and its ``Result``), ``loop_tables``,
``smooth_stroke``.  Units mm, s, N, mass in tonne.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

#: drag coefficients (along X, across the link, normal), N·s/mm³
DRAG = (3.0e-9, 3.0e-9, 5.67e-9)

#: (w_L, w_R) corners of the stroke loops, in units of the amplitude; each leg T/4
LOOPS = {
    "square": [(0, 0), (1, 0), (1, 1), (0, 1), (0, 0)],
    "reciprocal": [(0, 0), (1, 0), (1, 1), (1, 0), (0, 0)],
}


# --------------------------------------------------------------------------
# The body's data
# --------------------------------------------------------------------------


@dataclass(frozen=True)
class Body:
    """Geometry, density and drag of the three-link body."""

    link_width: float = 0.5  # ℓ, across a link (mm)
    length: float = 5.0  # L, along X (mm)
    thickness: float = 0.2  # t (mm)
    density: float = 1.0e-8  # ρ (t/mm³)
    drag: tuple = DRAG  # (C₁, C₂, C₃); C₁ (along X) plays no role

    @property
    def mu(self) -> float:
        """Mass per reference area μ = ρ t."""
        return self.density * self.thickness

    @property
    def link_mass(self) -> float:
        """m = μ ℓ L."""
        return self.mu * self.link_width * self.length

    @property
    def c_across(self) -> float:
        """C₂: drag across the link (along e)."""
        return self.drag[1]

    @property
    def c_normal(self) -> float:
        """C₃: drag normal to the link (along n)."""
        return self.drag[2]

    @property
    def inertial_time(self) -> float:
        """μ / max(C₂, C₃): the fastest decay time of a link's velocity in the drag."""
        return self.mu / max(self.c_across, self.c_normal)


# --------------------------------------------------------------------------
# Prescribed edge heights
# --------------------------------------------------------------------------


class Table:
    """Piecewise-linear history from ``[[t, w], ...]``, constant outside the table.

    ``piece(t_mid)`` returns the affine (value, rate, acceleration) functions of
    the segment containing ``t_mid``, valid on the whole closed segment (so the
    integrator sees one smooth function between kinks)."""

    def __init__(self, rows):
        rows = np.asarray(rows, dtype=float)
        if rows.ndim != 2 or rows.shape[1] != 2 or len(rows) == 0:
            raise ValueError("a table is a list of [t, w] rows")
        if np.any(np.diff(rows[:, 0]) <= 0):
            raise ValueError("table times must increase")
        self.t, self.w = rows[:, 0], rows[:, 1]

    @property
    def breaks(self):
        return list(self.t)

    def piece(self, t_mid):
        i = int(np.searchsorted(self.t, t_mid, side="right")) - 1
        if i < 0 or i >= len(self.t) - 1:  # constant before / after
            w0 = float(self.w[0] if i < 0 else self.w[-1])
            return (lambda t: w0), (lambda t: 0.0), (lambda t: 0.0)
        t0, w0 = float(self.t[i]), float(self.w[i])
        slope = float((self.w[i + 1] - self.w[i]) / (self.t[i + 1] - self.t[i]))
        return (lambda t: w0 + slope * (t - t0)), (lambda t: slope), (lambda t: 0.0)


class Smooth:
    """A history made of smooth pieces: ``Smooth(w, w', w'')`` for one piece of
    callables valid at all times, or ``Smooth.pieces([(t_start, (w, w', w'')), ...])``
    for pieces that start at increasing times (a derivative may jump where a
    piece starts; the integrator restarts there, and a jump of w' is met by an
    impulse).  ``piece(t_mid)`` returns the triple in force at ``t_mid``, used
    on the whole closed interval around it.  ``time_scale`` (optional): the time
    over which the history changes appreciably, e.g. 1/ω; ``simulate``'s default
    step is at most 1/50 of it."""

    def __init__(self, value, rate, accel, time_scale=None):
        self._starts, self._triples = [-math.inf], [(value, rate, accel)]
        self.time_scale = time_scale

    @classmethod
    def pieces(cls, pieces, time_scale=None):
        self = cls.__new__(cls)
        self.time_scale = time_scale
        self._starts = [float(t) for t, _ in pieces]
        self._triples = [tuple(f) for _, f in pieces]
        if any(b <= a for a, b in zip(self._starts, self._starts[1:])):
            raise ValueError("piece start times must increase")
        return self

    @property
    def breaks(self):
        return [t for t in self._starts if math.isfinite(t)]

    def piece(self, t_mid):
        i = max(0, int(np.searchsorted(self._starts, t_mid, side="right")) - 1)
        return self._triples[i]


def as_history(spec):
    """A ``Table`` or ``Smooth`` from a table, a (w, w', w'') triple, or either object."""
    if isinstance(spec, (Table, Smooth)):
        return spec
    if isinstance(spec, tuple) and len(spec) == 3 and all(callable(f) for f in spec):
        return Smooth(*spec)
    return Table(spec)


def loop_tables(kind: str, amplitude: float, period: float, cycles: int):
    """``[[t, w]]`` tables of w_L and w_R for ``cycles`` cycles of a loop, each leg T/4.

    ``kind`` "square": (w_L, w_R) = (0,0) → (A,0) → (A,A) → (0,A) → (0,0);
    ``kind`` "reciprocal" (out and back): (0,0) → (A,0) → (A,A) → (A,0) → (0,0)."""
    corners = LOOPS[kind]
    wl, wr = [[0.0, 0.0]], [[0.0, 0.0]]
    for n in range(cycles):
        for j, (a, b) in enumerate(corners[1:], start=1):
            t = round(period * (n + j / 4), 12)
            wl.append([t, amplitude * a])
            wr.append([t, amplitude * b])
    return wl, wr


def smooth_stroke(amplitude: float, period: float, lag: float = 0.25):
    """A smooth non-reciprocal stroke starting from rest in the flat state:

        w_L(t) = A/2 (1 − cos(2π t / T)),
        w_R(t) = w_L(t − lag·T) for t ≥ lag·T, 0 before,

    i.e. the right edge repeats the left one a fraction ``lag`` of a cycle later
    (for lag = 1/4, once both move, a circle of radius A/2 about (A/2, A/2) in the
    (w_L, w_R) plane, run in the same sense as the square loop).  Both
    start at zero height with zero velocity, so no impulse acts; w_R'' jumps at
    t = lag·T (a break of the integration, no impulse).  Returns two ``Smooth``."""
    omega = 2 * math.pi / period
    half = amplitude / 2

    def cosine(shift):
        return (
            lambda t: half * (1 - math.cos(omega * (t - shift))),
            lambda t: half * omega * math.sin(omega * (t - shift)),
            lambda t: half * omega**2 * math.cos(omega * (t - shift)),
        )

    def zero(t):
        return 0.0

    return (
        Smooth(*cosine(0.0), time_scale=1 / omega),
        Smooth.pieces(
            [(-math.inf, (zero, zero, zero)), (lag * period, cosine(lag * period))],
            time_scale=1 / omega,
        ),
    )


# --------------------------------------------------------------------------
# Formulation A: middle centre and three link angles
# --------------------------------------------------------------------------


class AngleModel:
    """q = (Y_c, Z_c, θ_L, θ_M, θ_R): the middle link's centre and the link angles.

    A point at distance s ∈ [−ℓ/2, ℓ/2] from the centre of link k is at

        x = c + ∑_j a_kj e_j + s e_k,     e_j = (cos θ_j, sin θ_j),

    with the centre coefficients a_k = (−ℓ/2, −ℓ/2, 0) for the left link,
    (0, 0, 0) for the middle one and (0, ℓ/2, ℓ/2) for the right one.  The
    link's centre moves with V_k = (Ẏ_c, Ż_c) + ∑_j a_kj θ̇_j n_j, n_j = (−sin θ_j,
    cos θ_j), its points with V_k + s θ̇_k n_k.  In the link's own frame,

        V_k·e_k = (cos θ_k, sin θ_k, a_kj sin(θ_k − θ_j)) · q̇  =: Je_k q̇
        V_k·n_k = (−sin θ_k, cos θ_k, a_kj cos(θ_k − θ_j)) · q̇  =: Jn_k q̇

    (e_k·n_j = sin(θ_k − θ_j), n_k·n_j = cos(θ_k − θ_j)), and the centre's
    acceleration at q̈ = 0, b_k = −∑_j a_kj θ̇_j² e_j, has the components
    b_k·e_k = −∑_j a_kj θ̇_j² cos(θ_k − θ_j) and b_k·n_k = ∑_j a_kj θ̇_j² sin(θ_k − θ_j).
    Integrating across the width (∫ s ds = 0, ∫ s² ds = ℓ³/12), with m = μ ℓ L
    and I = m ℓ²/12:

        kinetic energy  ½ ∑_k (m |V_k|² + I θ̇_k²)
        M = m (Jeᵀ Je + Jnᵀ Jn) + I diag(0, 0, 1, 1, 1)
        h = m (Jeᵀ (b·e) + Jnᵀ (b·n))      (a point's −s θ̇_k² e_k integrates to 0)
        R = L ℓ (C₂ Jeᵀ Je + C₃ Jnᵀ Jn) + C₃ L ℓ³/12 diag(0, 0, 1, 1, 1)

    i.e. a link feels the force −L ℓ (C₂ (V·e) e + C₃ (V·n) n) and the moment
    −C₃ L ℓ³/12 θ̇.  The outer edges are the left link at s = −ℓ/2 and the right
    one at s = ℓ/2: x = c + ∑_j a_j e_j with a = (−ℓ, −ℓ/2, 0) and (0, ℓ/2, ℓ),
    so their heights are Z_c + ∑_j a_j sin θ_j."""

    name = "angles"

    def __init__(self, body: Body):
        self.body = body
        l = body.link_width
        self.a_centre = np.array([(-l / 2, -l / 2, 0.0), (0.0, 0.0, 0.0), (0.0, l / 2, l / 2)])
        self.a_edge = np.array([(-l, -l / 2, 0.0), (0.0, l / 2, l)])
        self.spin = np.diag([0.0, 0.0, 1.0, 1.0, 1.0])
        self.q0 = np.array([1.5 * l, 0.0, 0.0, 0.0, 0.0])
        self.translation_y = np.array([1.0, 0.0, 0.0, 0.0, 0.0])

    def _frames(self, q):
        """Rows e_j = (cos θ_j, sin θ_j) and n_j = (−sin θ_j, cos θ_j)."""
        e = np.empty((3, 2))
        np.cos(q[2:5], out=e[:, 0])
        np.sin(q[2:5], out=e[:, 1])
        n = e[:, ::-1] * (-1.0, 1.0)
        return e, n

    def terms(self, q, v):
        """(M, R, h, G, Ġq̇) at (q, q̇)."""
        body = self.body
        l, L, m = body.link_width, body.length, body.link_mass
        th = q[2:5]
        diff = th[:, None] - th[None, :]  # θ_k − θ_j
        S, C = np.sin(diff), np.cos(diff)
        cos, sin = np.cos(th), np.sin(th)
        a = self.a_centre
        Je, Jn = np.empty((3, 5)), np.empty((3, 5))  # rows e_kᵀ J_k, n_kᵀ J_k
        Je[:, 0], Je[:, 1], Je[:, 2:] = cos, sin, a * S
        Jn[:, 0], Jn[:, 1], Jn[:, 2:] = -sin, cos, a * C
        EE, NN = Je.T @ Je, Jn.T @ Jn
        M = m * (EE + NN) + (m * l * l / 12) * self.spin
        R = (L * l) * (
            body.c_across * EE + body.c_normal * NN + (body.c_normal * l * l / 12) * self.spin
        )
        w2 = v[2:5] ** 2
        h = m * (Je.T @ (-(a * C) @ w2) + Jn.T @ ((a * S) @ w2))
        G = self.jacobian(q, cos)
        gamma = -(self.a_edge * w2) @ sin  # Z of the edges' b
        return M, R, h, G, gamma

    def mass(self, q):
        return self.terms(q, np.zeros(5))[0]

    def drag_matrix(self, q):
        return self.terms(q, np.zeros(5))[1]

    def constraint(self, q):
        """g(q) = heights of the outer edges: Z_c + ∑_j a_j sin θ_j."""
        e, _ = self._frames(q)
        return q[1] + self.a_edge @ e[:, 1]

    def jacobian(self, q, cos=None):
        """G = ∂g/∂q = [0, 1, a_L cos θ_L, a_M cos θ_M, a_R cos θ_R] per edge."""
        G = np.zeros((2, 5))
        G[:, 1] = 1.0
        G[:, 2:] = self.a_edge * (np.cos(q[2:5]) if cos is None else cos)
        return G

    def targets(self, wl, wr):
        """Values of g(q) for edge heights (w_L, w_R); ``rates`` maps their rates
        (or accelerations) to those of g."""
        return np.array([wl, wr])

    def rates(self, dwl, dwr):
        return np.array([dwl, dwr])

    def outputs(self, q):
        l = self.body.link_width
        e, _ = self._frames(q)
        c = q[:2]
        corner = c - 0.5 * l * e[1] - l * e[0]
        right = c + 0.5 * l * e[1] + l * e[2]
        centroid = c + (l / 6) * (e[2] - e[0])
        return {
            "corner": corner,
            "right": right,
            "centre": c,
            "angles": q[2:5].copy(),
            "centroid": centroid,
        }


# --------------------------------------------------------------------------
# Formulation B: Cartesian edge/hinge lines with rigid-length constraints
# --------------------------------------------------------------------------


class LineModel:
    """q = (Y₀, Z₀, Y₁, Z₁, Y₂, Z₂, Y₃, Z₃): the outer edges P₀, P₃ and hinges P₁, P₂.

    A point of link k at ξ ∈ [0, 1] is (1 − ξ) P_k + ξ P_{k+1}; integrating over ξ,

        kinetic energy  = (m/6)(|V_k|² + V_k·V_{k+1} + |V_{k+1}|²),
        drag on (P_k, P_{k+1}) = −L ℓ ([[1/3, 1/6], [1/6, 1/3]] ⊗ D_k) (V_k, V_{k+1}),

    D_k = C₂ e eᵀ + C₃ n nᵀ with e = (P_{k+1} − P_k)/|P_{k+1} − P_k|.
    Constraints: ½(|P_{k+1} − P_k|² − ℓ²) = 0 (k = 0, 1, 2), Z₀ = w_L, Z₃ = w_R."""

    name = "lines"

    def __init__(self, body: Body):
        self.body = body
        l = body.link_width
        self.q0 = np.array([0.0, 0.0, l, 0.0, 2 * l, 0.0, 3 * l, 0.0])
        self.translation_y = np.array([1.0, 0.0] * 4)
        pair = np.array([[2.0, 1.0], [1.0, 2.0]]) / 6
        M = np.zeros((8, 8))
        for k in range(3):
            M[2 * k : 2 * k + 4, 2 * k : 2 * k + 4] += body.link_mass * np.kron(pair, np.eye(2))
        self._mass = M
        self._pair_drag = np.array([[1 / 3, 1 / 6], [1 / 6, 1 / 3]])

    def terms(self, q, v):
        """(M, R, h = 0, G, Ġq̇) at (q, q̇); for a length row Ġq̇ = |V_{k+1} − V_k|²."""
        V = v.reshape(4, 2)
        return (
            self._mass,
            self.drag_matrix(q),
            np.zeros(8),
            self.jacobian(q),
            np.concatenate([((V[1:] - V[:-1]) ** 2).sum(1), [0.0, 0.0]]),
        )

    def mass(self, q):
        return self._mass

    def drag_matrix(self, q):
        """R: blocks L ℓ [[1/3, 1/6], [1/6, 1/3]] ⊗ D_k on (P_k, P_{k+1})."""
        b = self.body
        d = np.diff(q.reshape(4, 2), axis=0)
        e = d / np.hypot(d[:, 0], d[:, 1])[:, None]
        n = np.stack([-e[:, 1], e[:, 0]], 1)
        D = (
            b.c_across * e[:, :, None] * e[:, None, :] + b.c_normal * n[:, :, None] * n[:, None, :]
        )  # (3, 2, 2)
        blocks = (
            b.length
            * b.link_width
            * self._pair_drag[None, :, None, :, None]
            * D[:, None, :, None, :]
        )
        blocks = blocks.reshape(3, 4, 4)
        R = np.zeros((8, 8))
        for k in range(3):
            R[2 * k : 2 * k + 4, 2 * k : 2 * k + 4] += blocks[k]
        return R

    def constraint(self, q):
        P = q.reshape(4, 2)
        d = P[1:] - P[:-1]
        return np.concatenate([0.5 * (d * d).sum(1), [P[0, 1], P[3, 1]]])

    def jacobian(self, q):
        P = q.reshape(4, 2)
        G = np.zeros((5, 8))
        for k in range(3):
            d = P[k + 1] - P[k]
            G[k, 2 * k : 2 * k + 2] = -d
            G[k, 2 * k + 2 : 2 * k + 4] = d
        G[3, 1] = 1.0
        G[4, 7] = 1.0
        return G

    def targets(self, wl, wr):
        half_l2 = 0.5 * self.body.link_width**2
        return np.array([half_l2, half_l2, half_l2, wl, wr])

    def rates(self, dwl, dwr):
        return np.array([0.0, 0.0, 0.0, dwl, dwr])

    def outputs(self, q):
        P = q.reshape(4, 2)
        d = P[1:] - P[:-1]
        return {
            "corner": P[0].copy(),
            "right": P[3].copy(),
            "centre": 0.5 * (P[1] + P[2]),
            "angles": np.arctan2(d[:, 1], d[:, 0]),  # in (−π, π]
            "centroid": (P[0] + 2 * P[1] + 2 * P[2] + P[3]) / 6,
        }


MODELS = {"angles": AngleModel, "lines": LineModel}


# --------------------------------------------------------------------------
# The driver
# --------------------------------------------------------------------------


@dataclass
class Leg:
    """Energy bookkeeping between two consecutive kinks t0 < t1 (energies in N·mm).

    ke_before: kinetic energy just before the impulse at t0; impulse_work: work of
    that impulse; constraint_work: work of the edge forces on (t0, t1); dissipation:
    drag dissipation on (t0, t1); ke_end: kinetic energy at t1 before the next
    impulse.  Balance: ke_end − ke_before = impulse_work + constraint_work − dissipation."""

    t0: float
    t1: float
    ke_before: float
    impulse_work: float
    ke_after: float
    constraint_work: float = 0.0
    dissipation: float = 0.0
    ke_end: float = 0.0

    @property
    def imbalance(self) -> float:
        return (self.ke_end - self.ke_before) - (
            self.impulse_work + self.constraint_work - self.dissipation
        )


@dataclass
class Result:
    """Outputs at the requested times (arrays over ``t``; lengths in mm, angles in rad).

    corner_y, corner_z: left outer edge's displacement (reference (0, 0));
    right_y, right_z: right outer edge's displacement (reference (1.5, 0));
    centre_y, centre_z: middle link centre's displacement (reference (0.75, 0));
    angle_middle: middle link's angle about +X, atan2(ΔZ, ΔY) of its direction from
    the left hinge to the right one (model "angles": followed continuously, so
    not wrapped to (−π, π]; model "lines": wrapped);
    angles: (n, 3) angles of the left, middle, right links, likewise;
    centroid_y, centroid_z: displacement of the area-weighted centroid;
    momentum_y: total Y momentum (t·mm/s = N·s); drag_impulse_y: ∫ (drag force
    along Y) dt from 0; dissipation, constraint_work: cumulative from 0 (work of
    impulses included in constraint_work); kinetic_energy (after any impulse at
    that time); legs: per-leg ``Leg`` bookkeeping; max_drift: largest constraint
    residual found (and removed) by a projection; steps: Runge-Kutta steps taken.
    ``summary(t)`` gives the outputs at one time as a dict."""

    t: np.ndarray
    corner_y: np.ndarray
    corner_z: np.ndarray
    right_y: np.ndarray
    right_z: np.ndarray
    centre_y: np.ndarray
    centre_z: np.ndarray
    angle_middle: np.ndarray
    angles: np.ndarray
    centroid_y: np.ndarray
    centroid_z: np.ndarray
    momentum_y: np.ndarray
    drag_impulse_y: np.ndarray
    kinetic_energy: np.ndarray
    dissipation: np.ndarray
    constraint_work: np.ndarray
    legs: list = field(default_factory=list)
    max_drift: float = 0.0
    steps: int = 0
    model: str = "angles"
    overdamped: bool = False

    def at(self, t):
        """Index of the output row at time ``t``."""
        i = int(np.argmin(np.abs(self.t - t)))
        if abs(self.t[i] - t) > 1e-9 * max(1.0, abs(t)):
            raise KeyError(f"no output at t = {t}")
        return i

    def summary(self, t=None) -> dict:
        i = -1 if t is None else self.at(t)
        return {
            "t": float(self.t[i]),
            "corner_y": float(self.corner_y[i]),
            "corner_z": float(self.corner_z[i]),
            "right_y": float(self.right_y[i]),
            "right_z": float(self.right_z[i]),
            "centre_y": float(self.centre_y[i]),
            "centre_z": float(self.centre_z[i]),
            "angle_middle": float(self.angle_middle[i]),
            "angle_left": float(self.angles[i, 0]),
            "angle_right": float(self.angles[i, 2]),
            "centroid_y": float(self.centroid_y[i]),
            "centroid_z": float(self.centroid_z[i]),
        }


def _solve_saddle(A, G, top, bottom):
    """Solve [[A, −Gᵀ], [G, 0]] (x, λ) = (top, bottom)."""
    n, m = A.shape[0], G.shape[0]
    K = np.zeros((n + m, n + m))
    K[:n, :n] = A
    K[:n, n:] = -G.T
    K[n:, :n] = G
    sol = np.linalg.solve(K, np.concatenate([top, bottom]))
    return sol[:n], sol[n:]


class _Integrator:
    """The state and its right-hand side for one model and regime.

    Inertial state y = (q, q̇, D, W, I_Y): coordinates, velocities, dissipated
    energy, work of the constraint forces and drag impulse along Y.
    Overdamped state y = (q, D, W, I_Y)."""

    def __init__(self, model, overdamped):
        self.model, self.overdamped = model, overdamped
        self.n = len(model.q0)

    def split(self, y):
        n = self.n
        if self.overdamped:
            return y[:n], None, y[n:]
        return y[:n], y[n : 2 * n], y[2 * n :]

    def rhs(self, t, y, piece):
        m = self.model
        (fl, dfl, ddfl), (fr, dfr, ddfr) = piece
        q, v, _ = self.split(y)
        if self.overdamped:
            R, G = m.drag_matrix(q), m.jacobian(q)
            v, lam = _solve_saddle(R, G, np.zeros(self.n), m.rates(dfl(t), dfr(t)))
            F = -R @ v
        else:
            M, R, h, G, gamma = m.terms(q, v)
            F = -R @ v
            acc, lam = _solve_saddle(M, G, F - h, m.rates(ddfl(t), ddfr(t)) - gamma)
        # (D, W, I_Y) rates: dissipation −F·q̇, constraint power λ·Gq̇, drag force along Y
        extras = [-F @ v, lam @ (G @ v), m.translation_y @ F]
        return np.concatenate([v, extras] if self.overdamped else [v, acc, extras])

    def project(self, y, t, piece):
        """Put q back on g(q) = w(t) (minimum-norm Gauss-Newton); return the residual."""
        m = self.model
        (fl, _, _), (fr, _, _) = piece
        q, _, _ = self.split(y)
        target = m.targets(fl(t), fr(t))
        r0 = float(np.abs(m.constraint(q) - target).max())
        for _ in range(5):
            r = m.constraint(q) - target
            if np.abs(r).max() < 1e-15:
                break
            G = m.jacobian(q)
            q -= G.T @ np.linalg.solve(G @ G.T, r)
        return r0

    def impulse(self, y, t, piece):
        """M Δq̇ = Gᵀ Λ, G q̇⁺ = ẇ⁺; return the impulse's work Λ · G (q̇⁻ + q̇⁺)/2."""
        if self.overdamped:
            return 0.0
        m = self.model
        (_, dfl, _), (_, dfr, _) = piece
        q, v, _ = self.split(y)
        M, G = m.mass(q), m.jacobian(q)
        dw = m.rates(dfl(t), dfr(t))
        before = G @ v
        MinvGt = np.linalg.solve(M, G.T)
        Lam = np.linalg.solve(G @ MinvGt, dw - before)
        v += MinvGt @ Lam
        return float(Lam @ (before + G @ v) / 2)

    def stabilize(self, y, t, piece):
        """Projection after steps: positions onto g(q) = w(t), velocities onto
        G q̇ = ẇ(t) (the least-kinetic-energy correction, its work booked with the
        constraint work).  Returns the position residual removed."""
        drift = self.project(y, t, piece)
        y[-2] += self.impulse(y, t, piece)
        return drift

    def kinetic_energy(self, y):
        if self.overdamped:
            return 0.0
        q, v, _ = self.split(y)
        return float(0.5 * v @ self.model.mass(q) @ v)

    def momentum_y(self, y):
        if self.overdamped:
            return 0.0
        q, v, _ = self.split(y)
        return float(self.model.translation_y @ self.model.mass(q) @ v)


def _rk4(f, t0, t1, y, steps, piece, project, every=8):
    """Classical Runge-Kutta steps from t0 to t1; ``project(t, y)`` puts the state
    back onto the constraints (in place) every ``every`` steps and at t1."""
    h = (t1 - t0) / steps
    for i in range(steps):
        t = t0 + i * h
        k1 = f(t, y, piece)
        k2 = f(t + h / 2, y + (h / 2) * k1, piece)
        k3 = f(t + h / 2, y + (h / 2) * k2, piece)
        k4 = f(t + h, y + h * k3, piece)
        y = y + (h / 6) * (k1 + 2 * k2 + 2 * k3 + k4)
        if (i + 1) % every == 0 or i + 1 == steps:
            project(t0 + (i + 1) * h, y)
    return y


def _merge(values, prefer=()):
    """Sorted values with near-duplicates (1e-12 relative) merged; a value close to
    one of ``prefer`` is replaced by it (so output times snap onto kinks)."""
    out = []
    for v in sorted(float(v) for v in values):
        v = next((p for p in prefer if abs(p - v) <= 1e-12 * max(1.0, abs(v))), v)
        if not out or abs(v - out[-1]) > 1e-12 * max(1.0, abs(v)):
            out.append(v)
    return out


def simulate(
    w_left,
    w_right,
    t_end,
    *,
    density=1.0e-8,
    thickness=0.2,
    link_width=0.5,
    length=5.0,
    drag=DRAG,
    times=None,
    max_step=None,
    model="angles",
    overdamped=None,
) -> Result:
    """Move the three-link body with the outer edges' heights prescribed.

    ``w_left``, ``w_right``: a ``[[t, w], ...]`` table, a ``(w, w', w'')`` triple of
    callables, or a ``Table`` / ``Smooth`` (e.g. from ``smooth_stroke``).
    ``times``: output times in [0, t_end] (default: 0, every kink and t_end).
    ``density`` 0 (or ``overdamped=True``) selects the overdamped drag balance.
    ``max_step``: largest Runge-Kutta step (default: 1/40 of the shortest interval
    between kinks, at most 1/50 of a ``Smooth`` history's ``time_scale`` (t_end/1000
    if it has none) and a quarter of the inertial time μ / max(C₂, C₃); this keeps
    the integration error of the outputs near 1e-9 (the loops) or 1e-8 (the smooth
    stroke) of their range).
    ``model``: "angles" (``AngleModel``) or "lines" (``LineModel``).
    Starts at rest and flat at t = 0 (the first velocity is reached by an impulse).
    A kink at ``t_end`` itself is not applied: the outputs at ``t_end`` are the
    state arriving there.  Returns a ``Result``."""
    t_end = float(t_end)
    body = Body(
        link_width=link_width, length=length, thickness=thickness, density=density, drag=tuple(drag)
    )
    if overdamped is None:
        overdamped = density == 0.0
    if not overdamped and density <= 0.0:
        raise ValueError("the inertial model needs a positive density")
    mdl = MODELS[model](body)
    hl, hr = as_history(w_left), as_history(w_right)
    if max(abs(h.piece(0.0)[0](0.0)) for h in (hl, hr)) > 1e-12:
        raise ValueError("the body starts flat: w_L(0) = w_R(0) = 0")
    tol = 1e-12 * max(1.0, t_end)
    kinks = [
        t for t in _merge([0.0, *(t for t in hl.breaks + hr.breaks if t > 0.0)]) if t < t_end - tol
    ]  # a kink at t_end (to rounding) is not applied
    ends = kinks + [t_end]
    times = _merge(ends if times is None else times, ends)
    if times[0] < 0 or times[-1] > t_end:
        raise ValueError("output times must lie in [0, t_end]")
    stops = _merge(ends + times, ends)
    if max_step is None:
        max_step = float(np.diff(ends).min()) / 40
        for h in (hl, hr):
            if isinstance(h, Smooth):
                max_step = min(max_step, h.time_scale / 50 if h.time_scale else t_end / 1000)
        if not overdamped:
            max_step = min(max_step, body.inertial_time / 4)

    integ = _Integrator(mdl, overdamped)
    y = np.concatenate([mdl.q0, np.zeros(3 if overdamped else len(mdl.q0) + 3)])
    n_state = len(y) - 3  # y[n_state:] = (D, W, I_Y)
    rows, legs = [], []
    impulse_total, drift, steps = 0.0, 0.0, 0

    def close_leg(t):
        leg = legs[-1]
        leg.t1 = t
        leg.ke_end = integ.kinetic_energy(y)
        leg.dissipation = float(y[n_state] - leg.dissipation)  # running totals at the start
        leg.constraint_work = float(y[n_state + 1] - leg.constraint_work)

    # Between stops: Runge-Kutta steps, projected back onto the constraints every
    # few steps and at the stop (with the motion of the interval, i.e. onto ẇ⁻).
    # At a kink: the impulse onto ẇ⁺; a leg of the energy bookkeeping ends and
    # the next one starts.
    for i, t0 in enumerate(stops):
        last = i == len(stops) - 1
        t1 = t0 + 1.0 if last else stops[i + 1]
        piece = (hl.piece(0.5 * (t0 + t1)), hr.piece(0.5 * (t0 + t1)))  # motion after t0
        if legs and (t0 in kinks or last):
            close_leg(t0)
        if t0 in kinks and not last:
            ke = integ.kinetic_energy(y)
            work = integ.impulse(y, t0, piece)
            impulse_total += work
            legs.append(
                Leg(
                    t0,
                    t1,
                    ke,
                    work,
                    integ.kinetic_energy(y),
                    constraint_work=y[n_state + 1],
                    dissipation=y[n_state],
                )
            )
        if t0 in times:
            o = mdl.outputs(integ.split(y)[0])
            rows.append(
                (
                    t0,
                    o,
                    integ.momentum_y(y),
                    y[n_state + 2],
                    integ.kinetic_energy(y),
                    y[n_state],
                    y[n_state + 1] + impulse_total,
                )
            )
        if last:
            break
        n = max(1, int(math.ceil((t1 - t0) / max_step - 1e-9)))

        def stabilize(t, y):
            nonlocal drift
            drift = max(drift, integ.stabilize(y, t, piece))

        y = _rk4(integ.rhs, t0, t1, y, n, piece, stabilize)
        steps += n

    def col(key):
        return np.array([r[1][key] for r in rows])

    corner, right, centre = col("corner"), col("right"), col("centre")
    angles, centroid = col("angles"), col("centroid")
    y_ref = 1.5 * link_width  # reference Y of the middle centre and centroid
    return Result(
        t=np.array([r[0] for r in rows]),
        corner_y=corner[:, 0],
        corner_z=corner[:, 1],
        right_y=right[:, 0] - 3 * link_width,
        right_z=right[:, 1],
        centre_y=centre[:, 0] - y_ref,
        centre_z=centre[:, 1],
        angle_middle=angles[:, 1],
        angles=angles,
        centroid_y=centroid[:, 0] - y_ref,
        centroid_z=centroid[:, 1],
        momentum_y=np.array([r[2] for r in rows]),
        drag_impulse_y=np.array([r[3] for r in rows]),
        kinetic_energy=np.array([r[4] for r in rows]),
        dissipation=np.array([r[5] for r in rows]),
        constraint_work=np.array([r[6] for r in rows]),
        legs=legs,
        max_drift=drift,
        steps=steps,
        model=model,
        overdamped=overdamped,
    )


# --------------------------------------------------------------------------
# Figures for the FE tests:  python3 tests/rigid_links.py
# --------------------------------------------------------------------------


def report(amplitude=0.1, period=0.4, cycles=9):
    """Print the nine-cycle inertial outputs of the three strokes and the
    overdamped displacement per cycle (the FE test candidates)."""
    import time

    marks = [period * k for k in range(1, cycles + 1)]
    strokes = {
        "reciprocal (case I)": loop_tables("reciprocal", amplitude, period, cycles),
        "square": loop_tables("square", amplitude, period, cycles),
        "smooth, w_R lags T/4": smooth_stroke(amplitude, period),
    }
    keys = [
        "corner_y",
        "corner_z",
        "centre_y",
        "centre_z",
        "angle_middle",
        "angle_left",
        "angle_right",
        "centroid_y",
        "centroid_z",
    ]
    for name, (wl, wr) in strokes.items():
        for density in (1.0e-8, 0.0):
            start = time.perf_counter()
            r = simulate(wl, wr, period * cycles, density=density, times=[0.0, *marks])
            wall = time.perf_counter() - start
            label = f"{name}, ρ = {density:g}"
            print(f"\n{label}: {r.steps} RK4 steps, {wall:.2f} s, drift {r.max_drift:.1e}")
            s = r.summary()
            print("  after %d cycles: " % cycles + ", ".join(f"{k} {s[k]:+.6e}" for k in keys))
            print("  per cycle (t, corner Y, centre Y, centre Z, middle angle, centroid Y):")
            for i, t in enumerate(r.t[1:], start=1):
                print(
                    f"    {t:4.1f} {r.corner_y[i]:+.6e} {r.centre_y[i]:+.6e} "
                    f"{r.centre_z[i]:+.6e} {r.angle_middle[i]:+.6e} {r.centroid_y[i]:+.6e}"
                )


if __name__ == "__main__":
    report()
