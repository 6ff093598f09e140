"""gmsh mesh builders and readers for rftfem.

Every body is a :class:`Body`: a dolfinx surface mesh in 3D (tdim 2, gdim 3)
with cell tags (regions) and facet tags (named edges and hinge lines), the
names of both, and the extents of the reference body in X and Y.

- :func:`build_strip` -- a structured strip in the XY plane, a grid of
  rectangles cut at region limits (x and/or y bands) and hinge lines, with the
  four sides and the hinge lines as named edges (``kind = "strip"``);
- :func:`build_three_link` -- three links side by side along Y joined by the
  hinge lines ``"hinge-left"`` and ``"hinge-right"`` (``kind = "three-link"``);
- :func:`read_gmsh` -- a user ``.msh`` file whose named physical surfaces are
  the regions and named physical curves the edges (``kind = "gmsh"``);
- :func:`build_body` -- the ``[mesh]`` table of a scene (docs/scenes.md) to a Body.

gmsh runs on rank 0 only; dolfinx distributes the mesh over the communicator.
The names (``regions``, ``edges``, ``hinges``) and extents are the same on
every rank.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from rftfem.errors import SceneError

if TYPE_CHECKING:
    import os
    from collections.abc import Sequence

    from mpi4py import MPI


@dataclass
class Body:
    """A reference body: mesh, tags and their names.

    ``regions[name]`` lists the cell-tag values that make up the region (a
    region may be made of several tagged pieces, and a cell may belong to
    several regions); ``edges[name]`` lists facet-tag values the same way.
    Integrate over a region with ``dx(tuple(body.regions[name]))`` and over an
    edge with ``ds(tuple(body.edges[name]))``. Hinge lines are named edges
    too, of interior facets (``dS``). ``hinges`` names the built-in hinge
    lines of the mesh kind (three-link: ``["hinge-left", "hinge-right"]``).
    ``points[name]`` holds the reference coordinates (k, 3) of a gmsh file's named
    physical point group, each a vertex of the mesh.
    """

    mesh: object  # dolfinx.mesh.Mesh, tdim 2, gdim 3
    cell_tags: object  # dolfinx MeshTags on cells; every cell has a positive tag
    facet_tags: object  # dolfinx MeshTags on facets of the named edges (may be empty)
    regions: dict[str, list[int]] = field(default_factory=dict)
    edges: dict[str, list[int]] = field(default_factory=dict)
    points: dict[str, object] = field(default_factory=dict)  # name -> (k, 3) coordinates
    length: float = 0.0  # extent in X of the reference body (global)
    width: float = 0.0  # extent in Y of the reference body (global)
    hinges: list[str] = field(default_factory=list)  # built-in hinge line names (in edges)
    #: a gmsh file's :class:`~rftfem.meshes.surface_checks.SurfaceReport` (cells by
    #: type, cells turned, free edges, pieces); None for the built-in meshes
    report: object = None


from .gmsh_file import Recipe, file_recipe, read_gmsh, realize  # noqa: E402
from .strip import build_strip, strip_recipe  # noqa: E402
from .three_link import build_three_link, three_link_recipe  # noqa: E402

__all__ = ["Body", "build_strip", "build_three_link", "read_gmsh", "build_body", "body_recipe"]


_DEFAULTS = {
    "strip": {"length": 12.0, "width": 1.0, "divisions": [16, 1], "cell": "quadrilateral"},
    "three-link": {
        "length": 12.0,
        "link_width": 0.5,
        "divisions": [10, 2],
        "cell": "quadrilateral",
    },
}


def _regions(raw) -> list:
    """``[[mesh.regions]]`` tables ``{name, x, y}`` as ``[(name, xband, yband)]``."""
    if not isinstance(raw, (list, tuple)):
        raise SceneError(f"mesh.regions: expected an array of tables, found {raw!r}")
    regions = []
    for i, item in enumerate(raw):
        if not isinstance(item, dict):
            raise SceneError(f"mesh.regions.{i}: expected a table {{name, x, y}}, found {item!r}")
        if "name" not in item:
            raise SceneError(f"mesh.regions.{i}.name: required")
        bands = [item.get("x"), item.get("y")]
        if bands == [None, None]:
            raise SceneError(f"mesh.regions.{i}: expected x = [a, b] and/or y = [a, b]")
        for k, axis in enumerate("xy"):
            band = bands[k]
            if band is not None:
                if not isinstance(band, (list, tuple)) or len(band) != 2:
                    raise SceneError(
                        f"mesh.regions.{i}.{axis}: expected [{axis}0, {axis}1], found {band!r}"
                    )
                bands[k] = tuple(band)
        regions.append((item["name"], *bands))
    return regions


def body_recipe(
    mesh_section: dict,
    scene_dir: str | os.PathLike[str] | None = None,
    hinges: Sequence[str] = (),
) -> Recipe:
    """The :class:`Recipe` of the scene's ``[mesh]`` table: :func:`build_body` without
    its ``comm``; errors as there."""
    import os

    if not isinstance(mesh_section, dict):
        raise SceneError(f"mesh: expected a table, found {mesh_section!r}")
    kind = mesh_section.get("kind", "strip")
    if kind in ("strip", "three-link"):
        get = lambda key: mesh_section.get(key, _DEFAULTS[kind][key])  # noqa: E731
        regions = _regions(mesh_section.get("regions", []))
        grading = float(mesh_section.get("grading") or 1.0)
        if kind == "strip":
            return strip_recipe(
                get("length"),
                get("width"),
                get("divisions"),
                get("cell"),
                regions,
                hinges,
                grading=grading,
            )
        return three_link_recipe(
            get("length"),
            get("link_width"),
            get("divisions"),
            get("cell"),
            regions,
            hinges,
            grading=grading,
        )
    if kind == "gmsh":
        path = mesh_section.get("file")
        if not isinstance(path, str) or not path:
            raise SceneError(f'mesh.file: required for kind = "gmsh" (a .msh path), found {path!r}')
        if float(mesh_section.get("grading") or 1.0) != 1.0:
            raise SceneError(
                'mesh.grading: for kind = "strip" or "three-link"; a gmsh '
                "file brings its own cell sizes (grade them in gmsh)"
            )
        if mesh_section.get("regions"):
            raise SceneError(
                'mesh.regions: x/y bands are for kind = "strip" or '
                '"three-link"; with kind = "gmsh" the named physical '
                "surfaces of the file are the regions"
            )
        if scene_dir is not None and not os.path.isabs(path):
            path = os.path.join(os.fspath(scene_dir), path)
        return file_recipe(path)
    raise SceneError(f'mesh.kind: expected "strip", "three-link" or "gmsh", found {kind!r}')


def build_body(
    comm: MPI.Comm,
    mesh_section: dict,
    scene_dir: str | os.PathLike[str] | None = None,
    hinges: Sequence[str] = (),
) -> Body:
    """The scene's ``[mesh]`` table (docs/scenes.md) as a Body; collective on ``comm``.

    ``kind`` (default ``"strip"``):

    - ``"strip"``: :func:`build_strip` from ``length`` (default 12.0),
      ``width`` (1.0), ``divisions`` (``[16, 1]``), ``cell``
      (``"quadrilateral"``) and ``[[mesh.regions]]`` tables ``{name, x, y}``
      (``x = [a, b]`` and/or ``y = [a, b]``);
    - ``"three-link"``: :func:`build_three_link` from ``length`` (12.0),
      ``link_width`` (0.5), ``divisions`` (``[10, 2]``: along X, across each
      link), ``cell`` and ``[[mesh.regions]]`` as for strips;
    - ``"gmsh"``: :func:`read_gmsh` of ``file``, relative to ``scene_dir``
      (the scene file's folder) unless absolute. Regions are the file's named
      physical surfaces, so ``mesh.regions`` is refused there.

    ``hinges``: the ``where`` strings of the scene's ``[[hinge]]`` tables;
    strips and three-link meshes cut and name the lines ``"x=c"`` / ``"y=c"``
    (errors name ``hinge.N.where``); for ``"gmsh"`` they are ignored here
    (hinges there are named physical curves of the file, resolved later).

    Bad values raise a one-line ``SceneError`` naming the ``mesh.*`` key.
    """
    return realize(comm, body_recipe(mesh_section, scene_dir, hinges))
