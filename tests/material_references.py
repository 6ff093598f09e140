"""Independent reference solutions (numpy/scipy only) for shell-code tests.

Beam-type references: tapered cantilevers, the large-deflection elastica with
variable stiffness, bending stiffness of a rotated orthotropic layer, and the
optimal thickness profile of a clamped magnetic strip.  Plate references
(clamped orthotropic rectangle) live in ``plate_references.py``; both are checked
against literature values and closed forms in ``test_material_references.py``.

Conventions: x runs along the beam from the clamp (x = 0) to the free end
(x = L); ``width`` is w; "thickness" is t; callables are functions of x.
"""

from __future__ import annotations

import warnings

import numpy as np
from scipy import integrate, optimize

RTOL = 1e-12


def _fun(v):
    """Return ``v`` as a function of x (numbers become constants)."""
    return v if callable(v) else (lambda x, c=float(v): c)


def _stiffness(width, E, thickness, plate, nu):
    """EI(x) = E'(x) w t(x)^3 / 12 with E' = E (narrow) or E/(1-nu^2) (plate)."""
    Ef, tf = _fun(E), _fun(thickness)
    k = 1.0 / (1.0 - nu * nu) if plate else 1.0
    return lambda x: k * Ef(x) * width * tf(x) ** 3 / 12.0


def _quad(f, a, b, points=None):
    inner = None if points is None else [p for p in points if a < p < b]
    val, _ = integrate.quad(f, a, b, epsabs=0.0, epsrel=RTOL, limit=500, points=inner or None)
    return val


def tapered_tip_deflection(P, L, width, E, thickness, plate=False, nu=0.0, points=None):
    """Small-deflection tip deflection of a cantilever under a tip force P.

        delta = int_0^L P (L - x)^2 / EI(x) dx,   EI = E(x) w t(x)^3 / 12.

    A *narrow* strip (free long edges, anticlastic curvature unrestrained) has
    EI = E w t^3/12.  A *wide* plate strip (cylindrical bending, kappa_yy = 0)
    has EI = E w t^3 / (12 (1 - nu^2)); select it with ``plate=True`` and
    ``nu``.  E and thickness may be numbers or callables of x; pass
    ``points`` (interior break points) if they jump.
    """
    EI = _stiffness(width, E, thickness, plate, nu)
    return _quad(lambda x: P * (L - x) ** 2 / EI(x), 0.0, L, points)


def tapered_tip_rotation(P, L, width, E, thickness, plate=False, nu=0.0, points=None):
    """Small-deflection tip rotation under a tip force P:
    theta_L = int_0^L P (L - x) / EI(x) dx  (EI as in tapered_tip_deflection)."""
    EI = _stiffness(width, E, thickness, plate, nu)
    return _quad(lambda x: P * (L - x) / EI(x), 0.0, L, points)


def tapered_deflection_gradient(P, L, width, E, thickness, edges, plate=False, nu=0.0):
    """d(delta)/d(t_i) for a uniform thickness change on [edges[i], edges[i+1]]:

        g_i = -3 int_{e_i}^{e_{i+1}} P (L - x)^2 * 12 / (E'(x) w t(x)^4) dx,

    from d(1/t^3)/dt = -3/t^4 (E' = E, or E/(1-nu^2) with plate=True).
    Returns an array of len(edges) - 1.
    """
    Ef, tf = _fun(E), _fun(thickness)
    k = 1.0 / (1.0 - nu * nu) if plate else 1.0
    g = lambda x: -3.0 * P * (L - x) ** 2 * 12.0 / (k * Ef(x) * width * tf(x) ** 4)
    e = np.asarray(edges, dtype=float)
    return np.array([_quad(g, e[i], e[i + 1]) for i in range(len(e) - 1)])


# --------------------------------------------------------------------------
# Large-deflection cantilever (elastica) with variable EI
# --------------------------------------------------------------------------


