"""Scenes: read a TOML scene, apply ``--set`` overrides, validate, fill defaults.

The keys are the user-facing contract documented in docs/scenes.md, whose "Scene
keys" part is generated from :data:`SCHEMA` (``python -m rftfem.scene_reference``):
every key carries its meaning (``doc``) and unit here. :func:`load_scene` returns a
plain nested ``dict`` (JSON-serialisable, so it can be echoed in summary.json)
in which every key of the schema is present:

- scalars and arrays get their documented default;
- optional arrays of tables (``boundary``, ``load``, ``motion``, ``hinge``,
  ``mesh.regions``, ``shell.parts``, ``output.probes``) default to ``[]``;
- the optional effect tables ``fluid`` and ``magnetic`` are ``None`` when the
  scene does not have them (``if scene["fluid"]:`` switches the effect);
- keys that only apply to another variant are ``None`` (``mesh.file`` unless
  ``kind = "gmsh"``, ``mesh.link_width`` and ``mesh.hinge_stiffness`` unless
  ``kind = "three-link"``, ``load.N.table`` unless ``ramp = "table"``,
  ``motion.N.values`` unless ``kind = "table"``);
- ``mesh.width`` is the body's width: 1.0 by default, ``3 * link_width`` for
  ``kind = "three-link"`` (where a user-given ``mesh.width`` is refused; the
  defaults there are ``link_width = 0.5``, ``hinge_stiffness = 0.0``);
- a ``mesh.regions`` entry has ``x`` and/or ``y`` (an interval); the one it does
  not give is ``None``. A three-link mesh has the built-in regions ``left``,
  ``middle`` and ``right`` (not listed in ``mesh.regions``, not redefinable)
  and the built-in hinges at ``y = w`` and ``y = 2w`` (``hinge-left``,
  ``hinge-right``; not listed in ``hinge``);
- a ``hinge`` entry's ``stiffness`` defaults to 0.0 (a free hinge);
- a ``shell.parts`` entry inherits every material value it does not set
  (E, nu, thickness, density) from ``[shell]``;
- ``time.scheme`` holds the resolved scheme (never ``"auto"``);
- ``mesh.file`` is an absolute path; ``scene["_path"]`` is the absolute path of
  the scene file.

Every problem raises :class:`rftfem.errors.SceneError` with a one-line message
that names the full key path (``load.0.value``), what was expected and what was
found. Checks that need the mesh (gmsh physical-group names, a ``where`` that
matches no dof) are left to the simulation module. Scenes are data: nothing in
them is evaluated.
"""

from __future__ import annotations

import difflib
import math
import os
import re
import tomllib
from pathlib import Path
from typing import Any, Iterable

from rftfem.errors import SceneError

__all__ = ["load_scene", "apply_override", "active_effects", "resolved_scheme",
           "EDGE_SELECTORS", "SPECIAL_SELECTORS", "THREE_LINK_REGIONS", "THREE_LINK_HINGES",
           "hinge_line"]

#: ``where`` selectors that always exist on a strip (besides region names).
EDGE_SELECTORS = ("x=0", "x=L", "y=0", "y=W")
SPECIAL_SELECTORS = ("all",) + EDGE_SELECTORS
#: the built-in regions (across Y: left, middle, right) and hinge lines of a three-link body
THREE_LINK_REGIONS = ("left", "middle", "right")
THREE_LINK_HINGES = ("hinge-left", "hinge-right")
#: mesh kinds made of straight lines x = const, y = const (strip-like rectangles)
_LINED_KINDS = ("strip", "three-link")
_BODY = {"strip": "strip", "three-link": "three-link body", "gmsh": "body"}

_NAME_RE = re.compile(r"^[A-Za-z_][A-Za-z0-9_-]*$")
_PETSC_KEY_RE = re.compile(r"^[a-z][a-z0-9_]*$")
_BARE_WORD_RE = re.compile(r"""^[A-Za-z_./~][^\s"'\[\]{},#]*$""")
#: a straight line of a strip-like mesh, ``x=c`` or ``y=c`` (no spaces, c a finite number)
_LINE_RE = re.compile(r"^([xy])=([+-]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?)$")


# --------------------------------------------------------------------------- text


def _fmt(value: Any, limit: int = 60) -> str:
    """Short TOML-like rendering of a value for messages."""
    if isinstance(value, bool):
        text = "true" if value else "false"
    elif isinstance(value, float):
        text = repr(value)
        if text.endswith(".0") and "e" not in text:
            text = text[:-2]
    elif isinstance(value, int):
        text = str(value)
    elif isinstance(value, str):
        text = '"' + value.replace("\n", "\\n") + '"'
    elif isinstance(value, list):
        text = "[" + ", ".join(_fmt(v, limit) for v in value) + "]"
    elif isinstance(value, dict):
        text = "{" + ", ".join(f"{k} = {_fmt(v, limit)}" for k, v in value.items()) + "}"
    elif value is None:
        text = "nothing"
    else:
        text = str(value)
    if len(text) > limit:
        text = text[: limit - 3] + "..."
    return text


def _found(value: Any) -> str:
    """'the string "abc"', 'the boolean true', '-0.1', 'a table', ..."""
    if isinstance(value, bool):
        return "the boolean " + _fmt(value)
    if isinstance(value, str):
        return "the string " + _fmt(value)
    if isinstance(value, dict):
        return "a table"
    if isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
        return f"an array of {len(value)} table(s)"
    if isinstance(value, (int, float, list)):
        return _fmt(value)
    return f"a {type(value).__name__.replace('datetime', 'date-time')} value {_fmt(value)}"


def _choices(options: Iterable[str]) -> str:
    opts = [f'"{o}"' for o in options]
    if len(opts) <= 2:
        return " or ".join(opts)
    return ", ".join(opts[:-1]) + " or " + opts[-1]


def _suggest(word: str, options: Iterable[str], prefix: str = "") -> str:
    close = difflib.get_close_matches(word, list(options), n=1, cutoff=0.6)
    return f" (did you mean '{prefix}{close[0]}'?)" if close else ""


def _err(path: str, expected: str, value: Any, extra: str = "") -> SceneError:
    return SceneError(f"{path}: expected {expected}, found {_found(value)}{extra}")


def _join(path: str, key: str | int) -> str:
    return f"{path}.{key}" if path else str(key)


def _leaf_name(path: str) -> str:
    for part in reversed(path.split(".")):
        if not part.isdigit():
            return part
    return path


# --------------------------------------------------------------------- validators
# A validator is a callable (value, path) -> normalised value with an ``expected``
# text used for "missing required key" messages.


class _V:
    expected = "a value"

    def __call__(self, value: Any, path: str) -> Any:  # pragma: no cover - abstract
        raise NotImplementedError

    def describe(self, name: str) -> str:
        """The accepted values of a key called ``name`` (for the scene reference)."""
        return self.expected


