"""Dirichlet plumbing shared by the components that hold degrees of freedom
(``[[boundary]]``, ``[[motion]]``, the hinges' inactive rotations): the collapsed
space of each sub-space with a zero value on it, and a record of which dofs of
each component are already held by whom, so that a dof takes one condition.
"""

from __future__ import annotations

import numpy as np
from dolfinx import fem


class DirichletSpaces:
    """Collapsed component spaces (cached by name) and the dofs held so far."""

    def __init__(self):
        self._spaces = {}
        #: component name -> [(who holds them, local dofs of ``w``)]
        self.held = {}

    def space(self, sub: fem.FunctionSpace, name: str) -> tuple[fem.FunctionSpace, fem.Function]:
        """The collapsed space of the sub-space ``sub`` and a zero Function on it."""
        if name not in self._spaces:
            V, _ = sub.collapse()
            self._spaces[name] = (V, fem.Function(V))
        return self._spaces[name]

    def hold(self, name: str, holder: str, dofs: np.ndarray) -> None:
        """Record that ``holder`` holds these dofs of component ``name``."""
        self.held.setdefault(name, []).append((holder, np.asarray(dofs)))

    def zero(
        self, sub: fem.FunctionSpace, dim: int, entities: np.ndarray, name: str, holder: str
    ) -> tuple[fem.DirichletBC, np.ndarray]:
        """``sub = 0`` on the dofs of the entities, recorded as held by ``holder``.
        Returns the condition and its local dofs of ``w``."""
        V, zero = self.space(sub, name)
        dofs = fem.locate_dofs_topological((sub, V), dim, entities)
        self.hold(name, holder, dofs[0])
        return fem.dirichletbc(zero, dofs, sub), np.asarray(dofs[0])
