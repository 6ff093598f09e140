"""Several bodies in one scene: the ``[[body]]`` tables and the ``body`` key of the
entries that address one.

A scene with ``[[body]]`` tables is turned, once validated, into the scene of one
mesh made of all of them (:func:`expand`), so that every effect, the solver and the
outputs work on it as on any body: the mesh table becomes ``kind = "bodies"``
(built by ``rftfem.meshes.bodies``); an entry's ``where``, ``region`` and ``at``,
given in its body's own reference frame, become the combined mesh's names
(``"NAME:x=0"``, ``"NAME:REGION"``, ``"NAME"`` for the whole body) and placed
points; a body's ``shell`` values and ``[[body.parts]]`` become ``[[shell.parts]]``
on its cells; a three-link body's built-in hinges become ``[[hinge]]`` entries.
Each entry's selectors are checked against its own body's mesh first, with the
messages a one-body scene gives, under the entry's own key.
"""

from __future__ import annotations

import re
from typing import Any, Callable

import numpy as np

from rftfem.errors import SceneError
from rftfem.scene.material_keys import PART_MATERIAL
from rftfem.scene.mesh_keys import MESH, check_mesh
from rftfem.scene.schema import Array, Leaf, Str, Table, Vec, check_unique, fmt, suggest
from rftfem.scene.selectors import (
    THREE_LINK_HINGES,
    check_on_body,
    check_region_ref,
    check_where,
)

#: what separates a body's name from the names of its own mesh (rftfem.meshes.bodies)
SEPARATOR = ":"

SCHEMA = Array(
    Table(
        {
            "name": Leaf(
                Str(name=True),
                required=True,
                doc="The body's name: entries address it with `body = NAME`, and its "
                "columns in body.csv start with `NAME_`; unique.",
            ),
            "mesh": Table(
                MESH.fields,
                required=True,
                doc="The body's mesh, as `[mesh]` (any kind), in its own reference frame.",
            ),
            "at": Leaf(
                Vec(),
                [0.0, 0.0, 0.0],
                unit="length",
                doc="Where the body's own origin goes: its reference is turned (`turn`), "
                "then moved by `at`.",
            ),
            "turn": Leaf(
                Vec(),
                [0.0, 0.0, 0.0],
                unit="degree",
                doc="The body's rotation: degrees about X, then about Y, then about Z "
                "(fixed axes).",
            ),
            "shell": Table(
                PART_MATERIAL,
                doc="The body's own material values; what it leaves out comes from [shell].",
            ),
            "parts": Array(
                Table(
                    {
                        "region": Leaf(
                            Str(name=True),
                            required=True,
                            doc="A region of the body's own mesh; one part per region.",
                        ),
                        **PART_MATERIAL,
                    }
                ),
                doc="Material values that differ on a region of the body, as "
                "[[shell.parts]]; a part takes what it leaves out from the body's shell.",
            ),
        }
    ),
    doc="Several bodies in one scene, each with its own mesh, placement and shell "
    "(instead of [mesh]). They share the liquid, the field and the planes; they do "
    "not touch each other (no contact between bodies).",
)

BODY_KEY = Leaf(
    Str(name=True),
    None,
    default_doc='the only body; required with several bodies unless the entry is for "all" of them',
    doc="The [[body]] the entry is on: its `where`, `region` and `at` are in that "
    "body's own reference frame.",
)

#: the entries that may address a body, and the keys that select on it
_ENTRIES = {
    "boundary": ("where",),
    "load": ("where", "at"),
    "motion": ("where",),
    "output.probes": ("at",),
    "magnetic.parts": ("region",),
    "contact": (),  # a plane: no selector, on every body unless it names one
}


def _entries(scene: dict, path: str) -> list[dict]:
    node: Any = scene
    for key in path.split("."):
        node = (node or {}).get(key)
    return node or []


