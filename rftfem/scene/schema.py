"""The scene-file schema: its nodes and the walk that validates a scene against them.

A schema is a tree of :class:`Table` (a TOML table with known keys),
:class:`Array` (an array of tables), :class:`Kinds` (an array of tables whose
keys depend on their ``kind``), :class:`Free` (PETSc options) and
:class:`Leaf` (one value, checked by a :class:`Validator`).  Every node carries
``doc`` and leaves a ``unit``; docs/scenes.md is generated from them
(:mod:`rftfem.reference`).  :func:`validate_table` walks raw TOML data
against a node, fills defaults and raises :class:`~rftfem.errors.SceneError`
with a one-line message naming the key path, what was expected and what was
found.  The scene's own tables live in :mod:`rftfem.scene.reading` and, for each
effect, in its module under :mod:`rftfem.model.effects`.
"""

from __future__ import annotations

import math
import re
from typing import Any, Sequence

from rftfem.errors import SceneError

# rftfem's own [solver] keys, read from here too (rftfem.petsc_options)
from rftfem.scene.solver_keys import FACTORIZATIONS as FACTORIZATIONS
from rftfem.scene.solver_keys import MATRIX_TYPES as MATRIX_TYPES
from rftfem.scene.solver_keys import TANGENTS as TANGENTS
from rftfem.scene.solver_keys import check_factorization as check_factorization
from rftfem.scene.solver_keys import check_matrix_type as check_matrix_type
from rftfem.scene.solver_keys import check_tangent as check_tangent
from rftfem.scene.validators import (
    NONNEGATIVE,
    POSITIVE,
    Bool,
    Divisions,
    Fix,
    Formula,
    Formulas,
    Int,
    Num,
    Pairs,
    Rows,
    Str,
    Validator,
    Vec,
    Where,
    err,
    fmt,
    join,
    one_of,
    suggest,
)

__all__ = [  # the validators and message helpers too: a table is written with one import
    "Leaf",
    "Table",
    "Array",
    "Kinds",
    "Free",
    "Parameters",
    "validate_table",
    "check_unique",
    "table_iff",
    "unit_vector",
    "copy_value",
    "section",
    "MAX_STEPS",
    "NONNEGATIVE",
    "POSITIVE",
    "Bool",
    "Divisions",
    "Fix",
    "Formula",
    "Formulas",
    "Int",
    "Num",
    "Pairs",
    "Rows",
    "Str",
    "Validator",
    "Vec",
    "Where",
    "err",
    "fmt",
    "join",
    "one_of",
    "suggest",
]

_PETSC_KEY_RE = re.compile(r"^[a-z][a-z0-9_]*$")

# Every node of the schema carries ``doc`` (what the key means, one or two
# sentences) and leaves a ``unit`` where they have one: the scene reference in
# docs/scenes.md is generated from them (rftfem/reference.py), which
# refuses a key without ``doc``. Units are dimensions ("length", "force/length²"),
# since a scene uses consistent units of the user's choice. ``default_doc`` says
# in words what a leaf whose default is not a plain value gets (filled in by the
# cross checks, inherited, or only used with another key's value).


class Leaf:
    def __init__(
        self,
        check: Validator,
        default: Any = None,
        required: bool = False,
        *,
        doc: str = "",
        unit: str = "",
        default_doc: str | None = None,
    ):
        self.check, self.default, self.required = check, default, required
        self.doc, self.unit, self.default_doc = doc, unit, default_doc


class Table:
    """A TOML table with known keys. ``optional``: absent -> None (not filled)."""

    def __init__(
        self,
        fields: dict[str, Any],
        required: bool = False,
        optional: bool = False,
        *,
        doc: str = "",
    ):
        self.fields, self.required, self.optional = fields, required, optional
        self.doc = doc


class Array:
    """An array of tables ([[name]]), each with the schema ``item``."""

    def __init__(self, item: Table, min_items: int = 0, *, doc: str = ""):
        self.item, self.min_items = item, min_items
        self.doc = doc


