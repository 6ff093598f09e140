"""Time-stepping schemes (docs/model.md §6) as coefficient sets.

Each scheme says how the velocity ``v_{n+1}`` and the inertia-weighted
acceleration ``a_{n+1-α_m}`` depend on the unknown displacement ``u_{n+1}`` and
the stored state ``(u_n, v_n, a_n)``, all linearly:

    v_{n+1}      = cv (u_{n+1} − u_n) + cv_v v_n + cv_a a_n
    a_{n+1−α_m}  = ca (u_{n+1} − u_n) + ca_v v_n + ca_a a_n

and with which weight ``α_f`` the non-inertial forces of the last step enter
the residual

    R = M a_{n+1−α_m} + (1 − α_f) F(u_{n+1}, v_{n+1}, d_{n+1}, t_{n+1}) + α_f F_n
        + F_end(u_{n+1})

(``F_end``: the contact forces, taken in full at the step's end).

Averaging *forces* rather than states is what lets the director be updated
multiplicatively (there is no meaningful "average director").  Which scheme a scene
runs (``time.scheme = "auto"`` resolved) is a scene rule: rftfem.scene.time_rules.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import numpy as np


@dataclass(frozen=True)
class Coefficients:
    cv: float = 0.0
    cv_v: float = 0.0
    cv_a: float = 0.0
    ca: float = 0.0
    ca_v: float = 0.0
    ca_a: float = 0.0
    alpha_f: float = 0.0
    #: the weight of ``a_n`` in ``a_{n+1−α_m}`` (prescribed motions' exact rates, motion.py)
    alpha_m: float = 0.0
    #: the step (0: none, as for the initial acceleration); contact friction's slip rate
    dt: float = 0.0
    #: the weight of the forces taken at the step's end (``Effect.end_forces``): 0 only
    #: where the step's tangent stands for the mass matrix (impulses.py)
    end_weight: float = 1.0


class Scheme:
    """Base class: a named scheme giving coefficients for a step size ``dt``."""

    name = "static"
    has_inertia = False
    has_velocity = False
    #: order of accuracy in time (0: no time error to control)
    order = 0
    #: the local error is estimated from the distance of a converged step to a
    #: prediction made from this many past steps (1: the last rate carried on,
    #: 2: the last two extrapolated), times ``error_fraction`` (Milne's device:
    #: C / (C_P − C), C the scheme's error constant, C_P the prediction's)
    error_predictor = 2
    error_fraction = 1.0

    def coefficients(self, dt: float) -> Coefficients:
        return Coefficients(dt=dt)

    def update(
        self, du: np.ndarray, v_n: np.ndarray, a_n: np.ndarray, dt: float
    ) -> tuple[np.ndarray, np.ndarray]:
        """``(v_{n+1}, a_{n+1})`` after convergence, from ``du = u_{n+1} − u_n`` (arrays)."""
        return 0.0 * v_n, 0.0 * a_n


class Static(Scheme):
    """Load stepping: no inertia, no velocity (drag-free and inertia-free scenes)."""


class ArcLength(Static):
    """Static path-following: the load factor λ is an unknown (arclength.py)."""

    name = "arc-length"


class BackwardEuler(Scheme):
    """First-order implicit scheme for scenes without inertia: ``v_{n+1} = (u_{n+1} − u_n)/dt``."""

    name = "backward-euler"
    has_velocity = True
    order = 1
    # the last rate is v_n, the velocity at the end of the last step:
    # u^P = u_n + h v_n has C_P = ½ against the scheme's C = −½
    error_predictor = 1
    error_fraction = 0.5

    def coefficients(self, dt: float) -> Coefficients:
        return Coefficients(cv=1.0 / dt, dt=dt)

    def update(
        self, du: np.ndarray, v_n: np.ndarray, a_n: np.ndarray, dt: float
    ) -> tuple[np.ndarray, np.ndarray]:
        return du / dt, 0.0 * a_n


class BDF2(Scheme):
    """Second-order backward differentiation for scenes without inertia, on variable steps.

    With ``h`` this step, ``r = h / h_n`` its ratio to the last accepted one and
    ``w_n = (u_n − u_{n−1}) / h_n`` the last step's mean velocity:

        v_{n+1} = (1 + 2r)/(1 + r) (u_{n+1} − u_n)/h − r/(1 + r) w_n

    (``3/2 Δu/h − ½ w_n`` at constant steps).  ``w_n`` is kept in the state's
    acceleration slot, unused without inertia.  The first step, with no history,
    is backward Euler; a halved step (r = ½) and the doubling back (r = 2) stay
    within the zero-stability bound r < 1 + √2.
    """

    name = "bdf2"
    has_velocity = True
    order = 2
    error_fraction = 2 / 11  # C = −2/9

    def __init__(self):
        #: the last accepted step (None before the first)
        self.dt_prev: float | None = None

    def coefficients(self, dt: float) -> Coefficients:
        if self.dt_prev is None:
            return Coefficients(cv=1.0 / dt, dt=dt)
        r = dt / self.dt_prev
        return Coefficients(cv=(1 + 2 * r) / ((1 + r) * dt), cv_a=-r / (1 + r), dt=dt)

    def update(
        self, du: np.ndarray, v_n: np.ndarray, a_n: np.ndarray, dt: float
    ) -> tuple[np.ndarray, np.ndarray]:
        c = self.coefficients(dt)
        self.dt_prev = dt
        return c.cv * du + c.cv_a * a_n, du / dt


class GeneralizedAlpha(Scheme):
    """Generalized-α of Chung & Hulbert (1993) with Newmark's relations.

    From the spectral radius at infinity ``ρ∞ ∈ [0, 1]``:
    ``α_m = (2ρ∞−1)/(ρ∞+1)``, ``α_f = ρ∞/(ρ∞+1)``, ``γ = ½ − α_m + α_f``,
    ``β = ¼(1 − α_m + α_f)²``.  ρ∞ = 1 is the trapezoidal rule (no dissipation).
    """

    name = "generalized-alpha"
    has_inertia = True
    has_velocity = True
    order = 2
    error_fraction = 1 / 11  # C = 1/12 of the trapezoidal rule (ρ∞ = 1)

    def __init__(self, rho_inf: float = 0.9):
        r = float(rho_inf)
        self.alpha_m = (2 * r - 1) / (r + 1)
        self.alpha_f = r / (r + 1)
        self._set_newmark()

    def _set_newmark(self):
        self.gamma = 0.5 - self.alpha_m + self.alpha_f
        self.beta = 0.25 * (1 - self.alpha_m + self.alpha_f) ** 2

    def _newmark(self, dt):
        """Newmark's relations as coefficients on (u − u_n, v_n, a_n):
        ``a_{n+1} = (u − u_n)/(β dt²) − v_n/(β dt) − (½ − β)/β a_n`` and
        ``v_{n+1} = v_n + dt((1 − γ) a_n + γ a_{n+1})``."""
        b, g = self.beta, self.gamma
        a = (1 / (b * dt**2), -1 / (b * dt), -(0.5 - b) / b)
        v = (g * dt * a[0], 1 + g * dt * a[1], dt * (1 - g) + g * dt * a[2])
        return v, a

    def coefficients(self, dt: float) -> Coefficients:
        (v_u, v_v, v_a), (a_u, a_v, a_a) = self._newmark(dt)
        am = self.alpha_m
        # a_{n+1−α_m} = (1 − α_m) a_{n+1} + α_m a_n
        return Coefficients(
            cv=v_u,
            cv_v=v_v,
            cv_a=v_a,
            ca=(1 - am) * a_u,
            ca_v=(1 - am) * a_v,
            ca_a=(1 - am) * a_a + am,
            alpha_f=self.alpha_f,
            alpha_m=am,
            dt=dt,
        )

    def update(
        self, du: np.ndarray, v_n: np.ndarray, a_n: np.ndarray, dt: float
    ) -> tuple[np.ndarray, np.ndarray]:
        (v_u, v_v, v_a), (a_u, a_v, a_a) = self._newmark(dt)
        return v_u * du + v_v * v_n + v_a * a_n, a_u * du + a_v * v_n + a_a * a_n


class HHT(GeneralizedAlpha):
    """Hilber-Hughes-Taylor α (the paper's choice, α = −0.05): ``α_m = 0``, ``α_f = −α``,
    ``γ = ½ − α``, ``β = ¼(1 − α)²``."""

    name = "hht"

    def __init__(self, alpha: float = -0.05):
        self.alpha_m = 0.0
        self.alpha_f = -float(alpha)
        self._set_newmark()  # γ = ½ + α_f, β = ¼(1 + α_f)²


def make_scheme(time_section: dict) -> Scheme:
    """The scheme named by a (validated, resolved) ``[time]`` section."""
    name = time_section["scheme"]
    if name == "generalized-alpha":
        return GeneralizedAlpha(time_section.get("rho_inf", 0.9))
    if name == "hht":
        return HHT(time_section.get("alpha", -0.05))
    if name == "backward-euler":
        return BackwardEuler()
    if name == "bdf2":
        return BDF2()
    if name == "static":
        return Static()
    if name == "arc-length":
        return ArcLength()
    raise ValueError(f"unknown time scheme {name!r}")