def _mesh_error(error: SceneError, i: int) -> SceneError:
    """A ``[mesh]`` message about body ``i``'s mesh, under its own key."""
    return SceneError(re.sub(r"(?<![\w.])mesh\.", f"body.{i}.mesh.", str(error)))


def body_names(scene: dict) -> list[str]:
    """The names of the scene's [[body]] tables (none: one [mesh] body)."""
    return [b["name"] for b in scene.get("body") or []]


def expand(scene: dict, has_mesh: bool) -> None:
    """Turn a validated scene with ``[[body]]`` tables into the scene of their one
    combined mesh (module doc), in place; a scene without them is left as it is,
    but for refusing a ``body`` key.  ``has_mesh``: whether the file gave [mesh]."""
    bodies = scene.get("body") or []
    names = [b["name"] for b in bodies]
    for path in (*_ENTRIES, "hinge"):
        for i, entry in enumerate(_entries(scene, path)):
            if entry.get("body") is not None and not bodies:
                raise SceneError(
                    f"{path}.{i}.body: names a body, found {fmt(entry['body'])}, but the "
                    "scene has no [[body]] tables (its [mesh] is the one body)"
                )
    if not bodies:  # one [mesh] body: the scene as it was before bodies existed
        scene.pop("body", None)
        for path in (*_ENTRIES, "hinge"):
            for entry in _entries(scene, path):
                entry.pop("body", None)
        return
    if has_mesh:
        raise SceneError(
            "mesh: a scene gives one body by [mesh] or several by [[body]] tables, not both"
        )
    _check_bodies(bodies)
    if scene["shell"]["parts"]:
        raise SceneError(
            "shell.parts: with [[body]] tables a region's values go in that body's [[body.parts]]"
        )
    hinges, built_in = _body_hinges(scene, bodies, names)
    own = {b["name"]: {"mesh": b["mesh"], "hinge": hinges[b["name"]]} for b in bodies}
    placed = {b["name"]: _placement(b) for b in bodies}
    _place_entries(scene, names, own, placed)
    scene["hinge"] += built_in
    scene["shell"]["parts"] = _parts(scene, bodies)
    scene["mesh"] = _combined_mesh(bodies)


def _check_bodies(bodies: list[dict]) -> None:
    """The [[body]] tables' names (unique, without the separator) and each one's mesh,
    under its own key."""
    check_unique(bodies, "name", "body", "body")
    for i, body in enumerate(bodies):
        if SEPARATOR in body["name"]:
            raise SceneError(
                f"body.{i}.name: expected a name without '{SEPARATOR}', found {fmt(body['name'])}"
            )
        try:
            check_mesh(body["mesh"])
        except SceneError as error:
            raise _mesh_error(error, i) from None


def _place_entries(
    scene: dict, names: list[str], own: dict[str, dict], placed: dict[str, Callable]
) -> None:
    """Each entry that selects on a body: checked against that body's own mesh
    (``own``), then its ``at`` placed and its ``where`` or ``region`` prefixed with
    the body's name."""
    for path, keys in _ENTRIES.items():
        for i, entry in enumerate(_entries(scene, path)):
            here = f"{path}.{i}"
            key = next((k for k in keys if entry.get(k) is not None), None)
            name = _entry_body(entry, here, key, names)
            if name is None:  # on every body
                continue
            entry["body"] = name
            if key == "at":
                check_on_body(entry["at"], f"{here}.at", _point_name(path), own[name])
                entry["at"] = [float(v) for v in placed[name](entry["at"])[0]]
            elif key == "region":
                check_region_ref(entry["region"], f"{here}.region", own[name])
                entry["region"] = _prefixed(name, entry["region"])
            elif key == "where":
                check_where(entry["where"], f"{here}.where", own[name])
                entry["where"] = _prefixed(name, entry["where"])