class _Str(_V):
    def __init__(self, choices: tuple[str, ...] | None = None, name: bool = False,
                 unavailable: dict[str, str] | None = None):
        self.choices, self.name, self.unavailable = choices, name, unavailable or {}
        if choices:
            self.expected = _choices(choices)
        elif name:
            self.expected = "a name (letters, digits, '_' or '-', not starting with a digit)"
        else:
            self.expected = "a string"

    def __call__(self, value, path):
        if not isinstance(value, str):
            raise _err(path, self.expected, value)
        if value in self.unavailable:
            raise SceneError(f"{path}: {_fmt(value)} {self.unavailable[value]}; "
                             f"expected {self.expected}")
        if self.choices and value not in self.choices:
            hint = difflib.get_close_matches(value, self.choices, n=1, cutoff=0.6)
            extra = f' (did you mean "{hint[0]}"?)' if hint else ""
            raise _err(path, self.expected, value, extra)
        if self.name and not _NAME_RE.match(value):
            raise _err(path, self.expected, value)
        if not self.choices and not self.name and not value.strip():
            raise _err(path, "a non-empty string", value)
        return value


class _Num(_V):
    """A finite float in a range; ints are accepted, bools are not numbers."""

    def __init__(self, lo: float | None = None, hi: float | None = None,
                 lo_open: bool = False, hi_open: bool = False, name: str | None = None):
        self.lo, self.hi, self.lo_open, self.hi_open, self.name = lo, hi, lo_open, hi_open, name
        self.expected = self._text("x")

    def _text(self, name: str) -> str:
        lo = None if self.lo is None else _fmt(float(self.lo))
        hi = None if self.hi is None else _fmt(float(self.hi))
        lop, hop = ("<" if self.lo_open else "<="), ("<" if self.hi_open else "<=")
        if lo is not None and hi is not None:
            return f"a number with {lo} {lop} {name} {hop} {hi}"
        if lo is not None:
            return f"a number {'>' if self.lo_open else '>='} {lo}"
        if hi is not None:
            return f"a number {hop} {hi}"
        return "a number"

    def describe(self, name: str) -> str:
        return self._text(self.name or name)

    def __call__(self, value, path):
        expected = self._text(self.name or _leaf_name(path))
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise _err(path, expected, value)
        try:
            x = float(value)
        except OverflowError:
            x = math.inf  # an integer too large for a float
        if not math.isfinite(x):
            raise _err(path, "a finite number", value)
        if self.lo is not None and (x < self.lo or (self.lo_open and x == self.lo)):
            raise _err(path, expected, value)
        if self.hi is not None and (x > self.hi or (self.hi_open and x == self.hi)):
            raise _err(path, expected, value)
        return x


class _Int(_V):
    def __init__(self, lo: int | None = None):
        self.lo = lo
        self.expected = "an integer" if lo is None else f"an integer >= {lo}"

    def __call__(self, value, path):
        if isinstance(value, bool) or not isinstance(value, int):
            raise _err(path, self.expected, value)
        if self.lo is not None and value < self.lo:
            raise _err(path, self.expected, value)
        return value


class _Bool(_V):
    expected = "true or false"

    def __call__(self, value, path):
        if not isinstance(value, bool):
            raise _err(path, self.expected, value)
        return value


class _Vec(_V):
    """A fixed-length list of floats."""

    def __init__(self, n: int = 3, item: _V | None = None, nonzero: bool = False,
                 some_positive: bool = False, expected: str | None = None):
        self.n, self.item = n, item or _Num()
        self.nonzero, self.some_positive = nonzero, some_positive
        self.expected = expected or (f"{'a nonzero vector of ' if nonzero else ''}"
                                     f"{n} numbers [x, y, z]" if n == 3 else f"{n} numbers")

    def __call__(self, value, path):
        if not isinstance(value, list) or len(value) != self.n:
            raise _err(path, self.expected, value)
        out = []
        for i, v in enumerate(value):
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                raise _err(path, self.expected, value)
            try:
                out.append(self.item(v, _join(path, i)))
            except SceneError:
                raise _err(path, self.expected, value) from None
        if self.nonzero and not any(x != 0.0 for x in out):
            raise _err(path, self.expected, value)
        if self.nonzero and not 1e-100 < max(abs(x) for x in out) < 1e100:
            # a direction: its length must survive squaring in double precision
            raise _err(path, "a direction of moderate length (largest entry between 1e-100 "
                             "and 1e100)", value)
        if self.some_positive and not any(x > 0.0 for x in out):
            raise _err(path, self.expected, value)
        return out


class _Divisions(_V):
    expected = "[n_length, n_width], two integers >= 1"

    def __call__(self, value, path):
        if (not isinstance(value, list) or len(value) != 2
                or any(isinstance(v, bool) or not isinstance(v, int) or v < 1 for v in value)):
            raise _err(path, self.expected, value)
        return list(value)


class _Pairs(_V):
    """A piecewise-linear table: [[t, value], ...] with strictly increasing t."""

    def __init__(self, what: str):
        self.expected = f"a list of [t, {what}] number pairs with strictly increasing t"
        self.pair = f"a [t, {what}] pair of numbers"

    def __call__(self, value, path):
        if not isinstance(value, list) or not value:
            raise _err(path, self.expected, value)
        out = []
        for i, pair in enumerate(value):
            if (not isinstance(pair, list) or len(pair) != 2
                    or any(isinstance(v, bool) or not isinstance(v, (int, float))
                           or not math.isfinite(v) for v in pair)):
                raise _err(_join(path, i), self.pair, pair)
            t, s = float(pair[0]), float(pair[1])
            if out and t <= out[-1][0]:
                raise SceneError(f"{path}: expected strictly increasing times, found "
                                 f"t = {_fmt(t)} after t = {_fmt(out[-1][0])} (entry {i})")
            out.append([t, s])
        return out


class _Fix(_V):
    options = ("ux", "uy", "uz", "rotation", "clamped")
    expected = "a non-empty list of " + _choices(options)

    def __call__(self, value, path):
        if not isinstance(value, list) or not value:
            raise _err(path, self.expected, value)
        for i, v in enumerate(value):
            if not isinstance(v, str) or v not in self.options:
                extra = ""
                if isinstance(v, str):
                    hint = difflib.get_close_matches(v, self.options, n=1, cutoff=0.6)
                    extra = f' (did you mean "{hint[0]}"?)' if hint else ""
                raise _err(_join(path, i), "one of " + _choices(self.options), v, extra)
        return list(value)


class _Where(_V):
    expected = ('a selector: "all", "x=0", "x=L", "y=0", "y=W", a [[hinge]] line, '
                "or a region / physical-group name")

    def __init__(self, expected: str | None = None):
        if expected:
            self.expected = expected

    def __call__(self, value, path):
        if not isinstance(value, str) or not value.strip() or value != value.strip():
            raise _err(path, self.expected, value)
        return value


# ------------------------------------------------------------------------- schema


