"""One key of a raw scene, addressed by its dotted path (``load.0.value``), set or
removed: what ``--set KEY=VALUE`` and ``--unset KEY`` do to the scene's table."""

from __future__ import annotations

import re
import tomllib
from typing import Any

from rftfem.errors import SceneError
from rftfem.scene.keys import SCHEMA
from rftfem.scene.schema import Array, Free, Leaf, Table, err, join, section, suggest

_BARE_WORD_RE = re.compile(r"""^[A-Za-z_./~][^\s"'\[\]{},#]*$""")


#: an override text that removes its key (``--unset KEY``) rather than setting it:
#: overrides travel as texts (summary.json, a sweep's child runs, a restart)
UNSET = "--unset "
#: the value set_key takes to remove a key
_REMOVE = object()


def unset_text(key: str) -> str:
    """The override text of ``--unset KEY``."""
    return UNSET + key.strip()


def apply_override(data: dict, text: str) -> None:
    """Apply one ``--set a.b.c=VALUE`` to the raw scene ``data`` (in place), or one
    ``--unset a.b.c`` (the text ``unset_text`` makes): the key is removed, and its
    default, or nothing, takes its place.

    VALUE is read as a TOML value; if it is not one but is a bare word
    (``triangle``, ``x=L``, ``plate.msh``) it is taken as a string. Arrays of
    tables are addressed by index (``load.0.value``). A path that is not in the
    schema, or an index out of range, raises SceneError naming the path. Missing
    tables on the way are created (``--set fluid.drag=[1,1,2]``).
    """
    if text.startswith(UNSET):
        unset_key(data, text[len(UNSET) :].strip())
        return
    key, sep, raw_value = text.partition("=")
    key = key.strip()
    if not sep or not key:
        raise SceneError(f"--set: expected KEY=VALUE (e.g. time.dt=0.005), found '{text}'")
    set_key(data, key, _parse_value(key, raw_value.strip()))


def unset_key(data: dict, key: str) -> list:
    """Remove the dotted ``key`` from the raw scene ``data`` (in place): a key of a
    table, or an entry of an array of tables (``load.1``; the later entries move
    up).  The path must be one the schema has; a key the scene does not set is left
    as it is.  Returns ``[the value removed]``, or ``[]``."""
    if not key:
        raise SceneError("--unset: expected a dotted key path like fluid.drag, found ''")
    removed = []
    try:
        set_key(data, key, _REMOVE, removed)
    except SceneError as exc:
        text = str(exc)
        raise SceneError(
            "--unset" + text[len("--set") :] if text.startswith("--set") else text
        ) from None
    return removed


def set_key(data: dict, key: str, value: Any, _removed: list | None = None) -> None:
    """Set the dotted ``key`` of the raw scene ``data`` to the Python ``value`` (in
    place), as ``--set`` does once it has read its value; errors name ``--set`` so
    that the Python API's messages are the command line's."""
    parts = key.split(".")
    if any(not p for p in parts):
        raise SceneError(
            f"--set {key}: expected a dotted key path like shell.thickness, "
            f"found an empty component"
        )

    spec: Any = SCHEMA
    node: Any = data
    path = ""
    for n, part in enumerate(parts):
        rest = parts[n + 1 :]
        if isinstance(spec, Table):
            step = _table_step(spec, node, path, part, rest, key, value, _removed)
        elif isinstance(spec, Array):
            step = _array_step(spec, node, path, part, rest, key, value, _removed)
        elif isinstance(spec, Free):
            _set_option(node, path, part, rest, key, value, _removed)
            return
        else:
            continue
        if step is None:
            return
        spec, node, path = step


