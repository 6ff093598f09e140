"""Clamped rectangular plate under uniform pressure: Rayleigh-Ritz reference.

Specially orthotropic Kirchhoff plate (D16 = D26 = 0) on |x| <= a/2,
|y| <= b/2, all edges clamped (w = dw/dn = 0), uniform pressure q.  The Ritz
solution minimises

    Pi[w] = 1/2 int [D11 w_xx^2 + 2 D12 w_xx w_yy + D22 w_yy^2 + 4 D66 w_xy^2]
            - int q w

over w = sum_ij c_ij X_i(x) Y_j(y).  The load and stiffness are symmetric in
x and in y, so only even functions are used.  Two bases:

* ``legendre``: X_i = (1 - xi^2)^2 P_2i(xi), xi = 2x/a (clamped factor times
  even Legendre polynomials; spectral convergence);
* ``beam``: symmetric clamped-clamped beam modes
  X_i = cos(l xi)/cos(l) - cosh(l xi)/cosh(l),  tan l + tanh l = 0
  (algebraic convergence, used as an independent check).

With 1-D matrices A0 = int X X, A1 = int X' X', A2 = int X'' X'',
C = int X'' X (per direction), the stiffness is
K = D11 A2x(x)A0y + D12 (Cx(x)Cy^T + Cx^T(x)Cy) + D22 A0x(x)A2y + 4 D66 A1x(x)A1y
and the load vector F = q bx(x)by with b = int X.  Integrals use
Gauss-Legendre quadrature; K is solved after symmetric diagonal scaling.

For clamped edges int (w_xx w_yy - w_xy^2) = 0, so only H = D12 + 2 D66
matters (a useful check).  If in addition H = sqrt(D11 D22), the map
x = (D11/D22)^(1/4) x' turns the problem into the isotropic one (D = D22) on
an (a (D22/D11)^(1/4)) x b rectangle.
"""

from __future__ import annotations

import numpy as np
from numpy.polynomial import Legendre, Polynomial
from numpy.polynomial import legendre as npleg
from scipy import linalg, optimize

# Timoshenko & Woinowsky-Krieger, Theory of Plates and Shells, table 35:
# clamped plate, uniform load, w_max = alpha q a^4 / D, b/a >= 1.
TIMOSHENKO_TABLE35 = {1.0: 0.00126, 1.5: 0.00220, 2.0: 0.00254, np.inf: 0.00260}
# Higher-precision literature value for the square: 0.00126532 q a^4 / D.
SQUARE_CLAMPED = 0.00126532


def _legendre_basis(m, xi):
    """Values and xi-derivatives (0, 1, 2) of (1-xi^2)^2 P_2i, i < m."""
    bubble = Legendre.cast(Polynomial([1.0, 0.0, -2.0, 0.0, 1.0]))
    out = np.empty((3, m, len(xi)))
    for i in range(m):
        f = bubble * Legendre.basis(2 * i)
        for d in range(3):
            out[d, i] = f.deriv(d)(xi) if d else f(xi)
    return out


def beam_roots(m):
    """First m positive roots of tan(l) + tanh(l) = 0 (symmetric modes)."""
    g = lambda l: np.tan(l) + np.tanh(l)
    return np.array(
        [
            optimize.brentq(g, (k + 0.5) * np.pi + 1e-9, (k + 1.0) * np.pi, xtol=1e-15)
            for k in range(m)
        ]
    )


def _beam_basis(m, xi):
    """Values and xi-derivatives of cos(l xi)/cos l - cosh(l xi)/cosh l."""
    lam = beam_roots(m)[:, None]
    ax = np.abs(xi)[None, :]
    # cosh(l xi)/cosh l and sinh(l xi)/cosh l without overflow
    e = np.exp(lam * (ax - 1.0)) / (1.0 + np.exp(-2.0 * lam))
    ch = e * (1.0 + np.exp(-2.0 * lam * ax))
    sh = np.sign(xi)[None, :] * e * (1.0 - np.exp(-2.0 * lam * ax))
    c, s = np.cos(lam * xi) / np.cos(lam), np.sin(lam * xi) / np.cos(lam)
    return np.array([c - ch, -lam * (s + sh), -(lam**2) * (c + ch)])


def _one_d(m, length, basis):
    """1-D matrices A0, A1, A2, C, load vector b and centre values X(0)."""
    nq = 2 * m + 12 if basis == "legendre" else 24 * m + 60
    xi, wq = npleg.leggauss(nq)
    make = _legendre_basis if basis == "legendre" else _beam_basis
    V = make(m, xi)
    V0 = make(m, np.array([0.0]))[0, :, 0]
    J = length / 2.0  # dx = J dxi, d/dx = (1/J) d/dxi
    X, X1, X2 = V[0], V[1] / J, V[2] / J**2
    W = wq * J
    A0, A1, A2 = (X * W) @ X.T, (X1 * W) @ X1.T, (X2 * W) @ X2.T
    C = (X2 * W) @ X.T
    return A0, A1, A2, C, X @ W, V0


def clamped_orthotropic_plate(a, b, D11, D12, D22, D66, q, terms=12, basis="legendre"):
    """Centre deflection of the clamped a x b plate (Ritz, ``terms`` functions
    per direction, terms^2 unknowns).  See the module docstring."""
    A0x, A1x, A2x, Cx, bx, vx = _one_d(terms, a, basis)
    A0y, A1y, A2y, Cy, by, vy = _one_d(terms, b, basis)
    K = (
        D11 * np.kron(A2x, A0y)
        + D22 * np.kron(A0x, A2y)
        + D12 * (np.kron(Cx, Cy.T) + np.kron(Cx.T, Cy))
        + 4.0 * D66 * np.kron(A1x, A1y)
    )
    F = q * np.kron(bx, by)
    s = 1.0 / np.sqrt(np.diag(K))
    c = s * linalg.solve(K * np.outer(s, s), F * s, assume_a="pos")
    return float(np.kron(vx, vy) @ c)


def clamped_orthotropic_plate_series(
    a, b, D11, D12, D22, D66, q, terms=(2, 4, 6, 8, 10, 12), basis="legendre"
):
    """[(terms, centre deflection)] for a sequence of basis sizes."""
    return [(m, clamped_orthotropic_plate(a, b, D11, D12, D22, D66, q, m, basis)) for m in terms]