# Every node of the schema carries ``doc`` (what the key means, one or two
# sentences) and leaves a ``unit`` where they have one: the scene reference in
# docs/scenes.md is generated from them (rftfem/scene_reference.py), which
# refuses a key without ``doc``. Units are dimensions ("length", "force/length²"),
# since a scene uses consistent units of the user's choice. ``default_doc`` says
# in words what a leaf whose default is not a plain value gets (filled in by the
# cross checks, inherited, or only used with another key's value).


class _Leaf:
    def __init__(self, check: _V, default: Any = None, required: bool = False, *,
                 doc: str = "", unit: str = "", default_doc: str | None = None):
        self.check, self.default, self.required = check, default, required
        self.doc, self.unit, self.default_doc = doc, unit, default_doc


class _Table:
    """A TOML table with known keys. ``optional``: absent -> None (not filled)."""

    def __init__(self, fields: dict[str, Any], required: bool = False, optional: bool = False,
                 *, doc: str = ""):
        self.fields, self.required, self.optional = fields, required, optional
        self.doc = doc


class _Array:
    """An array of tables ([[name]]), each with the schema ``item``."""

    def __init__(self, item: _Table, min_items: int = 0, *, doc: str = ""):
        self.item, self.min_items = item, min_items
        self.doc = doc


class _Free:
    """A table of PETSc options: any lowercase key, scalar values."""

    expected = ("any PETSc option name without prefix or dash (lowercase letters, digits, "
                "'_'); a string, number or boolean")

    def __init__(self, *, doc: str = ""):
        self.doc = doc


_POS = _Num(0.0, lo_open=True)

#: the most time steps a scene may ask for (time.end / time.dt)
MAX_STEPS = 1e9


def unit_vector(v) -> tuple[float, float, float]:
    """``v / |v|`` for a nonzero 3-vector of any finite size (scaled first: no overflow)."""
    scale = max(abs(x) for x in v)
    w = [x / scale for x in v]
    n = math.hypot(*w)
    return tuple(x / n for x in w)


_NONNEG = _Num(0.0)

_PART_MATERIAL = ("E", "nu", "thickness", "density")

_INTERVAL = "an interval [a, b] of 2 numbers"
_MOMENT_PER_LENGTH_RAD = "force·length/(length·rad)"
_INHERITED = "inherited from [shell]"

