"""Checks of single scene values, each with the wording of its errors.

A validator is a callable ``(value, path) -> normalised value`` with an
``expected`` text; it raises :class:`~rftfem.errors.SceneError` as
``PATH: expected WHAT, found VALUE`` (:func:`err`).  :mod:`rftfem.scene.schema` builds
the scene's tables from them.  The wording itself is :mod:`rftfem.scene.messages`,
the tables over time :mod:`rftfem.scene.rows`; both are read from here too.
"""

from __future__ import annotations

import contextlib
import contextvars
import difflib
import math
import re
from typing import Any, Iterator

from rftfem.errors import SceneError
from rftfem.scene.messages import Validator, err, fmt, join, one_of
from rftfem.scene.messages import found as found
from rftfem.scene.messages import suggest as suggest
from rftfem.scene.rows import Pairs as Pairs
from rftfem.scene.rows import Rows as Rows

#: names become column headers and file names (an optimisation's designs): a length a
#: file system always takes
NAME_LENGTH = 64
_NAME_RE = re.compile(rf"^[A-Za-z_][A-Za-z0-9_-]{{0,{NAME_LENGTH - 1}}}$")


def _leaf_name(path: str) -> str:
    for part in reversed(path.split(".")):
        if not part.isdigit():
            return part
    return path


class Str(Validator):
    def __init__(
        self,
        choices: tuple[str, ...] | None = None,
        name: bool = False,
        unavailable: dict[str, str] | None = None,
    ):
        self.choices, self.name, self.unavailable = choices, name, unavailable or {}
        if choices:
            self.expected = one_of(choices)
        elif name:
            self.expected = (
                "a name (letters, digits, '_' or '-', not starting with a digit, "
                f"at most {NAME_LENGTH} characters)"
            )
        else:
            self.expected = "a string"

    def __call__(self, value: Any, path: str) -> str:
        if not isinstance(value, str):
            raise err(path, self.expected, value)
        if value in self.unavailable:
            raise SceneError(
                f"{path}: {fmt(value)} {self.unavailable[value]}; expected {self.expected}"
            )
        if self.choices and value not in self.choices:
            hint = difflib.get_close_matches(value, self.choices, n=1, cutoff=0.6)
            extra = f' (did you mean "{hint[0]}"?)' if hint else ""
            raise err(path, self.expected, value, extra)
        if self.name and not _NAME_RE.match(value):
            raise err(path, self.expected, value)
        if not self.choices and not self.name and not value.strip():
            raise err(path, "a non-empty string", value)
        return value


class Num(Validator):
    """A finite float in a range; ints are accepted, bools are not numbers."""

    def __init__(
        self,
        lo: float | None = None,
        hi: float | None = None,
        lo_open: bool = False,
        hi_open: bool = False,
        name: str | None = None,
    ):
        self.lo, self.hi, self.lo_open, self.hi_open, self.name = lo, hi, lo_open, hi_open, name
        self.expected = self._text("x")

    def _text(self, name: str) -> str:
        lo = None if self.lo is None else fmt(float(self.lo))
        hi = None if self.hi is None else fmt(float(self.hi))
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

    def __call__(self, value: Any, path: str) -> float:
        expected = self._text(self.name or _leaf_name(path))
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise err(path, expected, value)
        try:
            x = float(value)
        except OverflowError:
            x = math.inf  # an integer too large for a float
        if not math.isfinite(x):
            raise err(path, "a finite number", value)
        if self.lo is not None and (x < self.lo or (self.lo_open and x == self.lo)):
            raise err(path, expected, value)
        if self.hi is not None and (x > self.hi or (self.hi_open and x == self.hi)):
            raise err(path, expected, value)
        return x


def _whole(v):
    """A whole float (``20.0``, as Python and numpy give) as the integer it is."""
    return int(v) if isinstance(v, float) and v.is_integer() and abs(v) < 2**53 else v


class Int(Validator):
    def __init__(self, lo: int | None = None):
        self.lo = lo
        self.expected = "an integer" if lo is None else f"an integer >= {lo}"

    def __call__(self, value: Any, path: str) -> int:
        value = _whole(value)
        if isinstance(value, bool) or not isinstance(value, int):
            raise err(path, self.expected, value)
        if self.lo is not None and value < self.lo:
            raise err(path, self.expected, value)
        return value


class Bool(Validator):
    expected = "true or false"

    def __call__(self, value: Any, path: str) -> bool:
        if not isinstance(value, bool):
            raise err(path, self.expected, value)
        return value


