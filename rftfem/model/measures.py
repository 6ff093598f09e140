"""Whole-body measures of a :class:`~rftfem.model.shell_model.Model` (one of its parts): the
scene's force scales (docs/model.md §7.3), the reference size and area, the
centroid, the stored energy, the largest rotation increment of the iterate, and the
director's unit error, each taken over all processes.
"""

from __future__ import annotations

import numpy as np
import ufl
from dolfinx import fem
from mpi4py import MPI
from petsc4py import PETSc

from rftfem import compat


class BodyMeasures:
    """Whole-body measures of a Model."""

    def reference_force(self) -> float:
        """A force scale of the scene for absolute Newton tolerances (docs/model.md §7.3):
        the largest of the forces that drive the body (loads, couples, drag at the
        prescribed speed); the bending force only where nothing else has a scale (a
        body moved by its supports alone). The elastic forces answer the drivers:
        where they dwarf them (a free link turning in drag) a tolerance in their
        units would accept states whose driving balance is not met at all."""
        drivers = [
            s
            for comp in self.components
            if comp.name != "elasticity"
            for s in comp.force_scales()
            if s > 0
        ]
        return max(drivers) if drivers else self.elastic_force()

    def elastic_force(self) -> float:
        """The bending force ``D W / L²`` that bends the body by order one."""
        return max(self["elasticity"].force_scales())

    def membrane_force(self) -> float:
        """The membrane force ``E t W`` that stretches the body by order one."""
        return self["elasticity"].membrane_force()

    def size(self) -> float:
        """Diagonal of the reference body's bounding box (global): the length that
        displacement errors are measured against."""
        if not hasattr(self, "_size"):
            x = self.mesh.geometry.x
            lo = x.min(axis=0) if len(x) else np.full(3, np.inf)
            hi = x.max(axis=0) if len(x) else np.full(3, -np.inf)
            self.comm.Allreduce(MPI.IN_PLACE, lo, op=MPI.MIN)
            self.comm.Allreduce(MPI.IN_PLACE, hi, op=MPI.MAX)
            self._size = float(np.linalg.norm(hi - lo))
        return self._size

    def largest_rotation_increment(self) -> float:
        """The largest nodal ``|θ|`` of the iterate over all processes and colours
        (``a₁, a₂`` are orthonormal, so ``|θ|² = θ¹² + θ²²``)."""
        theta = self.w.x.array[self.theta_dofs].reshape(-1, 2)
        local = float(np.sqrt((theta**2).sum(axis=1)).max()) if len(theta) else 0.0
        return self.comm.allreduce(local, op=MPI.MAX)

    def area(self, cells: np.ndarray | None = None) -> float:
        """Reference area ``∫ dA₀`` of the body, or of the given local cells (global)."""
        one = fem.Constant(self.mesh, PETSc.ScalarType(1.0))
        if cells is None:
            if not hasattr(self, "_area"):  # a reference quantity: computed once
                self._area = self.assemble_scalar(self.compile(one * self.dx))
            return self._area
        n = self.mesh.topology.index_map(self.mesh.topology.dim).size_local
        cells = np.asarray(cells)[np.asarray(cells) < n].astype(np.int32)  # owned only
        tags = compat.create_meshtags(
            self.mesh, self.mesh.topology.dim, cells, np.ones(len(cells), dtype=np.int32)
        )
        dx = ufl.Measure("dx", domain=self.mesh, subdomain_data=tags)
        return self.assemble_scalar(self.compile(one * dx(1)))

    def centroid(self) -> np.ndarray:
        """Area-weighted mean of the current positions, ``∫ x dA₀ / ∫ dA₀`` (global)."""
        if not hasattr(self, "_centroid_forms"):
            x = ufl.SpatialCoordinate(self.mesh) + self.kinematics().u
            self._centroid_forms = [self.compile(x[i] * self.dx) for i in range(3)]
        return np.array([self.assemble_scalar(f) for f in self._centroid_forms]) / self.area()

    def elastic_energy(self) -> float:
        """Stored energy ``Π`` of the current iterate, springs included."""
        if not hasattr(self, "_energy_form"):
            self._energy_form = self.compile(self.energy)
        return self.assemble_scalar(self._energy_form)

    def director_unit_error(self) -> float:
        """``max | |d| − 1 |`` over all nodal directors (global)."""
        return self.triad.unit_error()

    def nodal_director(self) -> fem.Function:
        """The nodal directors as one [P2]³ Function (for output)."""
        return self.triad.nodal_director()