SCHEMA = _Table({
    "title": _Leaf(_Str(), required=True,
                   doc="A free-text name of the scene; `rftfem check` and the first log line "
                       "of a run show it."),
    "mesh": _Table({
        "kind": _Leaf(_Str(("strip", "gmsh", "three-link")), "strip",
                      doc='How the body is made. "strip": the rectangle [0, length] × '
                          '[0, width] in the plane Z = 0. "three-link": three strips side by '
                          "side along Y, joined along X by two built-in hinges (regions left, "
                          'middle, right; hinge lines hinge-left, hinge-right). "gmsh": the '
                          "surface mesh in `mesh.file`, flat or curved."),
        "length": _Leaf(_POS, 10.0, unit="length",
                        doc="Extent of a strip or three-link body along X (the links' "
                            "length). Not used with a gmsh mesh."),
        # 1.0, or 3 * link_width: filled by _cross_check
        "width": _Leaf(_POS, None, unit="length",
                       default_doc='1.0; with kind = "three-link" it is 3 × link_width and '
                                   "may not be set",
                       doc="Extent of a strip along Y. Not used with a gmsh mesh."),
        # 0.5 for three-link: filled by _cross_check
        "link_width": _Leaf(_POS, None, unit="length",
                            default_doc='none: only with kind = "three-link", where it is 0.5',
                            doc="Width of each link of a three-link body across Y; the body "
                                "spans Y in [0, 3 link_width]."),
        # 0.0 for three-link: filled likewise
        "hinge_stiffness": _Leaf(_NONNEG, None, unit=_MOMENT_PER_LENGTH_RAD,
                                 default_doc='none: only with kind = "three-link", where it '
                                             "is 0.0",
                                 doc="Rotational spring of both built-in hinges of a "
                                     "three-link body, as `[[hinge]].stiffness`; 0 leaves "
                                     "them free."),
        "divisions": _Leaf(_Divisions(), [16, 1],
                           doc="Number of cells along X and across Y (three-link: across "
                               "each link). Region limits and hinge lines add cuts. Not used "
                               "with a gmsh mesh."),
        "cell": _Leaf(_Str(("quadrilateral", "triangle")), "quadrilateral",
                      doc="Cell shape of a strip or three-link mesh; the unknowns are "
                          "second order either way (Q2 or P2). A gmsh file brings its own "
                          "cells."),
        "file": _Leaf(_Str(), None,
                      default_doc='none: required only with kind = "gmsh"',
                      doc="The gmsh .msh file, relative to the scene file's folder unless "
                          "absolute. Its named physical surfaces are the regions, its named "
                          "physical curves are edges for `where` and hinge lines."),
        "regions": _Array(_Table({
            "name": _Leaf(_Str(name=True), required=True,
                          doc="The region's name, unique; not a selector (all, x=0, x=L, "
                              "y=0, y=W) nor a built-in three-link name."),
            "x": _Leaf(_Vec(2, expected=_INTERVAL), unit="length",
                       default_doc="none: the region spans all of X (give x, y or both)",
                       doc="The band a ≤ X ≤ b of reference coordinates, inside "
                           "[0, mesh.length]."),
            "y": _Leaf(_Vec(2, expected=_INTERVAL), unit="length",
                       default_doc="none: the region spans all of Y (give x, y or both)",
                       doc="The band a ≤ Y ≤ b of reference coordinates, inside the body's "
                           "width."),
        }), doc="Named parts of a strip or three-link body: the cells inside a band of X, of "
                "Y, or both. The mesh is cut along the band limits. A region can carry "
                "`[[shell.parts]]` and `[[magnetic.parts]]` values and serves as a `where` "
                "selector. Refused with a gmsh mesh, whose physical surfaces are the "
                "regions."),
    }, required=True,
        doc="The body in its reference (unloaded) state: the shell's mid-surface, its mesh "
            "and its named regions and edges."),
    "shell": _Table({
        "thickness": _Leaf(_POS, 0.1, unit="length", doc="Shell thickness."),
        "E": _Leaf(_POS, 1.2e6, unit="force/length²", doc="Young's modulus."),
        "nu": _Leaf(_Num(-1.0, 0.5, lo_open=True, hi_open=True), 0.0,
                    doc="Poisson's ratio."),
        "density": _Leaf(_NONNEG, 0.0, unit="mass/length³",
                         doc="Mass per volume, with mass in force·time²/length (t/mm³ for "
                             "N, mm, s). Above 0 (here or in a part) the body has inertia "
                             "and the automatic scheme is generalized-alpha."),
        "axis": _Leaf(_Vec(nonzero=True), [1.0, 0.0, 0.0],
                      doc="The material axis E1* in reference coordinates (normalised, not "
                          "along the normal). The drag frame follows it: C1 acts along the "
                          "axis as the body carries it, C2 across it in the surface."),
        "parts": _Array(_Table({
            "region": _Leaf(_Str(name=True), required=True,
                            doc="The region (of `[[mesh.regions]]`, a built-in three-link "
                                "region or a gmsh physical surface); one part per region."),
            "E": _Leaf(_POS, unit="force/length²", default_doc=_INHERITED,
                       doc="Young's modulus on the region."),
            "nu": _Leaf(_Num(-1.0, 0.5, lo_open=True, hi_open=True), default_doc=_INHERITED,
                        doc="Poisson's ratio on the region."),
            "thickness": _Leaf(_POS, unit="length", default_doc=_INHERITED,
                               doc="Thickness on the region."),
            "density": _Leaf(_NONNEG, unit="mass/length³", default_doc=_INHERITED,
                             doc="Density on the region."),
        }), doc="Material values that differ on a region; a part takes what it leaves out "
                "from [shell]."),
    }, required=True,
        doc="The material (isotropic, plane stress) and thickness of the shell."),
    "hinge": _Array(_Table({
        "where": _Leaf(_Where('a hinge line: "x=c" or "y=c" (c a number), '
                              "or a physical curve name"), required=True,
                       doc='The line: "x=c" or "y=c" strictly inside a strip or three-link '
                           "body (the mesh is cut there), or a named physical curve of a "
                           "gmsh mesh, straight or curved. One hinge per line."),
        "stiffness": _Leaf(_NONNEG, 0.0, unit=_MOMENT_PER_LENGTH_RAD,
                           doc="Rotational spring on the fold angle, per unit length of the "
                               "line; 0 is a free hinge."),
    }), doc="Lines along which the body folds: the displacement stays continuous, each side "
            "has its own director, so the line passes forces but no moment about itself "
            "(unless it has a spring). The name of the line (its `where`) is then a `where` "
            "selector as well."),
    "time": _Table({
        "end": _Leaf(_POS, 1.0, unit="time",
                     doc='The time the run stops at; linear load ramps reach their full value '
                         'there. With scheme = "static" time is only a load parameter.'),
        "dt": _Leaf(_POS, 0.01, unit="time",
                    doc="The nominal step, at most `end`: the run makes ceil(end / dt) steps, "
                        "the last one ending at `end`. A step that fails is halved and "
                        "retried, then grown back."),
        "scheme": _Leaf(_Str(("auto", "generalized-alpha", "hht", "backward-euler", "static")),
                        "auto",
                        doc='The time integrator. "generalized-alpha" and "hht" are second '
                            'order and need density; "backward-euler" is first order, for '
                            'drag without inertia; "static" steps the loads with no velocity '
                            '(refused with [fluid]). "auto" takes generalized-alpha with '
                            "density, backward-euler with [fluid] alone, static otherwise."),
        "rho_inf": _Leaf(_Num(0.0, 1.0), 0.9,
                         doc="Generalized-alpha's spectral radius at infinite frequency: 1 "
                             "damps nothing, smaller values damp the highest frequencies "
                             "more. Used by generalized-alpha only."),
        "alpha": _Leaf(_Num(-1.0 / 3.0, 0.0), -0.05,
                       doc="The α of the HHT scheme; 0 is the trapezoidal rule, more "
                           "negative values damp high frequencies. Used by hht only."),
        "output_every": _Leaf(_Int(1), 1,
                              doc="Write a row of probes.csv and body.csv, and the fields, "
                                  "every this many nominal steps (and after the last one)."),
        "max_cuts": _Leaf(_Int(0), 8,
                          doc="How many times one step may be halved before the run fails "
                              "(exit status 3)."),
        "max_rotation": _Leaf(_POS, 0.2, unit="rad",
                              doc="The most any director may turn within one converged step "
                                  "of a scheme with velocity (not static); a step that turns "
                                  "one further is halved, as it would skip fast motion."),
    }, required=True, doc="Time span, step and integration scheme."),
    "boundary": _Array(_Table({
        "where": _Leaf(_Where(), required=True,
                       doc="Where: all, an edge (x=0, x=L, y=0, y=W, a gmsh physical "
                           "curve), a hinge line or a region."),
        "fix": _Leaf(_Fix(), required=True,
                     doc="What is held at zero: the displacement components ux, uy, uz "
                         '(global axes) and "rotation" (the director keeps its reference '
                         'direction); "clamped" is all four.'),
    }), doc="Degrees of freedom held at zero for the whole run."),
    "load": _Array(_Table({
        "kind": _Leaf(_Str(("edge-moment", "edge-force")), required=True,
                      doc='"edge-force": a force on the edge; "edge-moment": a couple on the '
                          "edge's directors (its part about the director does nothing)."),
        "where": _Leaf(_Where(), required=True,
                       doc="The boundary edge: x=0, x=L, y=0, y=W or a gmsh physical curve "
                           "(not a hinge or another line inside the body)."),
        "value": _Leaf(_Vec(), required=True, unit="force; force·length for edge-moment",
                       doc="The total over the edge in global axes, spread evenly along the "
                           "edge's reference length and multiplied by the ramp's scale. The "
                           "load keeps its direction as the body moves (dead load)."),
        "ramp": _Leaf(_Str(("linear", "constant", "table")), "linear",
                      doc='The scale in time: "linear" t / time.end, "constant" 1, "table" '
                          "interpolated in `table`."),
        "table": _Leaf(_Pairs("scale"), unit="[time, 1]",
                       default_doc='none: required only with ramp = "table"',
                       doc="The scale, piecewise linear in time; before the first and after "
                           "the last time it keeps the end value."),
    }), doc="Dead loads on boundary edges."),
    "motion": _Array(_Table({
        "where": _Leaf(_Where(), "all",
                       doc="Where, as for `[[boundary]].where`."),
        "component": _Leaf(_Str(("ux", "uy", "uz")), required=True,
                           doc="The displacement component prescribed (global axes)."),
        "kind": _Leaf(_Str(("travelling-wave", "table")), "travelling-wave",
                      doc='"travelling-wave": u = amplitude sin(wavenumber (X − origin) + '
                          "angular_frequency t), with X each node's reference X coordinate; "
                          '"table": one value on the whole selection, interpolated in '
                          "`values`."),
        "amplitude": _Leaf(_Num(), 0.0, unit="length",
                           doc="The wave's amplitude (travelling-wave)."),
        "wavenumber": _Leaf(_Num(), 0.0, unit="rad/length",
                            doc="The wave number (travelling-wave); with a positive "
                                "angular_frequency the wave runs towards −X."),
        "angular_frequency": _Leaf(_Num(), 0.0, unit="rad/time",
                                   doc="The angular frequency (travelling-wave)."),
        "origin": _Leaf(_Num(), 0.0, unit="length",
                        doc="The reference X where the wave's phase is zero at t = 0 "
                            "(travelling-wave)."),
        "values": _Leaf(_Pairs("u"), unit="[time, length]",
                        default_doc='none: required only with kind = "table"',
                        doc="The displacement, piecewise linear in time; before the first "
                            "and after the last time it keeps the end value."),
    }), doc="A displacement component prescribed in time on a selection (a moving "
            "Dirichlet condition). A degree of freedom takes one condition: a motion where a "
            "`[[boundary]]` or another motion already holds the component is refused."),
    "fluid": _Table({
        "drag": _Leaf(_Vec(item=_NONNEG, some_positive=True,
                           expected="3 numbers >= 0 [along axis, across, normal], "
                                    "at least one > 0"), required=True,
                      unit="force·time/length³",
                      doc="The drag coefficients [C1, C2, C3]: along the material axis "
                          "(`shell.axis`) as the body carries it, across it in the surface, "
                          "and along the current normal. The traction per current area is "
                          "the sum of Ci (ei·v) ei over the three directions."),
    }, optional=True,
        doc="Resistive-force-theory drag of the surrounding fluid: a traction proportional "
            "to the local velocity."),
    "magnetic": _Table({
        "parts": _Array(_Table({
            "region": _Leaf(_Str(name=True), required=True,
                            doc="The magnetized region; a cell takes one magnetization."),
            "magnetization": _Leaf(_NONNEG, required=True, unit="current/length",
                                   doc="The size of the remanent magnetization; 0 switches "
                                       "the part off."),
            "direction": _Leaf(_Vec(nonzero=True), required=True,
                               doc="The magnetization's direction in the reference state "
                                   "(normalised); it turns with the material fibre."),
        }), min_items=1, doc="The magnetized regions of the body."),
        "field": _Table({
            "strength": _Leaf(_NONNEG, 0.0, unit="force/(current·length)",
                              doc="The size of the applied flux density once ramped up "
                                  "(tesla in SI units; 1 mT is 1e-6 N/(A·mm))."),
            "ramp_time": _Leaf(_NONNEG, 0.0, unit="time",
                               doc="The time the field takes to grow linearly from 0 to "
                                   "`strength` along `direction`; 0 starts at full "
                                   "strength."),
            "direction": _Leaf(_Vec(nonzero=True), [1.0, 0.0, 0.0],
                               doc="The field's direction during the ramp and when it starts "
                                   "to turn (normalised)."),
            "frequency": _Leaf(_Num(), 0.0, unit="1/time",
                               doc="Turns per unit time after `ramp_time` (Hz with "
                                   "seconds), right-handed about `rotation_axis`; negative "
                                   "turns the other way, 0 keeps the field still."),
            "rotation_axis": _Leaf(_Vec(nonzero=True), [0.0, 0.0, 1.0],
                                   doc="The axis the field turns about (normalised); not "
                                       "parallel to `direction` when the frequency is not "
                                       "0."),
        }, doc="The applied field, uniform in space: first it ramps up along a direction, "
               "then it turns about an axis."),
    }, optional=True,
        doc="Couples of an applied magnetic field on magnetized (hard-magnetic) regions."),
    "output": _Table({
        "probes": _Array(_Table({
            "name": _Leaf(_Str(name=True), required=True,
                          doc="The probe's columns in probes.csv are NAME_ux, NAME_uy, "
                              "NAME_uz; unique."),
            "at": _Leaf(_Vec(), required=True, unit="length",
                        doc="The material point, in reference coordinates; on a strip or "
                            "three-link body it must lie on the body (z = 0)."),
        }), doc="Material points whose displacement goes to probes.csv."),
        "fields": _Leaf(_Bool(), True,
                        doc="Write fields.xdmf and fields.h5 (displacement, director, "
                            "magnetization) for ParaView."),
        "render": _Leaf(_Str(("none", "png", "mp4", "gif")), "none",
                        doc="When the run ends (also when it fails), draw render.png, "
                            "render.mp4 or render.gif in the output folder with `rftfem "
                            'render` and its defaults; "none" draws nothing. Needs '
                            "`output.fields = true`; a drawing that fails only warns."),
    }, doc="What a run writes besides steps.csv, body.csv and summary.json."),
    "solver": _Free(doc="PETSc options of the nonlinear solve, named without prefix or dash "
                        "(snes_rtol, ksp_type, pc_type, ...). They replace rftfem's defaults; "
                        "PETSc options on the `rftfem run` command line replace them in "
                        "turn."),
}, doc="The top level of the scene file.")