class Vec(Validator):
    """A fixed-length list of floats."""

    def __init__(
        self,
        n: int = 3,
        item: Validator | None = None,
        nonzero: bool = False,
        some_positive: bool = False,
        expected: str | None = None,
    ):
        self.n, self.item = n, item or Num()
        self.nonzero, self.some_positive = nonzero, some_positive
        self.expected = expected or (
            f"{'a nonzero vector of ' if nonzero else ''}{n} numbers [x, y, z]"
            if n == 3
            else f"{n} numbers"
        )

    def __call__(self, value: Any, path: str) -> list[float]:
        if not isinstance(value, list) or len(value) != self.n:
            raise err(path, self.expected, value)
        out = []
        for i, v in enumerate(value):
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                raise err(path, self.expected, value)
            try:
                out.append(self.item(v, join(path, i)))
            except SceneError:
                raise err(path, self.expected, value) from None
        if self.nonzero and not any(x != 0.0 for x in out):
            raise err(path, self.expected, value)
        if self.nonzero and not 1e-100 < max(abs(x) for x in out) < 1e100:
            # a direction: its length must survive squaring in double precision
            raise err(
                path,
                "a direction of moderate length (largest entry between 1e-100 and 1e100)",
                value,
            )
        if self.some_positive and not any(x > 0.0 for x in out):
            raise err(path, self.expected, value)
        return out


#: the most cells a generated strip may have: 1e7 Q2 cells are ~2e8 unknowns, past
#: what a direct solver on one machine factorises; a typo (an extra zero or two) beyond
#: it would exhaust the memory while meshing, before any message
MAX_CELLS = 10_000_000


class Divisions(Validator):
    expected = "[n_length, n_width], two integers >= 1"

    def __call__(self, value: Any, path: str) -> list[int]:
        given, value = value, [_whole(v) for v in value] if isinstance(value, list) else value
        if (
            not isinstance(value, list)
            or len(value) != 2
            or any(isinstance(v, bool) or not isinstance(v, int) or v < 1 for v in value)
        ):
            raise err(path, self.expected, given)
        if value[0] * value[1] > MAX_CELLS:
            raise SceneError(
                f"{path}: {value[0]} x {value[1]} = {value[0] * value[1]:.3g} cells, "
                f"more than the {MAX_CELLS:.0e} a run can be made of (a typo?)"
            )
        return list(value)


#: the scene's [parameters] while its formulas are validated (``scene_parameters``)
_PARAMETERS: contextvars.ContextVar[dict] = contextvars.ContextVar("parameters", default={})


@contextlib.contextmanager
def scene_parameters(values: dict) -> Iterator[None]:
    """Within this block, formulas may use the names of ``values`` (a scene's
    ``[parameters]``); each is replaced by its number in the validated scene."""
    token = _PARAMETERS.set(dict(values or {}))
    try:
        yield
    finally:
        _PARAMETERS.reset(token)


class Formula(Validator):
    """A number (checked by ``number``) or a formula of ``variables`` (a string,
    :mod:`rftfem.scene.expressions`).  A formula without variables is its number.  The
    scene's parameters in a formula are replaced by their numbers."""

    def __init__(self, variables: tuple[str, ...], number: Validator | None = None):
        self.variables, self.number = tuple(variables), number or Num()
        names = ", ".join(self.variables)
        self.expected = (
            f"{self.number.expected} or a formula of {names} (a string)"
            if self.variables
            else self.number.expected
        )

    def __call__(self, value: Any, path: str) -> float | str:
        from rftfem.scene.expressions import parse, substitute

        if isinstance(value, str):
            value = substitute(value, _PARAMETERS.get())
            formula = parse(value, path, self.variables)
            if not formula.constant:
                return value
            value = formula.value()
        return self.number(value, path)


class Formulas(Validator):
    """``n`` entries, each a number or a formula of ``variables``; all numbers: checked
    as :class:`Vec` (``nonzero``)."""

    def __init__(self, variables: tuple[str, ...], n: int = 3, nonzero: bool = False):
        self.item = Formula(variables)
        self.vec = Vec(n, nonzero=nonzero)
        self.n = n
        self.expected = (
            f"{n} entries [x, y, z], each a number or a formula of "
            f"{', '.join(variables)} (a string)"
        )

    def __call__(self, value: Any, path: str) -> list[float | str]:
        if not isinstance(value, list) or len(value) != self.n:
            raise err(path, self.expected, value)
        out = [self.item(v, join(path, i)) for i, v in enumerate(value)]
        if all(not isinstance(v, str) for v in out):
            return self.vec(out, path)
        return out


class Fix(Validator):
    options = ("ux", "uy", "uz", "rotation", "clamped")
    expected = "a non-empty list of " + one_of(options)

    def __call__(self, value: Any, path: str) -> list[str]:
        if not isinstance(value, list) or not value:
            raise err(path, self.expected, value)
        for i, v in enumerate(value):
            if not isinstance(v, str) or v not in self.options:
                extra = ""
                if isinstance(v, str):
                    hint = difflib.get_close_matches(v, self.options, n=1, cutoff=0.6)
                    extra = f' (did you mean "{hint[0]}"?)' if hint else ""
                raise err(join(path, i), "one of " + one_of(self.options), v, extra)
        return list(value)


class Where(Validator):
    expected = (
        'a selector: "all", "x=0", "x=L", "y=0", "y=W", a [[hinge]] line, '
        "or a region / physical-group name"
    )

    def __init__(self, expected: str | None = None):
        if expected:
            self.expected = expected

    def __call__(self, value: Any, path: str) -> str:
        if not isinstance(value, str) or not value.strip() or value != value.strip():
            raise err(path, self.expected, value)
        return value


POSITIVE = Num(0.0, lo_open=True)
NONNEGATIVE = Num(0.0)