def nonuniform_elastica(P, L, EI, n=1, points=()):
    """Inextensible elastica of a cantilever under a dead tip load P (+y).

    Arc length s from the clamp; theta(s) = angle of the tangent to x.
    With the internal moment M(s) = P (x(L) - x(s)) (counter-clockwise
    positive, bends toward +y for P > 0):

        theta' = M / EI(s),  M' = -P cos(theta),  x' = cos(theta),
        y' = sin(theta);     theta(0) = 0, x(0) = y(0) = 0,  M(L) = 0.

    Shooting on M(0) in [0, |P| L] (brentq); each shot is a DOP853 solve
    (rtol 1e-12) restarted on n equal sub-intervals and at ``points`` so that
    jumps of a piecewise EI are never stepped over.  EI: number or callable.
    Returns (x(L) - L, y(L), theta(L)).
    """
    if P == 0:
        return 0.0, 0.0, 0.0
    sgn, Pa = np.sign(P), abs(P)
    EIf = _fun(EI)
    br = np.unique(
        np.concatenate([np.linspace(0.0, L, int(n) + 1), [p for p in points if 0 < p < L]])
    )
    atol = 1e-14 * np.array([1.0, Pa * L, L, L])

    def shoot(m0):
        z = np.array([0.0, m0, 0.0, 0.0])
        for a, b in zip(br[:-1], br[1:]):
            eps = 1e-9 * (b - a)

            def rhs(s, u, a=a, b=b, eps=eps):
                th, M = u[0], u[1]
                EIs = EIf(min(max(s, a + eps), b - eps))
                return [M / EIs, -Pa * np.cos(th), np.cos(th), np.sin(th)]

            sol = integrate.solve_ivp(rhs, (a, b), z, method="DOP853", rtol=RTOL, atol=atol)
            z = sol.y[:, -1]
        return z

    m0 = optimize.brentq(
        lambda m: shoot(m)[1], 0.0, Pa * L, xtol=1e-15 * Pa * L, rtol=4 * np.finfo(float).eps
    )
    th, _, x, y = shoot(m0)
    return x - L, sgn * y, sgn * th


def uniform_elastica_elliptic(alpha):
    """Exact uniform elastica via the first integral (independent of shooting).

    EI theta'' = -P cos(theta) gives theta'^2 = 2 k^2 (sin th0 - sin theta)
    with k^2 = P/EI and th0 = theta(L).  Then
        sqrt(alpha) = int_0^th0 d(theta) / sqrt(2 (sin th0 - sin theta)),
        x(L)/L = sqrt(2 sin th0 / alpha),
        y(L)/L = alpha^-1/2 int_0^th0 sin(theta) d(theta)/sqrt(2(sin th0 - sin theta)),
    with alpha = P L^2/EI.  The end singularity is removed with
    theta = th0 - v^2 and 2 (sin th0 - sin theta) = 4 cos(th0 - v^2/2)
    sin(v^2/2), so the integrand is f(theta) sqrt(2 / (cos(th0 - v^2/2)
    sinc(v^2/2))) on 0 <= v <= sqrt(th0).  Returns (1 - x/L, y/L, th0).
    """

    def integral(th0, f):
        g = lambda v: (
            f(th0 - v * v) * np.sqrt(2.0 / (np.cos(th0 - v * v / 2) * np.sinc(v * v / (2 * np.pi))))
        )
        return _quad(g, 0.0, np.sqrt(th0))

    one = lambda th: 1.0
    with warnings.catch_warnings():  # bracket end near pi/2: sign only
        warnings.simplefilter("ignore", integrate.IntegrationWarning)
        th0 = optimize.brentq(
            lambda t: integral(t, one) - np.sqrt(alpha), 1e-9, np.pi / 2 - 1e-9, xtol=1e-15
        )
    xL = np.sqrt(2.0 * np.sin(th0) / alpha)
    yL = integral(th0, np.sin) / np.sqrt(alpha)
    return 1.0 - xL, yL, th0


# --------------------------------------------------------------------------
# Orthotropic layer
# --------------------------------------------------------------------------


def orthotropic_D(E1, E2, G12, nu12, t, angle):
    """Bending stiffness D (3x3) of one orthotropic plane-stress layer.

    Material axes: Q = 1/(1 - nu12 nu21) [[E1, nu21 E1, 0],
    [nu12 E2, E2, 0], [0, 0, (1 - nu12 nu21) G12]],  nu21 = nu12 E2/E1.
    Fibre axis 1 at ``angle`` (rad) from x toward y, c = cos, s = sin.  With
    engineering strains e = (e_xx, e_yy, g_xy) the material strains are
    e' = T e,  T = [[c^2, s^2, cs], [s^2, c^2, -cs], [-2cs, 2cs, c^2 - s^2]],
    and energy invariance gives Qbar = T^T Q T.  D = Qbar t^3/12, so that
    M = D kappa with kappa = (k_xx, k_yy, 2 k_xy).
    """
    nu21 = nu12 * E2 / E1
    d = 1.0 - nu12 * nu21
    Q = np.array([[E1 / d, nu21 * E1 / d, 0.0], [nu12 * E2 / d, E2 / d, 0.0], [0.0, 0.0, G12]])
    c, s = np.cos(angle), np.sin(angle)
    T = np.array(
        [[c * c, s * s, c * s], [s * s, c * c, -c * s], [-2 * c * s, 2 * c * s, c * c - s * s]]
    )
    return T.T @ Q @ T * t**3 / 12.0


