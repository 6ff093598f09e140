"""Scenes: read a TOML scene, apply ``--set`` overrides, validate, fill defaults.

The keys are the user-facing contract documented in docs/scenes.md, whose "Scene
keys" part is generated from :data:`SCHEMA` (``python -m rftfem.reference``).
This module reads the file (or text, or a dict) and applies ``--set`` (one
dotted key set or removed: :mod:`rftfem.scene.dotted_keys`); the
tables ``title``, ``[shell]``, ``[time]``, ``[output]`` and ``[solver]`` and the
checks across them are in :mod:`rftfem.scene.keys` (``[mesh]`` in
:mod:`rftfem.scene.mesh_keys`). Every effect component
(:mod:`rftfem.model.effects`) brings its own keys (``[fluid]``, ``[magnetic]``,
``[[hinge]]``, ``[[boundary]]``, ``[[motion]]``, and its ``[[load]]`` kinds) and
checks them. :func:`load_scene` returns a plain nested ``dict``
(JSON-serialisable, so it can be echoed in summary.json) in which every key of
the schema is present:

- scalars and arrays get their documented default;
- optional arrays of tables (``boundary``, ``load``, ``motion``, ``hinge``,
  ``mesh.regions``, ``shell.parts``, ``output.probes``) default to ``[]``;
- the optional effect tables ``fluid`` and ``magnetic`` are ``None`` when the
  scene does not have them (``if scene["fluid"]:`` switches the effect);
- keys that only apply to another variant are ``None`` (``mesh.file`` unless
  ``kind = "gmsh"``, ``mesh.link_width`` and ``mesh.hinge_stiffness`` unless
  ``kind = "three-link"``, ``load.N.table`` unless ``ramp = "table"``,
  ``motion.N.values`` unless ``kind = "table"``); a ``[[load]]`` entry has the
  keys of its kind only;
- ``mesh.width`` is the body's width: 1.0 by default, ``3 * link_width`` for
  ``kind = "three-link"``;
- a ``shell.parts`` entry inherits every material value it does not set
  (E, nu, thickness, density) from ``[shell]``;
- ``time.scheme`` holds the resolved scheme (never ``"auto"``);
- ``mesh.file`` is an absolute path; ``scene["_path"]`` is the absolute path of
  the scene file.

Every problem raises :class:`rftfem.errors.SceneError` with a one-line message
that names the full key path (``load.0.value``), what was expected and what was
found. Checks that need the mesh (gmsh physical-group names, a ``where`` that
matches no dof) are left to the model and its components. Scenes are data:
nothing in them is evaluated.
"""

from __future__ import annotations

import os
import tomllib
from pathlib import Path
from typing import Iterable

from rftfem.errors import SceneError
from rftfem.model import effects
from rftfem.scene import bodies
from rftfem.scene.dotted_keys import UNSET as UNSET  # (rftfem.scene.overrides reads it here)
from rftfem.scene.dotted_keys import apply_override, set_key, unset_key, unset_text
from rftfem.scene.keys import SCHEMA, cross_check
from rftfem.scene.schema import validate_table
from rftfem.scene.selectors import hinge_line
from rftfem.scene.time_rules import resolved_scheme
from rftfem.scene.validators import fmt, scene_parameters

__all__ = [
    "load_scene",
    "apply_override",
    "set_key",
    "unset_key",
    "unset_text",
    "read_scene_file",
    "parse_scene_text",
    "complete_scene",
    "with_overrides",
    "active_effects",
    "resolved_scheme",
    "hinge_line",
    "SCHEMA",
]


def read_scene_file(path: str | os.PathLike) -> dict:
    """The raw TOML table of the scene file ``path`` (nothing checked but TOML)."""
    shown = str(path)
    try:
        data = Path(path).expanduser().read_bytes()
    except FileNotFoundError:
        raise SceneError(f"scene file '{shown}' not found") from None
    except IsADirectoryError:
        raise SceneError(f"scene file '{shown}': expected a TOML file, found a directory") from None
    except OSError as exc:
        raise SceneError(f"cannot read scene file '{shown}': {exc.strerror or exc}") from None
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        raise SceneError(
            f"scene file '{shown}': expected a UTF-8 TOML file, found binary or non-UTF-8 data"
        ) from None
    return parse_scene_text(text, f"scene file '{shown}'")