def _section(path: str) -> str:
    return f"[{path}]"


def _validate_table(spec: _Table, raw: Any, path: str) -> dict:
    if not isinstance(raw, dict):
        raise _err(path, f"a table {_section(path)}", raw)
    for key in raw:
        if key not in spec.fields:
            where = f"'{_join(path, key)}'"
            raise SceneError(f"unknown key {where}"
                             + (_suggest(key, spec.fields, path + "." if path else "")
                                or f" (valid keys{' in ' + _section(path) if path else ''}: "
                                   f"{', '.join(spec.fields)})"))
    out: dict[str, Any] = {}
    for key, sub in spec.fields.items():
        sub_path = _join(path, key)
        present = key in raw
        value = raw.get(key)
        if isinstance(sub, _Leaf):
            if not present:
                if sub.required:
                    raise SceneError(f"missing required key '{sub_path}' "
                                     f"(expected {sub.check.expected})")
                out[key] = _copy(sub.default)
            else:
                out[key] = sub.check(value, sub_path)
        elif isinstance(sub, _Table):
            if not present:
                if sub.required:
                    raise SceneError(f"missing required section {_section(sub_path)}")
                out[key] = None if sub.optional else _validate_table(sub, {}, sub_path)
            else:
                out[key] = _validate_table(sub, value, sub_path)
        elif isinstance(sub, _Array):
            out[key] = _validate_array(sub, value if present else [], sub_path)
        elif isinstance(sub, _Free):
            out[key] = _validate_free(value if present else {}, sub_path)
    return out


def _validate_array(spec: _Array, raw: Any, path: str) -> list:
    if isinstance(raw, dict):
        raise _err(path, f"an array of tables [[{path}]]", raw,
                   f" (write [[{path}]], not [{path}])")
    if not isinstance(raw, list) or any(not isinstance(v, dict) for v in raw):
        raise _err(path, f"an array of tables [[{path}]]", raw)
    if len(raw) < spec.min_items:
        raise SceneError(f"{path}: expected at least {spec.min_items} [[{path}]] "
                         f"entr{'y' if spec.min_items == 1 else 'ies'}, found {len(raw)}")
    return [_validate_table(spec.item, item, _join(path, i)) for i, item in enumerate(raw)]


def _validate_free(raw: Any, path: str) -> dict:
    if not isinstance(raw, dict):
        raise _err(path, f"a table {_section(path)} of PETSc options", raw)
    out = {}
    for key, value in raw.items():
        kp = _join(path, key)
        if not _PETSC_KEY_RE.match(key):
            raise SceneError(f"{kp}: expected a PETSc option name without prefix or dash "
                             f"(lowercase letters, digits, '_'), found '{key}'")
        if isinstance(value, float) and not math.isfinite(value):
            raise _err(kp, "a finite number", value)
        if not isinstance(value, (str, int, float, bool)):
            raise _err(kp, "a string, number or boolean", value)
        out[key] = value
    return out


