"""A plane wall for the fast multipoles (``operator = "fmm"`` with ``[fluid.wall]``,
docs/stokes.md §A wall): Blake's images of ``rftfem.model.stokeslets.Wall`` as
sources that fmm3dpy's Stokes and Laplace multipole methods take.

In the wall's frame (wall z = 0, liquid z > 0), a force F at y = (y₁, y₂, h) has
its images at y* = (y₁, y₂, −h); with R = x − y*, D = diag(1, 1, −1) and the
fmm3d kernels' own scales (Stokeslet S/8π, doublet ∂_y(S σ)·v/4π, Laplace dipole
potential φ_q = q·R/(4πR³)), Blake's image velocity (times μ) is

    −S(R) F/8π  +  h² ∇φ_{DF}(R)  +  doublet(σ = h e₃, v = DF) at y*,

a Stokeslet of −F, a potential dipole (the gradient of a Laplace dipole potential)
and a Stokes doublet.  Their velocity gradient at the targets (the targets'
motion in the position derivative) comes from the same calls.  A source's motion
dy moves its images by D dy and their height by dh = dy₃:

* the Stokeslet: a doublet (σ = −F/2, v = D dy);
* the potential dipole: a Laplace dipole 2h dh DF, and −Σ_b ∇∂_b Φ_b with Φ_b the
  dipole potentials of h² (D dy)_b DF (three densities at once: the Hessians);
* the doublet: a doublet (σ = dh e₃, v = DF), and −Σ_b ∂_b U_b with U_b the
  doublets of σ = h (D dy)_b e₃, v = DF (three densities: their gradients).

Nothing is cut off: the images are as exact as the multipoles' requested precision,
like the free part (``rftfem.model.stokes_fmm``).  They stay unregularized, as in
the dense and direct operators.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from rftfem.model import stokes_kernels

if TYPE_CHECKING:
    from rftfem.model.stokeslets import Wall

_MIRROR = np.array([1.0, 1.0, -1.0])
_E3 = np.array([0.0, 0.0, 1.0])


def _columns(v: np.ndarray) -> np.ndarray:
    """(…, N, 3) → fmm3d's (…, 3, N), contiguous."""
    return np.ascontiguousarray(np.swapaxes(v, -1, -2))