class Kinds(Array):
    """An array of tables whose keys depend on their ``kind`` (``[[load]]``).

    Each entry has the ``common`` keys (``kind`` among them, first) and the keys
    of its kind, ``kinds[kind]``.  :attr:`item` is the union of all of them (for
    ``--set`` paths and walking the schema); :meth:`table_of` is one kind's table
    (for validation and the reference).  A key of another kind is refused with a
    message that names the kinds that use it.
    """

    def __init__(
        self,
        common: dict[str, Leaf],
        kinds: dict[str, dict[str, Leaf]],
        kind_docs: dict[str, str],
        *,
        doc: str = "",
    ):
        self.common, self.kinds, self.kind_docs = common, kinds, kind_docs
        first = dict(list(common.items())[:1])
        union = dict(first)
        for fields in kinds.values():
            for key, leaf in fields.items():
                union.setdefault(key, leaf)
        union.update(common)
        super().__init__(Table(union), doc=doc)

    def table_of(self, kind: str) -> Table:
        items = list(self.common.items())
        return Table(dict(items[:1] + list(self.kinds[kind].items()) + items[1:]))


class Free:
    """A table of PETSc options: any lowercase key, scalar values."""

    expected = (
        "any PETSc option name without prefix or dash (lowercase letters, digits, "
        "'_'); a string, number or boolean"
    )
    #: the reference's row for its keys: default and meaning (``{path}`` is its path)
    entry_default = "none: rftfem's own solver options apply"
    entry_doc = "Any PETSc option of the solve, e.g. `{path}.snes_rtol = 1e-10`."

    def __init__(self, *, doc: str = ""):
        self.doc = doc

    def validate(self, raw: Any, path: str) -> dict:
        return _validate_free(raw, path)


class Parameters(Free):
    """A table of named numbers that the scene's formulas may use."""

    expected = (
        "a name (letters, digits, '_', not starting with a digit, not a function, "
        "pi or a coordinate) = a finite number"
    )
    entry_default = "none"
    entry_doc = (
        "A number the scene's formulas may use by its name, e.g. `{path}.wavelength "
        '= 3.7` with `direction = ["cos(2*pi*X/wavelength)", ...]`; '
        "`--set {path}.wavelength=5` changes it everywhere."
    )

    def validate(self, raw: Any, path: str) -> dict:
        from rftfem.scene.expressions import RESERVED

        if not isinstance(raw, dict):
            raise err(path, f"a table {section(path)} of named numbers", raw)
        out = {}
        for key, value in raw.items():
            kp = join(path, key)
            if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", key) or key in RESERVED:
                raise SceneError(
                    f"{kp}: expected a parameter name (letters, digits, '_', "
                    f"not starting with a digit, not one of the formulas' own "
                    f"names), found '{key}'"
                )
            if (
                isinstance(value, bool)
                or not isinstance(value, (int, float))
                or not math.isfinite(value)
            ):
                raise err(kp, "a finite number", value)
            out[key] = float(value) if isinstance(value, float) else value
        return out


#: the most time steps a scene may ask for (time.end / time.dt)
MAX_STEPS = 1e9


def unit_vector(v: Sequence[float]) -> tuple[float, float, float]:
    """``v / |v|`` for a nonzero 3-vector of any finite size (scaled first: no overflow)."""
    scale = max(abs(x) for x in v)
    w = [x / scale for x in v]
    n = math.hypot(*w)
    return tuple(x / n for x in w)


def section(path: str) -> str:
    return f"[{path}]"


def validate_table(spec: Table, raw: Any, path: str) -> dict:
    if not isinstance(raw, dict):
        raise err(path, f"a table {section(path)}", raw)
    for key in raw:
        if key not in spec.fields:
            where = f"'{join(path, key)}'"
            raise SceneError(
                f"unknown key {where}"
                + (
                    suggest(key, spec.fields, path + "." if path else "")
                    or f" (valid keys{' in ' + section(path) if path else ''}: "
                    f"{', '.join(spec.fields)})"
                )
            )
    out: dict[str, Any] = {}
    for key, sub in spec.fields.items():
        sub_path = join(path, key)
        present = key in raw
        value = raw.get(key)
        if isinstance(sub, Leaf):
            if not present:
                if sub.required:
                    raise SceneError(
                        f"missing required key '{sub_path}' (expected {sub.check.expected})"
                    )
                out[key] = copy_value(sub.default)
            else:
                out[key] = sub.check(value, sub_path)
        elif isinstance(sub, Table):
            if not present:
                if sub.required:
                    raise SceneError(f"missing required section {section(sub_path)}")
                out[key] = None if sub.optional else validate_table(sub, {}, sub_path)
            else:
                out[key] = validate_table(sub, value, sub_path)
        elif isinstance(sub, Kinds):
            out[key] = _validate_kinds(sub, value if present else [], sub_path)
        elif isinstance(sub, Array):
            out[key] = _validate_array(sub, value if present else [], sub_path)
        elif isinstance(sub, Free):
            out[key] = sub.validate(value if present else {}, sub_path)
    return out