def narrow_strip_curvatures(E1, E2, G12, nu12, t, angle, moment_per_width):
    """Narrow strip along x bent by M_xx = M about y, free long edges
    (M_yy = M_xy = 0):  kappa = D^-1 (M, 0, 0).  Returns (k_xx, k_yy, 2 k_xy);
    a nonzero 2 k_xy is the bending-twisting coupling of an off-axis layer."""
    D = orthotropic_D(E1, E2, G12, nu12, t, angle)
    return tuple(np.linalg.solve(D, [moment_per_width, 0.0, 0.0]))


def wide_plate_curvature(E1, E2, G12, nu12, t, angle, moment_per_width):
    """Cylindrical bending of a wide plate (k_yy = 0 and k_xy = 0 enforced by
    the surroundings): k_xx = M / D11."""
    return moment_per_width / orthotropic_D(E1, E2, G12, nu12, t, angle)[0, 0]


# --------------------------------------------------------------------------
# Magnetic strip: optimal thickness distribution
# --------------------------------------------------------------------------
#
# Couple per length c(x) = M0 B w t(x); bending moment m(x) = int_x^L c ds;
# EI = E w t^3/12.  With mt(x) = int_x^L t ds and a kernel k(x)
# (k = 1: tip rotation, k = L - x: tip deflection),
#     response = (12 M0 B / E) * J[t],   J[t] = int_0^L mt(x) k(x) / t(x)^3 dx.
# Swapping the order, J = int_0^L t(s) G(s) ds with G(s) = int_0^s k/t^3 dx,
# so the first variation is
#     dJ/dt(s) = g(s) = G(s) - 3 mt(s) k(s) / t(s)^4.
# Maximising J with int t = tbar L and tmin <= t <= tmax (multiplier lam):
#     g(s) = lam where tmin < t < tmax,  g >= lam where t = tmax,
#     g <= lam where t = tmin.
# g is most negative at the root (large mt, G = 0) and positive at the tip
# (mt = 0), so tmin sits at the clamp and tmax toward the free end: the
# bang-bang profile t = tmin on [0, a), tmax on (a, L], with
# a = L (tmax - tbar)/(tmax - tmin) fixed by the mass.  There g is
# increasing on both parts and jumps up at a, so the conditions hold with
# any lam in [g(a-), g(a+)].
#
# It is the *global* maximum (J is not concave; SLSQP also stops at other
# KKT points).  Proof: 1/t^3 is convex, so on [tmin, tmax] it lies below its
# chord c(t) = alpha - beta t (equality at the bounds), and since mt k >= 0,
#     J[t] <= Jr[t] = int mt k (alpha - beta t) dx.
# With t = -mt', int k t mt = k(0) (tbar L)^2/2 + 1/2 int k' mt^2, so
#     Jr[t] = int mt (alpha k + beta |k'| mt / 2) dx - beta k(0) (tbar L)^2/2
# for k' <= 0 (both kernels), which grows with mt pointwise.  Every
# admissible t has mt(x) <= min(tmax (L - x), tbar L - tmin x) = mt of the
# bang-bang profile, where J = Jr.  Hence J[t] <= J[bang-bang].  A
# piecewise-constant design is an admissible t, so the n-cell optimum is
# <= the bang-bang value, with equality when a falls on a cell edge.
#
# Discretisation: n cells of length h, t_i constant, S_i = h sum_{j>=i} t_j.
# On cell i (u = x_{i+1} - x): mt = S_{i+1} + t_i u, so
#     J = sum_i (S_{i+1} A_i + t_i B_i) / t_i^3,
# A_i = int_cell k dx, B_i = int_cell u k dx, and
#     dJ/dt_k = -3 (S_{k+1} A_k + t_k B_k)/t_k^4 + B_k/t_k^3
#               + h sum_{i<k} A_i / t_i^3.


def _strip_weights(L, n, kind):
    h = L / n
    if kind == "rotation":
        return h, np.full(n, h), np.full(n, h * h / 2)
    R = L - h * np.arange(1, n + 1)  # L - x_{i+1}
    return h, R * h + h * h / 2, R * h * h / 2 + h**3 / 3


def magnetic_strip_coefficient(t_values, L, kind="rotation"):
    """J[t] for piecewise-constant t on n equal cells (see notes above);
    kind = 'rotation' (k = 1) or 'deflection' (k = L - x)."""
    J, _ = _strip_objective(np.asarray(t_values, float), L, kind)
    return J