def _copy(value: Any) -> Any:
    if isinstance(value, list):
        return [_copy(v) for v in value]
    if isinstance(value, dict):
        return {k: _copy(v) for k, v in value.items()}
    return value


# ---------------------------------------------------------------- cross checks


def _check_unique(items: list[dict], key: str, path: str, what: str) -> None:
    seen: set[str] = set()
    for i, item in enumerate(items):
        name = item[key]
        if name in seen:
            raise SceneError(f"{path}.{i}.{key}: expected a unique {what} name, "
                             f"found '{name}' a second time")
        seen.add(name)


def _region_names(scene: dict) -> list[str]:
    """The region names of a strip-like mesh: built-in (three-link) then [[mesh.regions]]."""
    builtin = list(THREE_LINK_REGIONS) if scene["mesh"]["kind"] == "three-link" else []
    return builtin + [r["name"] for r in scene["mesh"]["regions"]]


def _check_region_ref(name: str, path: str, scene: dict) -> None:
    """For strip-like meshes, a part's region must be built in or one of [[mesh.regions]]."""
    if scene["mesh"]["kind"] not in _LINED_KINDS:
        return  # gmsh: checked against the file's physical groups later
    names = _region_names(scene)
    if name in names:
        return
    if not names:
        raise SceneError(f"{path}: unknown region '{name}'; expected a name defined in "
                         "[[mesh.regions]], but the scene defines none")
    raise SceneError(f"{path}: unknown region '{name}'; expected one of: {', '.join(names)}"
                     + _suggest(name, names))


def _table_iff(entry: dict, path: str, switch: str, key: str, what: str):
    """``entry[key]`` is required when ``entry[switch] == "table"`` and refused otherwise."""
    if entry[switch] == "table" and entry[key] is None:
        raise SceneError(f"missing required key '{path}.{key}' (expected a list of {what}, "
                         f"because {path}.{switch} = \"table\")")
    if entry[switch] != "table" and entry[key] is not None:
        raise SceneError(f"{path}.{key}: only used with {switch} = \"table\", found "
                         f"{path}.{switch} = {_fmt(entry[switch])}")


def hinge_line(where: str) -> tuple[str, float] | None:
    """``("x", c)`` or ``("y", c)`` for a line selector ``"x=c"`` / ``"y=c"`` with c a
    finite number (``"y=0.5"``, ``"x=-1e-3"``); ``None`` for anything else."""
    match = _LINE_RE.match(where)
    if not match:
        return None
    c = float(match.group(2))
    return (match.group(1), c) if math.isfinite(c) else None


def _selectors(scene: dict) -> list[str]:
    """The ``where`` selectors of a strip-like mesh: special ones, the three-link's hinge
    lines, the [[hinge]] lines, then region names."""
    valid = list(SPECIAL_SELECTORS)
    if scene["mesh"]["kind"] == "three-link":
        valid += THREE_LINK_HINGES
    valid += [h["where"] for h in scene["hinge"] if h["where"] not in valid]
    return valid + _region_names(scene)


def _check_where(value: str, path: str, scene: dict) -> None:
    if value in SPECIAL_SELECTORS or scene["mesh"]["kind"] not in _LINED_KINDS:
        return
    valid = _selectors(scene)
    if value not in valid:
        raise SceneError(f"{path}: unknown selector '{value}'; expected one of: "
                         f"{', '.join(valid)}" + _suggest(value, valid))


def _check_mesh(mesh: dict) -> None:
    """Fill the kind-dependent keys of [mesh] and check its regions."""
    kind = mesh["kind"]
    three = kind == "three-link"
    if kind == "gmsh" and mesh["file"] is None:
        raise SceneError("missing required key 'mesh.file' (expected the path of a gmsh "
                         'mesh, relative to the scene file, when mesh.kind = "gmsh")')
    if kind != "gmsh":
        mesh["file"] = None  # only read for gmsh meshes (lets --set mesh.kind=strip work)
    if three:
        if mesh["width"] is not None:
            raise SceneError("mesh.width: expected no mesh.width with mesh.kind = "
                             '"three-link" (set mesh.link_width: the body is 3 * link_width '
                             f"wide), found mesh.width = {_fmt(mesh['width'])}")
        if mesh["link_width"] is None:
            mesh["link_width"] = 0.5
        if mesh["hinge_stiffness"] is None:
            mesh["hinge_stiffness"] = 0.0
        mesh["width"] = 3.0 * mesh["link_width"]
        if not math.isfinite(mesh["width"]):
            raise _err("mesh.link_width", "a number whose triple (the body's width) is "
                       "finite", mesh["link_width"])
    else:
        if mesh["width"] is None:
            mesh["width"] = 1.0
        # only read for three-link meshes (lets --set mesh.kind=strip work)
        mesh["link_width"] = mesh["hinge_stiffness"] = None

    regions = mesh["regions"]
    _check_unique(regions, "name", "mesh.regions", "region")
    extent = {"x": (mesh["length"], "mesh.length"),
              "y": (mesh["width"], "3 * mesh.link_width" if three else "mesh.width")}
    for i, region in enumerate(regions):
        name = region["name"]
        if three and name in THREE_LINK_REGIONS + THREE_LINK_HINGES:
            raise SceneError(f"mesh.regions.{i}.name: expected a name other than the "
                             "three-link mesh's built-in regions and hinge lines "
                             f"{', '.join(THREE_LINK_REGIONS + THREE_LINK_HINGES)}, "
                             f"found '{name}'")
        if name in SPECIAL_SELECTORS:
            raise SceneError(f"mesh.regions.{i}.name: expected a name other than the "
                             f"selectors {', '.join(SPECIAL_SELECTORS)}, found '{name}'")
        if region["x"] is None and region["y"] is None:
            raise SceneError(f"mesh.regions.{i}: expected x = [a, b] and/or y = [a, b], "
                             f"found neither in region '{name}'")
        for axis in ("x", "y"):
            band = region[axis]
            if band is None:
                continue
            a, b = band
            path = f"mesh.regions.{i}.{axis}"
            if a >= b:
                raise SceneError(f"{path}: expected an interval [a, b] with a < b, found "
                                 f"{_fmt(band)} (the region selects nothing)")
            size, size_key = extent[axis]
            tol = 1e-9 * size
            if kind in _LINED_KINDS and (a < -tol or b > size + tol):
                nothing = b <= 0.0 or a >= size
                raise SceneError(f"{path}: expected an interval [a, b] with 0 <= a < b <= "
                                 f"{size_key} = {_fmt(size)}, found {_fmt(band)}"
                                 + (" (the region selects nothing)" if nothing else
                                    f" (the region reaches outside the {_BODY[kind]})"))