def _table_step(
    spec: Table,
    node: dict,
    path: str,
    part: str,
    rest: list[str],
    key: str,
    value: Any,
    removed: list | None,
) -> tuple[Any, Any, str] | None:
    """The key ``part`` of the table ``node`` at ``path``: set or removed if it is the
    last of the path (None), else the schema, node and path of the next step
    (tables on the way created)."""
    here = join(path, part)
    if part not in spec.fields:
        raise SceneError(
            f"--set: unknown key '{here}'"
            + (
                suggest(part, spec.fields, path + "." if path else "")
                or f" (valid keys{' in ' + section(path) if path else ''}:"
                f" {', '.join(spec.fields)})"
            )
        )
    sub = spec.fields[part]
    if not rest:
        if value is _REMOVE:
            if part in node:
                removed.append(node.pop(part))
        else:
            node[part] = value
        return None
    if isinstance(sub, Leaf):
        if value is _REMOVE:
            raise SceneError(
                f"--unset {key}: '{here}' is a value: unset it whole, not one component"
            )
        _set_component(node, part, rest, key, here, value)
        return None
    if part not in node:
        if value is _REMOVE:
            return None  # nothing on the way, nothing to remove
        node[part] = [] if isinstance(sub, Array) else {}
    child = node[part]
    if isinstance(sub, Array):
        if not isinstance(child, list):
            raise err(here, f"an array of tables [[{here}]]", child)
    elif not isinstance(child, dict):
        raise err(here, f"a table {section(here)}", child)
    return sub, child, here


def _array_step(
    spec: Array,
    node: list,
    path: str,
    part: str,
    rest: list[str],
    key: str,
    value: Any,
    removed: list | None,
) -> tuple[Any, Any, str] | None:
    """The entry ``part`` (an index) of the array of tables ``node`` at ``path``: set
    or removed if it is the last of the path (None), else the next step's schema,
    node and path."""
    here = join(path, part)
    if not re.fullmatch(r"\d+", part):
        raise SceneError(
            f"--set {key}: expected an index into [[{path}]] after '{path}', found '{part}'"
        )
    index = int(part)
    if index >= len(node):
        raise SceneError(
            f"--set {key}: index {index} out of range, the scene has "
            f"{len(node)} [[{path}]] entr{'y' if len(node) == 1 else 'ies'}"
        )
    if not rest:
        if value is _REMOVE:
            removed.append(node.pop(index))
        else:
            node[index] = value
        return None
    if not isinstance(node[index], dict):
        raise err(here, "a table", node[index])
    return spec.item, node[index], here


def _set_option(
    node: dict, path: str, part: str, rest: list[str], key: str, value: Any, removed: list | None
) -> None:
    """The PETSc option ``part`` of the table ``node`` at ``path``, set or removed."""
    if rest:
        raise SceneError(f"--set {key}: '{join(path, part)}' is a PETSc option, not a table")
    if value is _REMOVE:
        if part in node:
            removed.append(node.pop(part))
    else:
        node[part] = value


def _set_component(node: dict, part: str, rest: list[str], key: str, here: str, value: Any) -> None:
    """``--set load.0.value.2=3``: one component of the vector at ``here`` (the same
    addresses as ``rftfem optimize --vary`` and the quantities' ``scene(KEY)``)."""
    if len(rest) != 1 or not re.fullmatch(r"\d+", rest[0]):
        raise SceneError(
            f"--set {key}: '{here}' is a value, not a table, so '{key}' does not exist"
        )
    vector = node.get(part)
    if not isinstance(vector, list):
        raise SceneError(
            f"--set {key}: '{here}' is "
            + ("not set in the scene" if vector is None else f"{vector!r}, not a vector")
            + f", so it has no component {rest[0]}; set the whole value"
        )
    index = int(rest[0])
    if index >= len(vector):
        raise SceneError(
            f"--set {key}: index {index} out of range, '{here}' has {len(vector)} components"
        )
    vector[index] = value


def _parse_value(key: str, text: str) -> Any:
    if "\n" not in text and "\r" not in text:
        try:
            parsed = tomllib.loads("v = " + text)
        except tomllib.TOMLDecodeError:
            parsed = None
        if parsed is not None and list(parsed) == ["v"]:
            return parsed["v"]
    if _BARE_WORD_RE.match(text):
        return text
    raise SceneError(
        f"--set {key}: expected a TOML value (a number, true/false, "
        f"\"string\", [array] or bare word), found '{text}'"
    )