def parse_scene_text(text: str, shown: str = "scene text") -> dict:
    """The raw TOML table of a scene given as text; ``shown`` names it in errors."""
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        msg = " ".join(str(exc).split())
        raise SceneError(f"{shown} is not valid TOML: {msg}") from None


def load_scene(path: str | os.PathLike, overrides: Iterable[str] = ()) -> dict:
    """Read, override, validate and complete the scene in ``path`` (see module doc)."""
    raw = read_scene_file(path)
    overrides = list(overrides)
    for text in overrides:
        apply_override(raw, text)
    scene_path = Path(path).expanduser().resolve()
    return complete_scene(raw, scene_path.parent, scene_path, overrides)


def complete_scene(
    raw: dict,
    folder: str | os.PathLike,
    path: str | os.PathLike | None = None,
    overrides: Iterable[str] = (),
) -> dict:
    """Validate and complete the raw scene table ``raw`` (left as it is): relative
    files (``mesh.file``, profiles) are read from ``folder``; ``path`` is the scene
    file, if there is one, and ``overrides`` the ``--set`` texts already applied,
    both for the record (summary.json)."""
    import copy

    kept = copy.deepcopy(raw)
    raw = copy.deepcopy(raw)  # validation fills defaults in the tables it is given
    # the [parameters] first: the formulas that use them are validated with their numbers
    parameters = SCHEMA.fields["parameters"].validate(raw.get("parameters", {}), "parameters")
    with scene_parameters(parameters):
        has_mesh = "mesh" in raw
        if not has_mesh and raw.get("body"):  # [[body]] tables stand for [mesh]
            raw["mesh"] = {}
        scene = validate_table(SCHEMA, raw, "")
        bodies.expand(scene, has_mesh)
        cross_check(scene)
    scene["time"]["scheme"] = resolved_scheme(scene)

    folder = Path(folder).expanduser().resolve()
    meshes = scene["mesh"]["bodies"] if scene["mesh"]["kind"] == "bodies" else [scene]
    for i, body in enumerate(meshes):
        if body["mesh"]["kind"] == "gmsh":
            key = "mesh.file" if body is scene else f"body.{i}.mesh.file"
            body["mesh"]["file"] = _mesh_file(body["mesh"]["file"], folder, key)
    scene["_path"] = None if path is None else str(path)
    scene["_folder"] = str(folder)
    scene["_overrides"] = list(overrides)
    scene["_raw"] = kept
    return scene


def _mesh_file(given: str, folder: Path, key: str) -> str:
    """The absolute path of a gmsh mesh file named in the scene (relative to its
    folder), which must be a readable file; else a SceneError at ``key``."""
    mesh_file = (folder / Path(given).expanduser()).resolve()
    try:
        found, regular = mesh_file.exists(), mesh_file.is_file()
    except OSError as exc:  # a name too long for the file system, a looping link...
        raise SceneError(
            f"{key}: expected a readable gmsh mesh file, found "
            f"{fmt(given)} which cannot be looked up ({exc.strerror or exc})"
        ) from None
    if not found:
        raise SceneError(
            f"{key}: expected a readable gmsh mesh file, found "
            f"'{given}' which does not exist ({mesh_file})"
        )
    if not regular:
        raise SceneError(
            f"{key}: expected a readable gmsh mesh file, found "
            f"'{given}' which is not a regular file ({mesh_file})"
        )
    try:
        with open(mesh_file, "rb") as fh:
            fh.read(1)
    except OSError as exc:
        raise SceneError(
            f"{key}: expected a readable gmsh mesh file, found "
            f"'{given}' which cannot be read "
            f"({exc.strerror or exc})"
        ) from None
    return str(mesh_file)


def with_overrides(scene: dict, overrides: Iterable[str]) -> dict:
    """A completed scene like ``scene`` with the ``--set`` texts ``overrides`` applied
    after its own (the scene file is not read again)."""
    import copy

    raw = copy.deepcopy(scene["_raw"])
    overrides = list(overrides)
    for text in overrides:
        apply_override(raw, text)
    return complete_scene(
        raw, scene["_folder"], scene["_path"], [*scene.get("_overrides", []), *overrides]
    )


def active_effects(scene: dict) -> list[str]:
    """The effects the scene asks for, in the registry's order (rftfem/model/effects)."""
    return effects.active_effects(scene)