def _check_hinges(scene: dict) -> None:
    """[[hinge]] lines: well formed, inside the body, one hinge per line."""
    mesh = scene["mesh"]
    kind = mesh["kind"]
    lined = kind in _LINED_KINDS
    three = kind == "three-link"
    extent = {"x": mesh["length"], "y": mesh["width"]}
    hinged: list[tuple[str, float, str]] = []  # (axis, c, description) of each hinge line
    if three:
        w = mesh["link_width"]
        hinged += [("y", w, f"the built-in hinge-left at y = {_fmt(w)}"),
                   ("y", 2.0 * w, f"the built-in hinge-right at y = {_fmt(2.0 * w)}")]
    named: dict[str, int] = {}  # gmsh physical curve names
    builtin_hint = "; the three-link mesh hinges it already: set mesh.hinge_stiffness for " \
                   "its built-in hinges"
    for i, hinge in enumerate(scene["hinge"]):
        where = hinge["where"]
        path = f"hinge.{i}.where"
        if three and where in THREE_LINK_HINGES:
            w = mesh["link_width"] * (1.0 if where == "hinge-left" else 2.0)
            raise SceneError(f"{path}: two hinges on one line ({_fmt(where)} and the built-in "
                             f"{where} at y = {_fmt(w)}){builtin_hint}")
        on_boundary = f"{path}: {_fmt(where)} lies on the body's boundary; a hinge joins two sides"
        if where in ("x=L", "y=W"):
            axis = where[0]
            raise SceneError(on_boundary + (f" (expected {axis}=c with 0 < c < "
                                            f"{_fmt(extent[axis])})" if lined else ""))
        line = hinge_line(where)
        if line is None:
            if lined or re.match(r"^[xy]\s*=", where):
                raise _err(path, 'a hinge line "x=c" or "y=c" with c a number (like "y=0.5")'
                           + ("" if lined else " or a physical curve name"), where)
            if where in named:  # a gmsh physical curve, checked against the file later
                raise SceneError(f"{path}: two hinges on one line ({_fmt(where)} and "
                                 f"hinge.{named[where]}.where = {_fmt(where)})")
            named[where] = i
            continue
        axis, c = line
        tol = 0.0
        if lined:
            size = extent[axis]
            tol = 1e-9 * size
            if c < -tol or c > size + tol:
                raise SceneError(f"{path}: {_fmt(where)} is not a line of the mesh: the body "
                                 f"spans {axis} in [0, {_fmt(size)}]")
            if c <= tol or c >= size - tol:
                raise SceneError(on_boundary + f" (expected {axis}=c with 0 < c < {_fmt(size)})")
        for other_axis, other, text in hinged:
            if other_axis == axis and abs(c - other) <= tol:
                raise SceneError(f"{path}: two hinges on one line ({_fmt(where)} and {text})"
                                 + (builtin_hint if text.startswith("the built-in") else
                                    "; expected one [[hinge]] per line"))
        hinged.append((axis, c, f"hinge.{i}.where = {_fmt(where)}"))


def _cross_check(scene: dict) -> None:
    mesh, shell, time = scene["mesh"], scene["shell"], scene["time"]

    _check_mesh(mesh)
    output = scene["output"]
    if output["render"] != "none" and not output["fields"]:
        raise SceneError(f'output.render = "{output["render"]}" draws the fields: '
                         "it needs output.fields = true")
    lined = mesh["kind"] in _LINED_KINDS
    length, width = mesh["length"], mesh["width"]
    _check_hinges(scene)

    # shell parts: region references, inherited material values
    for i, part in enumerate(shell["parts"]):
        _check_region_ref(part["region"], f"shell.parts.{i}.region", scene)
        for key in _PART_MATERIAL:
            if part[key] is None:
                part[key] = shell[key]
    _check_unique(shell["parts"], "region", "shell.parts", "region")

    # time
    if time["dt"] > time["end"]:
        raise SceneError(f"time.dt: expected a number <= time.end = {_fmt(time['end'])}, "
                         f"found {_fmt(time['dt'])}")
    if time["end"] / time["dt"] > MAX_STEPS:
        raise SceneError(f"time.dt: expected at most {MAX_STEPS:.0e} steps up to time.end = "
                         f"{_fmt(time['end'])}, found dt = {_fmt(time['dt'])} "
                         f"({time['end'] / time['dt']:.1e} steps)")

    # a rotating field needs an axis across its direction
    field = (scene["magnetic"] or {}).get("field")
    if field and field["frequency"] != 0.0:
        b, a = (unit_vector(field["direction"]), unit_vector(field["rotation_axis"]))
        cross = (b[1] * a[2] - b[2] * a[1], b[2] * a[0] - b[0] * a[2], b[0] * a[1] - b[1] * a[0])
        if math.hypot(*cross) <= 1e-9:
            raise SceneError(
                f"magnetic.field.rotation_axis: expected an axis not parallel to "
                f"magnetic.field.direction = {_fmt(field['direction'])} (the field would not "
                f"rotate at frequency = {_fmt(field['frequency'])}), found "
                f"{_fmt(field['rotation_axis'])}")

    # selectors
    for section in ("boundary", "load", "motion"):
        for i, item in enumerate(scene[section]):
            _check_where(item["where"], f"{section}.{i}.where", scene)

    # a table of values exactly when the entry says it is a table
    for i, load in enumerate(scene["load"]):
        _table_iff(load, f"load.{i}", "ramp", "table", "[t, scale] pairs")
    for i, motion in enumerate(scene["motion"]):
        _table_iff(motion, f"motion.{i}", "kind", "values", "[t, u] pairs")

    # magnetic parts
    if scene["magnetic"] is not None:
        for i, part in enumerate(scene["magnetic"]["parts"]):
            _check_region_ref(part["region"], f"magnetic.parts.{i}.region", scene)
        _check_unique(scene["magnetic"]["parts"], "region", "magnetic.parts", "region")

    # probes
    probes = scene["output"]["probes"]
    _check_unique(probes, "name", "output.probes", "probe")
    if lined:
        tol = 1e-9 * length
        for i, probe in enumerate(probes):
            x, y, z = probe["at"]
            if not (-tol <= x <= length + tol and -tol <= y <= width + tol and abs(z) <= tol):
                raise SceneError(
                    f"output.probes.{i}.at: probe outside the body: expected a point on the "
                    f"{_BODY[mesh['kind']]} (0 <= x <= {_fmt(length)}, "
                    f"0 <= y <= {_fmt(width)}, z = 0), found {_fmt(probe['at'])}")


# ------------------------------------------------------------------ public API