def _combined_mesh(bodies: list[dict]) -> dict:
    """The [mesh] table of the bodies' one mesh (``kind = "bodies"``)."""
    return {
        "kind": "bodies",
        "bodies": bodies,
        "length": None,
        "width": None,
        "link_width": None,
        "hinge_stiffness": None,
        "file": None,
        "regions": [],
    }


def _placement(body: dict):
    from rftfem.meshes.bodies import rotation

    R, at = rotation(body["turn"]), np.asarray(body["at"], dtype=float)
    return lambda x: np.asarray(x, dtype=float).reshape(-1, 3) @ R.T + at


def _prefixed(name: str, selector: str) -> str:
    return name if selector == "all" else f"{name}{SEPARATOR}{selector}"


def _point_name(path: str) -> str:
    return "probe" if path == "output.probes" else "point"


def _entry_body(entry: dict, here: str, key: str | None, names: list[str]) -> str | None:
    """The body an entry is on (checked), or None for every body (no selector, or
    ``"all"``, and no ``body``)."""
    name = entry.get("body")
    if name is None:
        if len(names) == 1:
            return names[0]
        if key is None or entry[key] == "all":
            return None
        raise SceneError(
            f"{here}.body: required with several bodies (one of {', '.join(names)}): "
            f"which body's {fmt(entry[key])}?"
        )
    if name not in names:
        raise SceneError(
            f"{here}.body: unknown body '{name}'; expected one of: {', '.join(names)}"
            + suggest(name, names)
        )
    return name


def _body_hinges(
    scene: dict, bodies: list[dict], names: list[str]
) -> tuple[dict[str, list[dict]], list[dict]]:
    """Each body's [[hinge]] tables, checked as a one-body scene checks them (their
    lines cut its own mesh), their lines renamed; and a three-link body's built-in
    hinges as [[hinge]] entries with its ``hinge_stiffness``."""
    from rftfem.model.effects.hinge import Hinges

    hinges: dict[str, list[dict]] = {n: [] for n in names}
    index: dict[str, list[int]] = {n: [] for n in names}  # their indices in [[hinge]]
    for i, hinge in enumerate(scene["hinge"]):
        name = _entry_body(hinge, f"hinge.{i}", "where", names)
        if name is None:
            raise SceneError(f"hinge.{i}.body: required with several bodies")
        hinges[name].append(dict(hinge))
        index[name].append(i)
        hinge["where"], hinge["body"] = _prefixed(name, hinge["where"]), name
    built_in = []
    for body in bodies:
        name = body["name"]
        try:
            Hinges.check({"mesh": body["mesh"], "hinge": hinges[name]})
        except SceneError as error:
            text = re.sub(
                r"hinge\.(\d+)\.", lambda m: f"hinge.{index[name][int(m[1])]}.", str(error)
            )
            raise _mesh_error(SceneError(text), names.index(name)) from None
        if body["mesh"]["kind"] == "three-link":
            k = body["mesh"]["hinge_stiffness"]
            built_in += [
                {"where": _prefixed(body["name"], line), "stiffness": k, "body": body["name"]}
                for line in THREE_LINK_HINGES
            ]
    return hinges, built_in


def _parts(scene: dict, bodies: list[dict]) -> list[dict]:
    """[[shell.parts]] of every body: its own shell values on all its cells, then its
    [[body.parts]] (each over the body's values)."""
    parts = []
    for i, body in enumerate(bodies):
        name = body["name"]
        values = {k: v for k, v in body["shell"].items() if v is not None}
        if values:
            parts.append({"region": name, **values})
        own = {"mesh": body["mesh"], "hinge": []}
        check_unique(body["parts"], "region", f"body.{i}.parts", "region")
        for j, part in enumerate(body["parts"]):
            check_region_ref(part["region"], f"body.{i}.parts.{j}.region", own)
            given = {k: v for k, v in part.items() if v is not None and k != "region"}
            parts.append({"region": _prefixed(name, part["region"]), **values, **given})
    return parts
