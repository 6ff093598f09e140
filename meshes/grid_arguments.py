"""The arguments of a grid body (:mod:`.strip`, :mod:`.three_link`) checked: sizes,
divisions, cell type, region bands and hinge lines; a bad one raises ``SceneError``
naming the scene key.
"""

from __future__ import annotations

import math
import re
from numbers import Integral, Real
from typing import TYPE_CHECKING

from rftfem.errors import SceneError

if TYPE_CHECKING:
    from collections.abc import Sequence

    from .strip import Band, Region

#: the named sides of a strip and their facet tags (no region may take these names)
EDGE_TAGS = {"x=0": 1, "x=L": 2, "y=0": 3, "y=W": 4}
CELLS = ("quadrilateral", "triangle")

_HINGE = re.compile(r"\s*([xy])\s*=\s*(\S+)\s*")


def _is_number(v) -> bool:
    return isinstance(v, Real) and not isinstance(v, bool)


#: the largest length a strip may have: its areas and energies (squares and higher
#: powers of it) must stay finite in double precision
MAX_SIZE = 1e100


def check_size(key: str, v: object) -> float:
    """``v`` as a positive finite float below ``MAX_SIZE``; ``SceneError("mesh.<key>:
    ...")`` otherwise."""
    if not _is_number(v) or not (math.isfinite(v) and v > 0):
        raise SceneError(f"mesh.{key}: expected a positive number, found {v!r}")
    if v > MAX_SIZE:
        raise SceneError(
            f"mesh.{key}: expected a length below {MAX_SIZE:g} (its area must "
            f"be finite in double precision), found {v!r}"
        )
    return float(v)


def check_divisions(divisions: object, names: str) -> tuple[int, int]:
    """``divisions`` as two positive ints; ``names`` (e.g. ``"[nx, ny]"``) for the message."""
    try:
        a, b = divisions
        ok = all(isinstance(n, Integral) and not isinstance(n, bool) and n >= 1 for n in (a, b))
    except (TypeError, ValueError):
        ok = False
    if not ok:
        raise SceneError(
            f"mesh.divisions: expected two positive integers {names}, found {divisions!r}"
        )
    return int(a), int(b)


def check_cell(cell: object) -> None:
    if cell not in CELLS:
        raise SceneError(f'mesh.cell: expected "quadrilateral" or "triangle", found {cell!r}')


def _check_band(key: str, band, axis: str, extent: float):
    """A band ``[a, b]`` along ``axis`` validated and clipped to ``[0, extent]``."""
    tol = 1e-9 * extent
    try:
        a, b = band
    except (TypeError, ValueError):
        raise SceneError(
            f"{key}: expected two numbers [{axis}0, {axis}1], found {band!r}"
        ) from None
    if not (_is_number(a) and _is_number(b)):
        raise SceneError(f"{key}: expected two numbers [{axis}0, {axis}1], found {list(band)!r}")
    a, b = float(a), float(b)
    what = "length" if axis == "x" else "width"
    if not (math.isfinite(a) and math.isfinite(b)) or b - a <= tol:
        raise SceneError(
            f"{key}: expected an interval [{axis}0, {axis}1] with {axis}1 − {axis}0 "
            f"> {tol:.3g} (1e-9 of the {what}), found [{a:g}, {b:g}]"
        )
    if a < -tol or b > extent + tol:
        raise SceneError(
            f"{key}: [{a:g}, {b:g}] is not inside the body: it spans {axis} in [0, {extent:g}]"
        )
    return min(max(a, 0.0), extent), min(max(b, 0.0), extent)


def check_regions(
    regions: Sequence[Region], length: float, width: float, reserved: Sequence[str] = ()
) -> list[tuple[str, Band | None, Band | None]]:
    """Validated ``[(name, xband or None, yband or None)]`` clipped to the body.

    An item is ``(name, xband, yband)`` or the older ``(name, xband)``; names
    in ``reserved`` (built-in regions) are refused like the edge names.
    """
    out, seen = [], set()
    for i, item in enumerate(regions):
        key = f"mesh.regions.{i}"
        try:
            name, xband, yband = (*item, None) if len(item) == 2 else item
        except (TypeError, ValueError):
            raise SceneError(
                f"{key}: expected a name and bands x = [x0, x1] and/or y = [y0, y1], found {item!r}"
            ) from None
        if not isinstance(name, str) or not name:
            raise SceneError(f"{key}.name: expected a non-empty string, found {name!r}")
        if name in seen:
            raise SceneError(f"{key}.name: region '{name}' is defined twice")
        if name in EDGE_TAGS:
            raise SceneError(
                f"{key}.name: '{name}' is the name of an edge of the body; "
                "choose another region name"
            )
        if name in reserved:
            raise SceneError(
                f"{key}.name: '{name}' is a built-in region of this mesh; "
                "choose another region name"
            )
        seen.add(name)
        if xband is None and yband is None:
            raise SceneError(f"{key}: expected x = [a, b] and/or y = [a, b]")
        if xband is not None:
            xband = _check_band(f"{key}.x", xband, "x", length)
        if yband is not None:
            yband = _check_band(f"{key}.y", yband, "y", width)
        out.append((name, xband, yband))
    return out


def check_hinges(
    hinges: Sequence[str],
    length: float,
    width: float,
    builtin: Sequence[tuple[str, float, str]] = (),
) -> list[tuple[str, float, str]]:
    """Hinge lines ``[(axis, c, name)]``: the ``builtin`` ones, then ``hinges``.

    ``builtin`` is ``[(axis, c, name)]`` (already valid); each of ``hinges`` is
    a selector ``"x=c"`` / ``"y=c"`` named as written. SceneError naming
    ``hinge.N.where`` for a bad form, a line outside or on the boundary of the
    body, or a second hinge on one line (within 1e-9 of the extent).
    """
    if isinstance(hinges, (str, bytes)):
        raise SceneError(f'hinge: expected a list of "x=c" / "y=c" lines, found {hinges!r}')
    extent = {"x": length, "y": width}
    lines = [(axis, c, name, name) for axis, c, name in builtin]  # + label for messages
    for i, where in enumerate(hinges):
        key = f"hinge.{i}.where"
        match = _HINGE.fullmatch(where) if isinstance(where, str) else None
        try:
            c = float(match.group(2)) if match else math.nan
        except ValueError:
            c = math.nan
        if not math.isfinite(c):
            raise SceneError(
                f'{key}: expected "x=c" or "y=c" (a line of the mesh) with c '
                f"a finite number, found {where!r}"
            )
        axis = match.group(1)
        size, tol = extent[axis], 1e-9 * extent[axis]
        if c < -tol or c > size + tol:
            raise SceneError(
                f'{key}: "{where}" is not a line of the mesh: the body spans '
                f"{axis} in [0, {size:g}]"
            )
        if abs(c) <= tol or abs(c - size) <= tol:
            raise SceneError(
                f'{key}: "{where}" lies on the body\'s boundary; a hinge joins two sides'
            )
        for other_axis, other, _, label in lines:
            if other_axis == axis and abs(other - c) <= tol:
                raise SceneError(f"{key}: two hinges on one line: {label} and {key}")
        lines.append((axis, c, where, key))
    return [(axis, c, name) for axis, c, name, _ in lines]