class FmmImages:
    """The images of the forces at ``x`` (N, 3, global) in ``wall``, by fast
    multipoles to ``precision``; velocities and gradients times μ, global axes.
    With ``free`` each call adds the free Stokeslets' part (the singular sums of
    ``rftfem.model.stokes_fmm``) in the same multipole call.

    The Stokes sums are evaluated at their sources (the nodes among them, with no
    strength if need be): fmm3d's Stokes method with separate targets costs about
    twice as much here.  The Laplace sums take the nodes as targets (cheaper)."""

    def __init__(self, x: np.ndarray, wall: Wall, precision: float):
        self.Q, self.precision = wall.Q, precision
        #: the nodes in the wall's frame, their heights and their images
        self.y = stokes_kernels.to_frame(wall.Q, wall.point, x)
        self.h = self.y[:, 2].copy()
        self.star = self.y * _MIRROR
        self.n = len(self.y)

    def _to_frame(self, v):
        return stokes_kernels.to_frame(self.Q, None, np.reshape(v, (-1, 3)))

    def _stokes(self, copies=1, gradient=False, nd=1, **sources):
        """fmm3d's Stokes sums of ``sources`` given at the nodes and then at the images
        ``copies`` times over (strengths (…, (1 + copies) N, 3)), on the nodes: the
        velocity (nd, 3, N), or with ``gradient`` its gradient (nd, k, a, N)."""
        import fmm3dpy

        points = np.concatenate([self.y] + [self.star] * copies)
        out = fmm3dpy.stfmm3d(
            eps=self.precision,
            sources=_columns(points),
            ifppreg=3 if gradient else 1,
            nd=nd,
            **{k: _columns(v) for k, v in sources.items()},
        )
        if gradient:
            return np.reshape(out.grad, (nd, 3, 3, -1))[..., : self.n]
        return np.reshape(out.pot, (nd, 3, -1))[..., : self.n]

    def _laplace(self, dipoles, nd=1):
        """fmm3d's Laplace dipole sums at the images on the nodes: their gradients
        (nd, 3, N) and Hessians (nd, N, 3, 3)."""
        import fmm3dpy

        out = fmm3dpy.lfmm3d(
            eps=self.precision,
            sources=_columns(self.star),
            dipvec=_columns(dipoles),
            targets=_columns(self.y),
            pgt=3,
            nd=nd,
        )
        hessians = _hessians(np.reshape(out.hesstarg, (nd, 6, self.n)))
        return np.reshape(out.gradtarg, (nd, 3, self.n)), hessians

    def _sources(self, F, free):
        """The Stokeslets (the nodes' if ``free``, the images') and the images'
        doublets and potential dipoles of the forces F (frame)."""
        DF, zero = F * _MIRROR, np.zeros_like(F)
        stokeslets = np.concatenate([F if free else zero, -F])
        sigma = np.concatenate([zero, self.h[:, None] * _E3])
        return stokeslets, sigma, np.concatenate([zero, DF]), (self.h**2)[:, None] * DF

    def velocity(self, forces: np.ndarray, free: bool = False) -> np.ndarray:
        """The images' velocity (times μ) at every node, (N, 3)."""
        stokeslet, sigma, v, dipole = self._sources(self._to_frame(forces), free)
        u = self._stokes(stoklet=stokeslet, doublet=sigma, doubvec=v)[0].T
        return (u + self._laplace(dipole)[0][0].T) @ self.Q

    def gradient(self, forces: np.ndarray, free: bool = False) -> np.ndarray:
        """``∂u_a/∂x_k`` of the images' velocity (times μ) at every node, (N, k, a)."""
        stokeslet, sigma, v, dipole = self._sources(self._to_frame(forces), free)
        g = self._stokes(gradient=True, stoklet=stokeslet, doublet=sigma, doubvec=v)[0]
        g = np.moveaxis(g, -1, 0) + self._laplace(dipole)[1][0]
        return np.einsum("ki,nkl,lj->nij", self.Q, g, self.Q)

    def source_motion(self, forces: np.ndarray, dx: np.ndarray, free: bool = False) -> np.ndarray:
        """The images' velocity change (times μ) at every node when the sources move
        by ``dx`` (N, 3) at fixed forces and targets, (N, 3)."""
        F, dy = self._to_frame(forces), self._to_frame(dx)
        DF, w, dh, h = F * _MIRROR, dy * _MIRROR, dy[:, 2:], self.h[:, None]
        # doublets at fixed strength: the free Stokeslets' motion (∂_y S = 4π doublet),
        # the images' Stokeslets' motion, the doublets' height
        u = self._stokes(
            copies=2,
            doublet=np.concatenate([0.5 * F if free else 0 * F, -0.5 * F, dh * _E3]),
            doubvec=np.concatenate([dy, w, DF]),
        )[0].T
        # the potential dipole: its height (one density), its position (three)
        dipoles = np.stack([2 * h * dh * DF] + [h**2 * w[:, [b]] * DF for b in range(3)])
        gradients, hessians = self._laplace(dipoles, nd=4)
        u += gradients[0].T - np.einsum("bnba->na", hessians[1:])
        # the doublet's position: three densities of doublets, their gradients
        zero = np.zeros((3, self.n, 3))
        sigma = np.stack([h * w[:, [b]] * _E3 for b in range(3)])
        vectors = np.concatenate([zero, np.stack([DF] * 3)], axis=1)
        g = self._stokes(
            gradient=True, nd=3, doublet=np.concatenate([zero, sigma], axis=1), doubvec=vectors
        )
        u -= np.einsum("bban->na", g)  # Σ_b ∂_b U_b: g[b, k, a, n] at k = b
        return u @ self.Q


def _hessians(packed: np.ndarray) -> np.ndarray:
    """fmm3d's packed Hessians (…, 6, N: xx, yy, zz, xy, xz, yz) as (…, N, 3, 3)."""
    idx = np.array([[0, 3, 4], [3, 1, 5], [4, 5, 2]])
    return np.moveaxis(packed[..., idx, :], -1, -3)