def _strip_objective(t, L, kind):
    n = len(t)
    h, A, B = _strip_weights(L, n, kind)
    S_next = h * (np.cumsum(t[::-1])[::-1] - t)  # S_{i+1}
    J = np.sum((S_next * A + t * B) / t**3)
    inner = np.concatenate([[0.0], np.cumsum(A / t**3)[:-1]])
    grad = -3 * (S_next * A + t * B) / t**4 + B / t**3 + h * inner
    return J, grad


def _slsqp(L, tbar, tmin, tmax, kind, u0):
    """One SLSQP run from u0 = t/tbar (objective scaled by the uniform J)."""
    n = len(u0)
    scale = magnetic_strip_coefficient(np.full(n, tbar), L, kind)

    def f(u):
        J, g = _strip_objective(u * tbar, L, kind)
        return -J / scale, -g * tbar / scale

    cons = {"type": "eq", "fun": lambda u: np.mean(u) - 1.0, "jac": lambda u: np.full(n, 1.0 / n)}
    with warnings.catch_warnings():  # SLSQP's harmless bound clipping
        warnings.filterwarnings("ignore", "Values in x were outside bounds")
        return optimize.minimize(
            f,
            u0,
            jac=True,
            method="SLSQP",
            bounds=[(tmin / tbar, tmax / tbar)] * n,
            constraints=[cons],
            options={"ftol": 1e-15, "maxiter": 2000},
        )