def apply_override(data: dict, text: str) -> None:
    """Apply one ``--set a.b.c=VALUE`` to the raw scene ``data`` (in place).

    VALUE is read as a TOML value; if it is not one but is a bare word
    (``triangle``, ``x=L``, ``plate.msh``) it is taken as a string. Arrays of
    tables are addressed by index (``load.0.value``). A path that is not in the
    schema, or an index out of range, raises SceneError naming the path. Missing
    tables on the way are created (``--set fluid.drag=[1,1,2]``).
    """
    key, sep, raw_value = text.partition("=")
    key = key.strip()
    if not sep or not key:
        raise SceneError(f"--set: expected KEY=VALUE (e.g. time.dt=0.005), found '{text}'")
    value = _parse_value(key, raw_value.strip())
    parts = key.split(".")
    if any(not p for p in parts):
        raise SceneError(f"--set {key}: expected a dotted key path like shell.thickness, "
                         f"found an empty component")

    spec: Any = SCHEMA
    node: Any = data
    path = ""
    for n, part in enumerate(parts):
        last = n == len(parts) - 1
        here = _join(path, part)
        if isinstance(spec, _Table):
            if part not in spec.fields:
                raise SceneError(f"--set: unknown key '{here}'"
                                 + (_suggest(part, spec.fields, path + "." if path else "")
                                    or f" (valid keys{' in ' + _section(path) if path else ''}:"
                                       f" {', '.join(spec.fields)})"))
            sub = spec.fields[part]
            if last:
                node[part] = value
                return
            if isinstance(sub, _Leaf):
                raise SceneError(f"--set {key}: '{here}' is a value, not a table, so "
                                 f"'{key}' does not exist")
            if part not in node:
                node[part] = [] if isinstance(sub, _Array) else {}
            child = node[part]
            if isinstance(sub, _Array):
                if not isinstance(child, list):
                    raise _err(here, f"an array of tables [[{here}]]", child)
            elif not isinstance(child, dict):
                raise _err(here, f"a table {_section(here)}", child)
            spec, node, path = sub, child, here
        elif isinstance(spec, _Array):
            if not re.fullmatch(r"\d+", part):
                raise SceneError(f"--set {key}: expected an index into [[{path}]] after "
                                 f"'{path}', found '{part}'")
            index = int(part)
            if index >= len(node):
                raise SceneError(f"--set {key}: index {index} out of range, the scene has "
                                 f"{len(node)} [[{path}]] entr{'y' if len(node) == 1 else 'ies'}")
            if last:
                node[index] = value
                return
            if not isinstance(node[index], dict):
                raise _err(here, "a table", node[index])
            spec, node, path = spec.item, node[index], here
        elif isinstance(spec, _Free):
            if not last:
                raise SceneError(f"--set {key}: '{here}' is a PETSc option, not a table")
            node[part] = value
            return


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
    raise SceneError(f"--set {key}: expected a TOML value (a number, true/false, "
                     f"\"string\", [array] or bare word), found '{text}'")


def load_scene(path: str | os.PathLike, overrides: Iterable[str] = ()) -> dict:
    """Read, override, validate and complete the scene in ``path`` (see module doc)."""
    scene_path = Path(path).expanduser()
    shown = str(path)
    try:
        data = scene_path.read_bytes()
    except FileNotFoundError:
        raise SceneError(f"scene file '{shown}' not found") from None
    except IsADirectoryError:
        raise SceneError(f"scene file '{shown}': expected a TOML file, found a directory") \
            from None
    except OSError as exc:
        raise SceneError(f"cannot read scene file '{shown}': {exc.strerror or exc}") from None
    try:
        raw = tomllib.loads(data.decode("utf-8"))
    except UnicodeDecodeError:
        raise SceneError(f"scene file '{shown}': expected a UTF-8 TOML file, found "
                         "binary or non-UTF-8 data") from None
    except tomllib.TOMLDecodeError as exc:
        msg = " ".join(str(exc).split())
        raise SceneError(f"scene file '{shown}' is not valid TOML: {msg}") from None

    for text in overrides:
        apply_override(raw, text)

    scene = _validate_table(SCHEMA, raw, "")
    _cross_check(scene)
    scene["time"]["scheme"] = resolved_scheme(scene)

    folder = scene_path.resolve().parent
    mesh = scene["mesh"]
    if mesh["kind"] == "gmsh":
        mesh_file = (folder / Path(mesh["file"]).expanduser()).resolve()
        if not mesh_file.exists():
            raise SceneError(f"mesh.file: expected a readable gmsh mesh file, found "
                             f"'{mesh['file']}' which does not exist ({mesh_file})")
        if not mesh_file.is_file():
            raise SceneError(f"mesh.file: expected a readable gmsh mesh file, found "
                             f"'{mesh['file']}' which is not a regular file ({mesh_file})")
        try:
            with open(mesh_file, "rb") as fh:
                fh.read(1)
        except OSError as exc:
            raise SceneError(f"mesh.file: expected a readable gmsh mesh file, found "
                             f"'{mesh['file']}' which cannot be read "
                             f"({exc.strerror or exc})") from None
        mesh["file"] = str(mesh_file)
    scene["_path"] = str(scene_path.resolve())
    scene["_overrides"] = list(overrides)
    return scene


def has_inertia(scene: dict) -> bool:
    """Inertia is an effect when some part has density and the scheme is second
    order in time (the one definition, for ``check`` and for the model)."""
    return _has_density(scene) and resolved_scheme(scene) in ("generalized-alpha", "hht")


def _has_density(scene: dict) -> bool:
    shell = scene.get("shell") or {}
    if (shell.get("density") or 0.0) > 0.0:
        return True
    return any((part.get("density") or 0.0) > 0.0 for part in shell.get("parts") or [])


def active_effects(scene: dict) -> list[str]:
    """The effects the scene asks for, in a fixed order (docs/model.md, effects)."""
    effects = ["elasticity"]
    hinges = scene.get("hinge") or []
    mesh = scene.get("mesh") or {}
    three = mesh.get("kind") == "three-link"
    if hinges or three:
        effects.append("hinge")
    if (any((h.get("stiffness") or 0.0) > 0.0 for h in hinges)
            or (three and (mesh.get("hinge_stiffness") or 0.0) > 0.0)):
        effects.append("hinge-spring")
    if has_inertia(scene):
        effects.append("inertia")
    if scene.get("fluid"):
        effects.append("drag")
    if scene.get("magnetic"):
        effects.append("magnetic")
    kinds = {load.get("kind") for load in scene.get("load") or []}
    for kind in ("edge-force", "edge-moment"):
        if kind in kinds:
            effects.append(kind)
    if scene.get("motion"):
        effects.append("prescribed-motion")
    return effects


def resolved_scheme(scene: dict) -> str:
    """``time.scheme`` with "auto" resolved: second order with inertia, first
    order with drag only, load stepping otherwise."""
    scheme = (scene.get("time") or {}).get("scheme", "auto")
    inertia = _has_density(scene)
    if scheme == "auto":
        if inertia:
            return "generalized-alpha"
        return "backward-euler" if scene.get("fluid") else "static"
    if scheme == "static" and scene.get("fluid"):
        raise SceneError("time.scheme: \"static\" has no velocity, so the [fluid] drag would "
                         "do nothing; use \"backward-euler\", \"generalized-alpha\" (with "
                         "density) or \"auto\", or remove [fluid]")
    if scheme in ("generalized-alpha", "hht") and not inertia:
        raise SceneError(f"time.scheme: \"{scheme}\" needs inertia (shell.density > 0 or a "
                         "shell.parts density > 0), found shell.density = "
                         f"{_fmt((scene.get('shell') or {}).get('density', 0.0))}; use "
                         "\"backward-euler\", \"static\" or \"auto\"")
    return scheme