def _validate_kinds(spec: Kinds, raw: Any, path: str) -> list:
    _check_array(spec, raw, path)
    out = []
    for i, item in enumerate(raw):
        here = join(path, i)
        kind = item.get("kind")
        if not isinstance(kind, str) or kind not in spec.kinds:  # its own check says why
            out.append(validate_table(spec.item, item, here))
            continue
        table = spec.table_of(kind)
        for key in item:
            users = [k for k, fields in spec.kinds.items() if key in fields]
            if key not in table.fields and users:
                raise SceneError(
                    f"{join(here, key)}: only used with kind = "
                    + " or ".join(f'"{k}"' for k in users)
                    + f", found kind = {fmt(kind)}"
                )
        out.append(validate_table(table, item, here))
    return out


def _check_array(spec: Array, raw: Any, path: str) -> None:
    if isinstance(raw, dict):
        raise err(path, f"an array of tables [[{path}]]", raw, f" (write [[{path}]], not [{path}])")
    if not isinstance(raw, list) or any(not isinstance(v, dict) for v in raw):
        raise err(path, f"an array of tables [[{path}]]", raw)
    if len(raw) < spec.min_items:
        raise SceneError(
            f"{path}: expected at least {spec.min_items} [[{path}]] "
            f"entr{'y' if spec.min_items == 1 else 'ies'}, found {len(raw)}"
        )


def _validate_array(spec: Array, raw: Any, path: str) -> list:
    _check_array(spec, raw, path)
    return [validate_table(spec.item, item, join(path, i)) for i, item in enumerate(raw)]


def _validate_free(raw: Any, path: str) -> dict:
    if not isinstance(raw, dict):
        raise err(path, f"a table {section(path)} of PETSc options", raw)
    out = {}
    for key, value in raw.items():
        kp = join(path, key)
        if not _PETSC_KEY_RE.match(key):
            raise SceneError(
                f"{kp}: expected a PETSc option name without prefix or dash "
                f"(lowercase letters, digits, '_'), found '{key}'"
            )
        if isinstance(value, float) and not math.isfinite(value):
            raise err(kp, "a finite number", value)
        if not isinstance(value, (str, int, float, bool)):
            raise err(kp, "a string, number or boolean", value)
        out[key] = value
    return out


def copy_value(value: Any) -> Any:
    if isinstance(value, list):
        return [copy_value(v) for v in value]
    if isinstance(value, dict):
        return {k: copy_value(v) for k, v in value.items()}
    return value


def check_unique(items: list[dict], key: str, path: str, what: str) -> None:
    seen: set[str] = set()
    for i, item in enumerate(items):
        name = item[key]
        if name in seen:
            raise SceneError(
                f"{path}.{i}.{key}: expected a unique {what} name, found '{name}' a second time"
            )
        seen.add(name)


def table_iff(entry: dict, path: str, switch: str, key: str, what: str) -> None:
    """``entry[key]`` is required when ``entry[switch] == "table"`` and refused otherwise."""
    if entry[switch] == "table" and entry[key] is None:
        raise SceneError(
            f"missing required key '{path}.{key}' (expected a list of {what}, "
            f'because {path}.{switch} = "table")'
        )
    if entry[switch] != "table" and entry[key] is not None:
        raise SceneError(
            f'{path}.{key}: only used with {switch} = "table", found '
            f"{path}.{switch} = {fmt(entry[switch])}"
        )