def _strip_optimum(L, tbar, tmin, tmax, n, kind):
    x = (np.arange(n) + 0.5) / n
    if n > 40:  # continuation: refine the optimum of the half-size grid
        tc, _ = _strip_optimum(L, tbar, tmin, tmax, n // 2, kind)
        u0 = tc[np.minimum((x * len(tc)).astype(int), len(tc) - 1)] / tbar
        starts = (u0 / np.mean(u0),)
    else:  # plain starts, best kept (the problem is not concave)
        ramp = 0.5 * (x - 0.5) * (tmax - tmin) / tbar
        starts = (np.ones(n), 1.0 + ramp, 1.0 - ramp)
    best = min((_slsqp(L, tbar, tmin, tmax, kind, u0) for u0 in starts), key=lambda r: r.fun)
    t = np.clip(best.x, tmin / tbar, tmax / tbar) * tbar
    return t, magnetic_strip_coefficient(t, L, kind)


def magnetic_strip_thickness_optimum(L, tbar, tmin, tmax, n):
    """Thickness t(x) (n equal cells) maximising the tip rotation
        theta_L = (12 M0 B / E) int_0^L (int_x^L t ds) / t(x)^3 dx
    at fixed mass int t = tbar L, tmin <= t <= tmax (SLSQP, analytic
    gradient; n <= 40: best of three plain starts, n > 40: refined from the
    n//2 optimum).  First variation g(s) = int_0^s t^-3 dx - 3 mt(s)/t(s)^4;
    t = tmin where g < lam, tmax where g > lam.  The optimum is t = tmin on
    [0, a), tmax on (a, L] (globally, see the module notes; bang_bang_
    coefficients).  Returns (t_values, theta_coefficient)."""
    return _strip_optimum(L, tbar, tmin, tmax, n, "rotation")


def magnetic_strip_deflection_optimum(L, tbar, tmin, tmax, n):
    """As magnetic_strip_thickness_optimum, maximising the tip deflection
        w_L = (12 M0 B / E) int_0^L (int_x^L t ds) (L - x) / t(x)^3 dx;
    g(s) = int_0^s (L - x) t^-3 dx - 3 mt(s) (L - x)/t(s)^4.  Same optimal
    profile (tmin at the clamp, tmax from a to the tip).
    Returns (t_values, deflection_coefficient)."""
    return _strip_optimum(L, tbar, tmin, tmax, n, "deflection")


def uniform_strip_rotation_coefficient(L, tbar):
    """Uniform strip: int_0^L tbar (L - x) / tbar^3 dx = L^2 / (2 tbar^2)."""
    return L * L / (2.0 * tbar * tbar)


def uniform_strip_deflection_coefficient(L, tbar):
    """Uniform strip: int_0^L (L - x)^2 / tbar^2 dx = L^3 / (3 tbar^2)."""
    return L**3 / (3.0 * tbar * tbar)


def bang_bang_coefficients(L, tbar, tmin, tmax):
    """Continuous bang-bang profile t = tmin on [0, a), tmax on (a, L],
    a = L (tmax - tbar)/(tmax - tmin).  Closed forms (b = L - a):
      rotation:   tmax b a / tmin^3 + a^2/(2 tmin^2) + b^2/(2 tmax^2)
      deflection: int_0^a (tmax b + tmin (a - x)) (L - x) dx / tmin^3
                  + b^3 / (3 tmax^2).
    Returns (a, rotation_coefficient, deflection_coefficient)."""
    a = L * (tmax - tbar) / (tmax - tmin)
    b = L - a
    rot = tmax * b * a / tmin**3 + a * a / (2 * tmin**2) + b * b / (2 * tmax**2)
    # int_0^a (L - x) dx = a L - a^2/2;  int_0^a (a - x)(L - x) dx = a^2 L/2 - a^3/6
    defl = (tmax * b * (a * L - a * a / 2) + tmin * (a * a * L / 2 - a**3 / 6)) / tmin**3 + b**3 / (
        3 * tmax**2
    )
    return a, rot, defl


# Piecewise-LINEAR t (rftfem's profile: n values, linear between equal-spaced
# nodes): J = int_0^L k mt / t^3 dx with t = P t_n, mt = Q t_n at 16 Gauss
# points a segment (smooth there: exact to ~1e-15), and for that rule exactly
#     dJ/dt_n = Q^T (w k / t^3) - 3 P^T (w k mt / t^4).
# k = 1: tip rotation; chord = d: k = min(1, (L - x)/d), the slope of the chord
# of the last d (theta_L less int kappa (x - L + d)/d over it; L - d a node).


def _linear_strip(L, n, chord, m=16):
    e, h = n - 1, L / (n - 1)
    g, gw = np.polynomial.legendre.leggauss(m)
    xi = (g + 1) / 2
    P, Q = np.zeros((e * m, n)), np.zeros((e * m, n))
    for k in range(e):
        r = slice(k * m, (k + 1) * m)
        P[r, k], P[r, k + 1] = 1 - xi, xi
        Q[r, k] = h * (1 - xi) ** 2 / 2  # int_x^{x_k+1} of the two hats
        Q[r, k + 1] = h * (1 - xi * xi) / 2 + (h / 2 if k + 1 < e else 0.0)
        Q[r, k + 2 :] = h - h / 2 * (np.arange(k + 2, n) == n - 1)  # later ones
    x = h * (np.arange(e)[:, None] + xi).ravel()
    w = np.tile(gw * h / 2, e) * (np.minimum(1.0, (L - x) / chord) if chord else 1.0)
    return P, Q, w


def magnetic_strip_linear_coefficient(t_nodes, L, chord=0.0, grad=False):
    """J (with grad, also dJ/dt_nodes) of piecewise-linear t; theta = 12 M0 B J / E."""
    t = np.asarray(t_nodes, float)
    P, Q, w = _linear_strip(L, len(t), chord)
    tq, mq = P @ t, Q @ t
    J = w @ (mq / tq**3)
    return (J, Q.T @ (w / tq**3) - 3 * P.T @ (w * mq / tq**4)) if grad else J


def magnetic_strip_piecewise_linear_optimum(L, tbar, tmin, tmax, n_nodes, chord=0.0):
    """Optimum over piecewise-linear t (n_nodes values in [tmin, tmax], mean tbar by
    the trapezoid rule): SLSQP, exact gradient, from uniform, two ramps and five
    seeded random starts; the best feasible end (the tmin | one ramp | tmax profile
    for n_nodes <= 81; at 301 it stops short).  Returns (t_nodes, J)."""
    n, lo, hi = n_nodes, tmin / tbar, tmax / tbar
    c = np.r_[0.5, np.ones(n - 2), 0.5] / (n - 1)  # mean = c @ t
    J0 = magnetic_strip_linear_coefficient(np.full(n, tbar), L, chord)

    def f(u):
        J, g = magnetic_strip_linear_coefficient(u * tbar, L, chord, grad=True)
        return -J / J0, -g * tbar / J0

    x, rng = np.linspace(-0.5, 0.5, n), np.random.default_rng(1)
    us = [np.ones(n), 1 + x, 1 - x, *rng.uniform(lo, hi, (5, n))]
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", "Values in x were outside bounds")
        ends = [
            optimize.minimize(
                f,
                np.clip(u / (c @ u), lo, hi),
                jac=True,
                method="SLSQP",
                bounds=[(lo, hi)] * n,
                options={"ftol": 1e-15, "maxiter": 2000},
                constraints=[{"type": "eq", "fun": lambda u: c @ u - 1.0, "jac": lambda u: c}],
            ).x
            for u in us
        ]
    t = tbar * min(
        (np.clip(u, lo, hi) for u in ends if abs(c @ u - 1) < 1e-9), key=lambda u: f(u)[0]
    )
    return t, magnetic_strip_linear_coefficient(t, L, chord)
