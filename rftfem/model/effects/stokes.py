"""Stokes flow around the body, ``[fluid] model = "stokes"`` (docs/stokes.md).

The mid-surface is a single layer of regularized Stokeslets.  Two discretisations
(``fluid.method``) share everything here:

- ``"layer"`` (default): a force density on the shell's own elements, or on each
  element cut ``2^refine`` times (``rftfem.model.stokes_layer``), the kernel
  integrated over each element, no slip at the grid's nodes, consistent nodal loads;
- ``"blobs"``: point forces at the displacement nodes with blobs of the spacing
  (``rftfem.model.stokeslets``; the matrix-free operators ``"direct"`` and
  ``"fmm"`` need them).

Either way a step's nodal loads are a resistance applied to the nodes' velocities
``v(u)`` of the time scheme, ``F = R(x) v(u)``, ``x = X + u``: the force the body
exerts on the liquid, which enters the residual like drag (with +, resisting).  The
operator is nonlocal, so it is not a UFL form: the residual takes it through
``add_nodal_forces`` and the Newton tangent through :meth:`Stokes.tangent_product`,
exact in the positions too (``dF = M⁻¹ (c_v du − G du)``, ``G`` the derivative of the
velocities at fixed forces), applied matrix-free by the solver
(``rftfem.integration.coupled``) around a preconditioner made of the sparse tangent
plus the lumped blocks of the resistance (a local drag).  Which operator, and the
resistance of one configuration, are ``stokes_operators``'s; the wall's gap checks
``stokes_wall``'s.

Every process holds the whole body's nodes (gathered in rank order); each
evaluates the kernel for its share of the rows (the matrix's and the position
derivative's, kept) and the processes factorise the matrix together
(``rftfem.model.dense_factors``); each adds the forces of the nodes it owns.  The
direct sums are shared out by rows too; the fast multipoles run on the first
process only, threaded, and their results are broadcast.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from rftfem.model import layer_rules, stokes_body, stokes_layer, stokes_report, stokeslets
from rftfem.model.effects import fluid, stokes_operators, stokes_wall
from rftfem.model.effects.base import FluidModel, NonlocalEffect
from rftfem.model.ranks import gather_rows
from rftfem.model.rates import scheme_velocity
from rftfem.model.stokes_matrix_free import MatrixFreeResistance

if TYPE_CHECKING:
    from rftfem.model.body_parts import BodyPart
    from rftfem.model.shell_model import Model
#: the most nodes the dense operator is meant for (``stokes_operators``)
DENSE_NODES = stokes_operators.DENSE_NODES


#: the layer's Newton tangents keep the liquid's factors and derivative while GMRES
#: on them solves a residual in at most this many iterations (docs/stokes.md §Cost)
REUSE_ITERATIONS = 10
#: a Newton residual within this many times the matrix-free forces' error is their
#: noise (a soft sphere over a wall, whose estimated errors were 2e-12 to 4e-11,
#: stalled at 3e-11 and then wandered up to 1.4e-10 while its steps were cut)
FLOOR_MARGIN = 10.0

WALL_GAP_REFUSED, WALL_GAP_WARNED = stokes_body.WALL_GAP_REFUSED, stokes_body.WALL_GAP_WARNED


class Stokes(FluidModel, NonlocalEffect):
    name = "stokes"
    columns = ["fluid_power"] + fluid.RESULTANT_COLUMNS

    @classmethod
    def active(cls, scene: dict) -> bool:
        return fluid.model_of(scene) == "stokes"

    @classmethod
    def names(cls, scene: dict) -> list[str]:
        """ "stokes", and "stokes wall" when the liquid has a plane wall (its images):
        what `rftfem check`, ``Scene.check()`` and summary.json list alike."""
        if not cls.active(scene):
            return []
        return ["stokes"] + (["stokes wall"] if scene["fluid"].get("wall") else [])

    def __init__(self, model: Model):
        super().__init__(model)
        #: ``[fluid]`` parsed (fluid.FluidSettings)
        self.settings = given = fluid.settings(self.scene)
        self.viscosity = given.viscosity
        comm = model.comm
        im = model.Vu.dofmap.index_map
        self.n_owned = im.size_local
        counts = comm.allgather(self.n_owned)
        self.offset = int(sum(counts[: comm.rank]))
        #: the local dofs of ``w`` holding the owned nodes' displacement, (n_owned, 3)
        self.owned_u = model.u_dofs.reshape(-1, 3)[: self.n_owned]
        #: the reference positions of every node of the body, in rank order (N, 3)
        self.X = self._gather(model.Vu.tabulate_dof_coordinates()[: self.n_owned])
        #: "layer" (the density on the elements) or "blobs" (point forces at the nodes)
        self.method = given.method
        if self.method == "layer":
            self._set_up_layer(given)
        else:
            #: each node's blob size δ (N,); for the layer the liquid's resolution there
            #: (the wall's gap is measured in it)
            self.delta = self._gather(self._node_blobs(given.regularization))
        stokes_body.check_blob_size(self.delta, self.model.size())
        wall = given.wall
        #: the no-slip plane (``[fluid.wall]``), or None
        self.wall = stokeslets.Wall(*wall) if wall else None
        if self.wall is not None:
            #: the closest gap between body and wall in blobs, the prescribed motions'
            #: reach towards the wall taken off (docs/stokes.md: the images need 2.5)
            self.wall_gap = stokes_body.wall_gap(self.wall, self.X, self.delta, self.scene)
            #: body.csv's closest gap to the wall in blobs, row by row
            self.columns = [*type(self).columns, "wall_gap_blobs"]
        #: "dense" or "fmm": how the operator is applied
        self.operator = stokes_operators.choose_operator(given.operator, len(self.X), self.method)
        if self.method == "blobs" and self.operator == "dense":  # refused if too large
            stokes_report.admit(len(self.X), len(self.X), comm.size, "blobs")
        length, width = fluid.body_extents(self.X, self.scene["shell"]["axis"])
        #: slender-body drag coefficients of the same viscosity (time scales only)
        self.C = fluid.slender_body_drag(self.viscosity, length, max(width, 1e-300))
        self._resistance = None  # the factorised mobility of the last positions
        #: the layer's factors are kept across residuals and steps (``fluid.factors``)
        self.keep_factors = given.factors == "kept"
        self._factored = None  # the resistance whose factors are kept
        self._last = None  # (positions, velocities, forces) of the last residual
        self._tangent = None

    # --- set-up -----------------------------------------------------------

    def _gather(self, owned: np.ndarray) -> np.ndarray:
        return gather_rows(owned, self.model.comm)

    def _node_blobs(self, uniform) -> np.ndarray:
        """δ of the owned nodes: ``uniform`` if given, else the node spacing."""
        if uniform is not None:
            return np.full(self.n_owned, float(uniform))
        return stokes_body.node_spacing(self.model)[: self.n_owned]

    def _set_up_layer(self, given):
        """The integrated layer's rules (``rftfem.model.stokes_layer``): the elements
        of every process in the global node numbering, ε and the refinement."""
        m = self.model
        cells, cell = stokes_body.global_cells(m)
        self.refine = given.refine
        #: the shell's elements in the global node numbering, and their kind
        self.shell_cells, self.cell = cells, cell
        eps = given.regularization
        spacing = self._gather(self._node_blobs(None))
        #: ε, the blob size (a length of its own); 0, the default: the Stokeslet itself
        self.epsilon = 0.0 if eps is None else float(eps)
        #: the integrated layer on the force grid (its rows: this process's share), and
        #: the grid's interpolation from the shell's nodes
        self.layer, self.interpolation = stokes_operators.grid_layer(
            self.X, cells, cell, self.refine, self.epsilon, m.comm
        )
        self.delta = np.maximum(self.epsilon, spacing / 2**self.refine)

    def _serial_layer(self, level: int) -> stokes_layer.Layer:
        """The layer of ``fluid.refine = level`` with every row (one process's estimate)."""
        if level == self.refine and self.model.comm.size == 1:
            return self.layer
        grid, cells, _ = layer_rules.refined(self.X, self.shell_cells, self.cell, level)
        return stokes_layer.Layer(grid, cells, self.cell, self.epsilon)

    def describe(self) -> dict:
        """The discretisation, its cost and its estimated error (``rftfem check``,
        summary.json's ``fluid``; ``rftfem.model.stokes_report``)."""
        return stokes_report.describe(self)

    def check_lines(self) -> list[str]:
        return stokes_report.check_lines(self.describe())

    def opening_lines(self) -> list[str]:
        return self.check_lines()

    def warnings(self) -> list[str]:
        """A body too large for the dense operator (docs/stokes.md, Cost); a wall
        closer than WALL_GAP_WARNED blobs."""
        out = stokes_wall.set_up_warnings(self.wall_gap) if self.wall is not None else []
        if self.method == "layer":
            out += stokes_report.warnings(self.describe())
            out += stokes_body.free_edge_warnings(self.cell, self.shell_cells)
        n = len(self.X) if self.method == "blobs" else len(self.layer.X)
        return out + stokes_operators.dense_warnings(n, self.operator)

    # --- state ------------------------------------------------------------

    def _state(self):
        """Global positions and velocities ``(x, v)`` of the current iterate, (N, 3) each."""
        m, c = self.model, self.model.coef
        n = self.n_owned
        u = m.w.x.array[self.owned_u]
        v = scheme_velocity(
            u - m.u_n.x.array.reshape(-1, 3)[:n],
            m.v_n.x.array.reshape(-1, 3)[:n],
            m.a_n.x.array.reshape(-1, 3)[:n],
            *(float(c[k].value) for k in ("cv", "cv_v", "cv_a")),
        )
        if m.drive:
            v = v + m.drive[0].x.array.reshape(-1, 3)[:n]
        both = self._gather(np.hstack([self.X[self.offset : self.offset + n] + u, v]))
        return both[:, :3], both[:, 3:]

    def resistance(self, x: np.ndarray) -> stokeslets.Resistance:
        """The factorised mobility at the positions ``x`` (kept for the same ``x``)."""
        if self._resistance is None or not np.array_equal(self._resistance.x, x):
            if isinstance(self._resistance, MatrixFreeResistance):
                # the factors it ended with (a second exact product makes its own)
                self._factored = self._resistance.factored
            if self.wall is not None and self.wall.heights(x).min() <= 0.0:
                # the body has reached the wall: no flow state exists; a residual of
                # NaN makes the step fail and be cut (the solver says it is not finite)
                self._resistance = stokes_body.Crossed(x)
            else:
                kept = self._factored if self.keep_factors else None
                self._resistance = stokes_operators.new_resistance(self, x, kept)
                if self.method == "layer" or self.operator == "direct":
                    self._factored = self._resistance.factored
        return self._resistance

    def nodal_forces(self) -> np.ndarray:
        """The forces (N, 3) the body exerts on the liquid at the current iterate."""
        x, v = self._state()
        F = self._forces(x, v)
        self._last = (x, v, F)
        return F

    def _forces(self, x, v) -> np.ndarray:
        """``R(x) v`` (N, 3); the last residual's forces if they are these, and the
        start of a matrix-free solve (a Newton iterate, a step or the stored state
        away: close)."""
        last = self._last
        if last is not None and np.array_equal(last[0], x) and np.array_equal(last[1], v):
            return last[2]
        res = self.resistance(x)
        if isinstance(res, MatrixFreeResistance) and last is not None:
            return res.solve(v.ravel(), guess=last[2]).reshape(-1, 3)
        return res.solve(v.ravel()).reshape(-1, 3)

    def residual_floor(self) -> float:
        """``FLOOR_MARGIN`` times the conjugate gradients' error in the last forces
        (the matrix-free operators; 0 for the factorised ones)."""
        return FLOOR_MARGIN * getattr(self._resistance, "force_error", 0.0)

    def add_nodal_forces(self, F: np.ndarray) -> None:
        forces = self.nodal_forces()
        F[self.owned_u] += forces[self.offset : self.offset + self.n_owned]

    # --- the tangent ------------------------------------------------------

    def prepare_tangent(self, scale: float, exact: bool = False) -> np.ndarray:
        """Make the tangent of ``scale · F`` at the current iterate; returns the
        lumped blocks of its velocity part for the owned nodes (n_owned, 3, 3).
        Without ``exact`` (a Newton update) the layer may give the kept factors'
        tangent (``fluid.factors = "kept"``)."""
        F = self.nodal_forces()
        x = self._last[0]
        res = self.resistance(x)
        cv = float(self.model.coef["cv"].value)
        kept = self._tangent
        on_kept = not getattr(res, "fresh", True)  # the layer's or one cluster's factors
        if isinstance(res, MatrixFreeResistance):
            # an exact tangent on kept factors: conjugate gradients preconditioned by
            # them for its first product, new factors at its second (tangent())
            res.exact_tangent, res._exact_products, exact = exact, 0, False
        if on_kept and (exact or res.iterations > REUSE_ITERATIONS):
            res.factorise()  # the solve slowed on the kept factors: this iterate's own
            self._factored, on_kept = res, False
        layer_kept = on_kept and self.method == "layer"
        if kept is not None and (kept.resistance is res and kept.forces is F or layer_kept):
            # the same iterate (a lifting made it: G depends on x and F only), or the
            # layer's kept factors' tangent (the blobs' direct G is cheap: this one's)
            G = kept.G
        else:
            G = res.position_operator(F)
        self._tangent = _Tangent(res, cv, G, scale, F)
        lumped = res.lumped()[self.offset : self.offset + self.n_owned]
        return scale * cv * lumped

    def tangent_product(self, dx: np.ndarray) -> np.ndarray:
        """``scale · M⁻¹ (c_v dx − G dx)`` for a displacement direction at every node
        (N, 3): the owned nodes' rows (n_owned, 3)."""
        res, cv, G, scale = (
            self._tangent.resistance,
            self._tangent.cv,
            self._tangent.G,
            self._tangent.scale,
        )
        du = np.ravel(dx)
        if hasattr(res, "tangent"):  # the layer's force grid; the matrix-free's factors
            out = scale * res.tangent(du, cv, G)
        else:
            out = scale * res.solve(cv * du - G @ du)
        return out.reshape(-1, 3)[self.offset : self.offset + self.n_owned]

    # --- outputs ----------------------------------------------------------

    def force_scales(self) -> list[float]:
        return fluid.force_scales(self)

    def after_step(self, t: float) -> list[str]:
        """The wall's closest gap at the converged state of an accepted step: under
        WALL_GAP_REFUSED blobs the run fails (RunFailed: the images no longer hold the
        wall's no slip); under WALL_GAP_WARNED it is warned of once, if the set-up's
        check did not already."""
        if self.wall is None:
            return []
        m, n = self.model, self.n_owned
        u = m.u_n.x.array.reshape(-1, 3)[:n]
        x = self._gather(self.X[self.offset : self.offset + n] + u)
        gaps = self.wall.heights(x) / self.delta
        # warned of once, if the set-up's check did not already
        warn = self.wall_gap >= WALL_GAP_WARNED and not getattr(self, "_gap_warned", False)
        lines = stokes_wall.check_step(x, gaps, t, warn)
        if lines:
            self._gap_warned = True
        return lines

    def _stored(self):
        """Positions, velocities and forces of the last converged state (``u_n``, ``v_n``)."""
        m, n = self.model, self.n_owned
        u = m.u_n.x.array.reshape(-1, 3)[:n]
        v = m.v_n.x.array.reshape(-1, 3)[:n]
        both = self._gather(np.hstack([self.X[self.offset : self.offset + n] + u, v]))
        x, v = both[:, :3], both[:, 3:]
        return x, v, self._forces(x, v)

    def resultant_on(self, part: BodyPart) -> np.ndarray:
        """The force and moment of the body's own nodal forces (as :meth:`values`)."""
        x, _, F = self._stored()
        mine = self._gather(part.nodes[: self.n_owned, None].astype(float))[:, 0] > 0.5
        return -np.concatenate([F[mine].sum(axis=0), np.cross(x[mine], F[mine]).sum(axis=0)])

    def values(self, t: float) -> list[float]:
        x, v, F = self._stored()
        force = -F.sum(axis=0)
        moment = -np.cross(x, F).sum(axis=0)
        out = [float(np.sum(F * v)), *force, *moment]
        if self.wall is not None:  # the closest gap in blobs (the set-up's check, row by row)
            out.append(float((self.wall.heights(x) / self.delta).min()))
        return out


class _Tangent(NamedTuple):
    """The tangent :meth:`Stokes.prepare_tangent` made: at the forces ``forces`` of the
    resistance ``resistance``, ``scale · M⁻¹ (c_v − G)``."""

    resistance: object
    cv: float
    G: object
    scale: float
    forces: np.ndarray
