"""Three links side by side along Y, joined by two hinge lines: a strip grid."""

from __future__ import annotations

from typing import TYPE_CHECKING

from .gmsh_file import realize
from .strip import check_cell, check_divisions, check_size, grid_recipe

if TYPE_CHECKING:
    from collections.abc import Sequence

    from mpi4py import MPI

    from . import Body
    from .gmsh_file import Recipe
    from .strip import Region

LINKS = ("left", "middle", "right")
HINGES = ("hinge-left", "hinge-right")


def three_link_recipe(
    length: float,
    link_width: float,
    divisions: Sequence[int],
    cell: str = "quadrilateral",
    regions: Sequence[Region] = (),
    hinges: Sequence[str] = (),
    grading: float = 1.0,
) -> Recipe:
    """The :class:`~.gmsh_file.Recipe` of :func:`build_three_link` (same arguments but
    ``comm``)."""
    length, w = check_size("length", length), check_size("link_width", link_width)
    nx, n = check_divisions(divisions, "[nx, n_per_link]")
    check_cell(cell)
    y = [0.0, w, 2.0 * w, 3.0 * w]
    return grid_recipe(
        length,
        y[3],
        nx,
        [(y[k], y[k + 1], n) for k in range(3)],
        cell,
        regions,
        hinges,
        grading=grading,
        builtin_lines=[("y", y[1], HINGES[0]), ("y", y[2], HINGES[1])],
        builtin_regions=[(LINKS[k], None, (y[k], y[k + 1])) for k in range(3)],
    )


def build_three_link(
    comm: MPI.Comm,
    length: float,
    link_width: float,
    divisions: Sequence[int],
    cell: str = "quadrilateral",
    regions: Sequence[Region] = (),
    hinges: Sequence[str] = (),
    grading: float = 1.0,
) -> Body:
    """Three equal links ``[0, L] x [k w, (k+1) w]`` (k = 0, 1, 2) at Z = 0 as a Body.

    The body is the strip ``[0, L] x [0, 3 w]`` of :func:`.strip.build_strip`
    with the lines y = w and y = 2 w always cut and named ``"hinge-left"`` and
    ``"hinge-right"`` (facet tags 5 and 6, interior facets, in ``edges`` and in
    ``Body.hinges``), and the regions ``"left"`` (0 ≤ y ≤ w), ``"middle"`` and
    ``"right"``. Edges ``"x=0"``, ``"x=L"``, ``"y=0"``, ``"y=W"`` (W = 3 w)
    have tags 1..4.

    ``divisions = [nx, n_per_link]``: elements along X and across each link
    (3 n_per_link across the body); extra Y cuts (user regions, hinges) share
    the divisions of the link they fall in. ``cell``, ``regions`` and
    ``hinges`` as for strips (user hinge tags 7, 8, ...), except that a user
    region may not be named like a link and a user hinge may not lie on a
    built-in hinge line.

    Bad arguments raise ``SceneError`` naming ``mesh.length``,
    ``mesh.link_width``, ``mesh.divisions``, ``mesh.cell``, ``mesh.regions.N``
    or ``hinge.N.where``.
    """
    return realize(
        comm, three_link_recipe(length, link_width, divisions, cell, regions, hinges, grading)
    )
