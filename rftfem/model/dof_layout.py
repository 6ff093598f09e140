"""Where the unknowns sit in ``w``: its nodes numbered as the displacement's, each
node's block of fields."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from dolfinx import fem

    from rftfem.model.shell_model import Model


def check_node_numbering(W: fem.FunctionSpace, Vu: fem.FunctionSpace) -> None:
    """The unknowns' space ``W`` and the displacement's ``Vu`` number their nodes
    alike (same mesh, same scalar element), which :func:`block_dofs` relies on."""
    x_w, x_u = (V.tabulate_dof_coordinates() for V in (W, Vu))
    size = float(np.abs(x_u).max()) if x_u.size else 0.0
    same = (
        W.dofmap.index_map.size_local == Vu.dofmap.index_map.size_local
        and x_w.shape == x_u.shape
        and np.allclose(x_w, x_u, rtol=0.0, atol=1e-9 * size)
    )
    if not same:
        raise RuntimeError("the unknowns' nodes are not numbered as the displacement's")


def block_dofs(model: Model, fields: Any) -> np.ndarray:
    """The local dofs of ``model.w`` that hold ``fields`` (positions in a node's
    block), node by node in the order of ``Vu``'s nodes."""
    im = model.Vu.dofmap.index_map
    nodes = np.arange(im.size_local + im.num_ghosts)
    return (model.block * nodes[:, None] + np.asarray(fields)[None, :]).ravel()
