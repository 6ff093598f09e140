"""The "scene keys" part of docs/scenes.md (:mod:`rftfem.reference`): a section per
table of the scene's schema, a row per key, walked in schema order."""

from __future__ import annotations

from typing import Any, Iterator

from rftfem.scene import reading as _scene
from rftfem.scene import schema as _schema
from rftfem.scene import toml_writer

#: the command that rewrites docs/scenes.md's generated parts
REGENERATE = "python -m rftfem.reference"


class UndocumentedKey(ValueError):
    """A schema key the reference cannot describe (no ``doc``, or no default text)."""


def _toml(value: Any) -> str:
    """A default value as it would be written in a scene."""
    return toml_writer.value(value)


def _cell(text: str) -> str:
    """Text for one cell of a Markdown table."""
    return " ".join(str(text).split()).replace("|", "\\|")


def _heading(display: str) -> str:
    return display if display.startswith("[[") else f"[{display}]"


def _require_doc(node: Any, path: str) -> str:
    doc = (getattr(node, "doc", "") or "").strip()
    if not doc:
        raise UndocumentedKey(
            f"scene key '{path}' has no doc: give its schema node in "
            "rftfem/scene/keys.py, rftfem/scene/mesh_keys.py or its effect's module in "
            "rftfem/model/effects a "
            'doc="..." (what it means), then run '
            f"{REGENERATE}"
        )
    return doc


def _default(leaf: Any, path: str) -> str:
    if leaf.required:
        return "required"
    if leaf.default_doc:
        return leaf.default_doc
    if leaf.default is None:
        raise UndocumentedKey(
            f"scene key '{path}' has no default and no default_doc: say "
            "in its schema node what a scene without it gets "
            '(default_doc="...")'
        )
    return f"`{_toml(leaf.default)}`"


def _join(display: str, key: str) -> str:
    return f"{display}.{key}" if display else key


def _array_item(path: str) -> str:
    """An array's heading, ``[[load]]``; in an array's entries TOML's own spelling,
    ``[[body.parts]]`` (not ``[[[[body]].parts]]``)."""
    return f"[[{path.replace(']].', '.').lstrip('[')}]]"


def walk(schema: Any = None) -> Iterator[tuple[str, Any]]:
    """``(display path, node)`` of every node below ``schema``, depth first in schema
    order: ``mesh``, ``mesh.kind``, ..., ``[[mesh.regions]]``, ``[[mesh.regions]].name``,
    ...; the keys of a ``_Free`` table appear as ``solver.*``."""
    schema = _scene.SCHEMA if schema is None else schema

    def visit(table, display):
        for key, sub in table.fields.items():
            path = _join(display, key)
            if isinstance(sub, _schema.Array):
                item = _array_item(path)
                yield item, sub
                yield from visit(sub.item, item)
            elif isinstance(sub, _schema.Table):
                yield path, sub
                yield from visit(sub, path)
            elif isinstance(sub, _schema.Free):
                yield path, sub
                yield path + ".*", sub
            else:
                yield path, sub

    yield from visit(schema, "")


def documented_paths(schema: Any = None) -> list[str]:
    """Every key path the reference lists (tables as ``[mesh]``, arrays as ``[[load]]``)."""
    out = []
    for path, node in walk(schema):
        if isinstance(node, _schema.Leaf) or path.endswith(".*"):
            out.append(path)
        else:
            out.append(_heading(path))
    return out


def _status(node: Any) -> str:
    if isinstance(node, _schema.Array):
        if node.min_items:
            n = node.min_items
            return f"Array of tables, at least {n} entr{'y' if n == 1 else 'ies'}."
        return "Optional array of tables, any number of entries."
    if isinstance(node, _schema.Free):
        return "Optional table."
    if node.required:
        return "Required table."
    if node.optional:
        return "Optional table; without it the effect is off."
    return "Optional table; without it every key takes its default."


_HEADER = [
    "| Key | Accepted values | Default | Unit | Meaning |",
    "| --- | --- | --- | --- | --- |",
]


#: a section of the reference: its heading, its text and its table's rows
_Section = tuple[str, str, list[str]]


def _row(*cells: str) -> str:
    """One row of a Markdown table."""
    return "| " + " | ".join(cells) + " |"


def _key_rows(display: str, fields: dict[str, Any]) -> list[str]:
    """One row per key of a table (its leaves; the tables below it have their sections)."""
    rows: list[str] = []
    for key, sub in fields.items():
        path = _join(display, key)
        if isinstance(sub, _schema.Leaf):
            doc = _require_doc(sub, path)
            rows.append(
                _row(
                    f"`{path}`",
                    _cell(sub.check.describe(key)),
                    _cell(_default(sub, path)),
                    _cell(sub.unit or "—"),
                    _cell(doc),
                )
            )
    return rows


def _free_section(path: str, sub: Any) -> _Section:
    """The section of a ``_Free`` table: one row for all its keys, ``path.*``."""
    doc = _require_doc(sub, path)
    row = _row(
        f"`{path}.*`",
        _cell(sub.expected),
        sub.entry_default,
        "—",
        _cell(sub.entry_doc.format(path=path)),
    )
    return (f"`[{path}]`", f"{_status(sub)} {doc}", [row])


def _kinds_sections(path: str, sub: Any) -> list[_Section]:
    """The sections of an array of kinds (``[[load]]``): its common keys, then each kind's."""
    item = f"[[{path}]]"
    out = _sections(
        item, _schema.Table(sub.common), f"`{item}`", f"{_status(sub)} {_require_doc(sub, item)}"
    )
    for kind, fields in sub.kinds.items():
        text = sub.kind_docs.get(kind) or ""
        if not text:
            raise UndocumentedKey(f"{item} kind '{kind}' has no doc")
        out += _sections(item, _schema.Table(fields), f'`{item}` with kind = "{kind}"', text)
    return out


def _sections(display: str, node: Any, title: str, text: str) -> list[_Section]:
    """The section of the table ``node``, then those of the tables below it, depth first."""
    fields = node.item.fields if isinstance(node, _schema.Array) else node.fields
    out = [(title, text, _key_rows(display, fields))]
    for key, sub in fields.items():
        path = _join(display, key)
        if isinstance(sub, _schema.Kinds):
            out += _kinds_sections(path, sub)
        elif isinstance(sub, _schema.Array):
            item = _array_item(path)
            out += _sections(item, sub, f"`{item}`", f"{_status(sub)} {_require_doc(sub, item)}")
        elif isinstance(sub, _schema.Table):
            title = f"`{path}`" if display[:2] == "[[" else f"`[{path}]`"  # in an array entry
            out += _sections(path, sub, title, f"{_status(sub)} {_require_doc(sub, path)}")
        elif isinstance(sub, _schema.Free):
            out.append(_free_section(path, sub))
    return out


def scene_keys_markdown(schema: Any = None) -> str:
    """The "scene keys" part: one section per table, one row per key."""
    schema = _scene.SCHEMA if schema is None else schema
    _require_doc(schema, "(the top level)")
    sections = _sections("", schema, "Top level", _require_doc(schema, "(the top level)"))
    out = [
        f"<!-- do not edit by hand: {REGENERATE} rewrites this part from "
        "the schema (rftfem/scene/reading.py, rftfem/scene/mesh_keys.py, rftfem/model/effects) -->",
        "",
    ]
    for title, text, rows in sections:
        out += [f"### {title}", "", " ".join(text.split()), ""]
        if rows:
            out += _HEADER + rows + [""]
    return "\n".join(out).rstrip("\n")
