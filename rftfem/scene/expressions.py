"""Formulas in scene files: a small, safe expression language, parsed, never ``eval``ed.

A key that allows it takes a string such as ``"62.9*cos(2*pi*X/3.7)"``: numbers,
``+ - * / ^`` (``^`` is the power, binding tighter than a sign: ``-2^2`` is -4),
parentheses, the functions ``sin cos tan asin acos atan atan2 exp log sqrt abs
min max``, the constant ``pi`` and the variables the key allows (``X, Y, Z`` the
reference coordinates, ``x, y, z`` the current ones, ``t`` the time).

:func:`parse` turns the text into a :class:`Formula` (a small tree, by the grammar
of :mod:`rftfem.scene.formula_grammar`), or raises a one-line
:class:`~rftfem.errors.SceneError` naming the key and the place in the text.  A
formula becomes UFL (:meth:`Formula.ufl`, for forms) or numbers
(:meth:`Formula.numbers`, numpy arrays or floats) from the same tree.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Callable

import numpy as np

from rftfem.errors import SceneError
from rftfem.scene.formula_grammar import CONSTANTS, FUNCTIONS, TOKEN, Parser

if TYPE_CHECKING:  # (UFL is imported when a formula becomes UFL)
    import ufl


@dataclass(frozen=True)
class Formula:
    """A parsed formula: its text, its tree and the variables it uses."""

    text: str
    tree: tuple
    names: frozenset
    #: the scene key it was given for (for messages)
    key: str = field(default="", compare=False)

    @property
    def constant(self) -> bool:
        """Whether it uses no variable (then :meth:`value` is its number)."""
        return not self.names

    def value(self) -> float:
        return float(self.numbers({}))

    def numbers(self, env: dict) -> float | np.ndarray:
        """The formula's value for ``env`` (variable -> float or numpy array).

        A division by zero among floats (``1/t`` at ``t = 0``) is a SceneError naming
        the key and the values; numpy arrays give inf or nan as numpy does."""
        try:
            return _evaluate(self.tree, env, _NUMPY)
        except (ZeroDivisionError, OverflowError) as exc:
            at = ", ".join(f"{k} = {v:g}" for k, v in env.items() if isinstance(v, (int, float)))
            raise SceneError(
                f"{self.key or 'formula'}: '{self.text}' has no value"
                f"{' at ' + at if at else ''} ({exc})"
            ) from None

    def ufl(
        self, env: dict, number: Callable[[float], ufl.core.expr.Expr] | None = None
    ) -> ufl.core.expr.Expr | float:
        """The formula as a UFL expression of ``env`` (variable -> UFL expression).

        ``number`` (float -> UFL), if given, makes each number of the formula (but
        exponents) a coefficient, e.g. a ``fem.Constant``: the compiled form then
        does not depend on the numbers, and a sweep over them compiles it once."""
        functions = dict(_ufl_functions())
        if number is not None:
            functions["__number__"] = number
        return _evaluate(self.tree, env, functions)


#: names a scene's [parameters] may not take (the formulas' own)
RESERVED = frozenset(FUNCTIONS) | frozenset(CONSTANTS) | {"X", "Y", "Z", "x", "y", "z", "t"}


def substitute(text: str, values: dict) -> str:
    """``text`` with each name in ``values`` (a scene parameter, not a function call)
    replaced by its number in parentheses; the rest of the text as it was."""
    if not values:
        return text
    out, pos = [], 0
    matches = list(TOKEN.finditer(text))
    for n, m in enumerate(matches):
        if m.end() == m.start():
            break
        name = m.group("name")
        following = matches[n + 1].group("op") if n + 1 < len(matches) else None
        if name in values and following != "(":
            start = m.start("name")
            out.append(text[pos:start] + f"({float(values[name])!r})")
            pos = m.end()
    return "".join(out) + text[pos:]


def parse(text: str | float, key: str, variables: tuple[str, ...]) -> Formula:
    """Parse ``text`` (a string, or a number taken as it is) for the scene key ``key``
    whose formulas may use ``variables``."""
    if isinstance(text, bool) or not isinstance(text, (str, int, float)):
        raise SceneError(f"{key}: expected a number or a formula (a string), found {text!r}")
    if not isinstance(text, str):
        value = float(text)
        if not math.isfinite(value):
            raise SceneError(f"{key}: expected a finite number, found {text!r}")
        return Formula(repr(value), ("num", value), frozenset(), key)
    parser = Parser(text, key, variables)
    tree = parser.expression()
    if parser.peek() is not None:
        parser.fail(f"unexpected '{parser.peek()[1]}'")
    if _check_constant_parts(tree, text, key):
        _require_finite(tree, text, key)
    return Formula(text, tree, frozenset(parser.used), key)


def _check_constant_parts(tree, text: str, key: str) -> bool:
    """Raise a :class:`SceneError` if a part of the formula that uses no variable has
    no finite real value: ``X/0``, ``log(0)``, ``(-8)^(1/3)``, typically a scene
    parameter set to 0 (parameters are numbers in the text by then).  Returns
    whether ``tree`` itself is constant."""
    kind = tree[0]
    if kind == "num":
        return True
    if kind == "var":
        return False
    parts = [tree[1]] if kind == "neg" else list(tree[2]) if kind == "call" else [tree[2], tree[3]]
    constant = [_check_constant_parts(p, text, key) for p in parts]
    if all(constant):
        return True
    for part, const in zip(parts, constant):
        if const:
            _require_finite(part, text, key)
    if kind not in ("neg", "call") and tree[1] == "/" and constant[1]:
        with np.errstate(all="ignore"):
            if _evaluate(tree[3], {}, _NUMPY) == 0:
                raise SceneError(
                    f"{key}: '{text}' divides by zero ({_show(tree)}); is a parameter 0?"
                )
    return False


def _require_finite(part, text: str, key: str) -> None:
    """Raise if the constant ``part`` has no finite real value, naming its smallest
    part that has none."""
    if _finite(part):
        return
    while True:
        children = (
            [part[1]]
            if part[0] == "neg"
            else list(part[2])
            if part[0] == "call"
            else [part[2], part[3]]
        )
        bad = [c for c in children if not _finite(c)]
        if not bad:
            break
        part = bad[0]
    raise SceneError(
        f"{key}: '{text}' has a part without a finite value "
        f"({_show(part)}); is a parameter 0 or out of range?"
    )


def _finite(part) -> bool:
    if part[0] == "num":
        return True
    try:
        with np.errstate(all="ignore"):
            value = _evaluate(part, {}, _NUMPY)
        return not isinstance(value, complex) and math.isfinite(float(value))
    except (ZeroDivisionError, OverflowError, ValueError, TypeError):
        return False


def _show(tree) -> str:
    """A formula's tree as text (for messages)."""
    kind = tree[0]
    if kind == "num":
        return repr(tree[1])
    if kind == "var":
        return tree[1]
    if kind == "neg":
        return f"-{_show(tree[1])}"
    if kind == "call":
        return f"{tree[1]}({', '.join(_show(a) for a in tree[2])})"
    return f"({_show(tree[2])} {tree[1]} {_show(tree[3])})"


_NUMPY = {
    "sin": np.sin,
    "cos": np.cos,
    "tan": np.tan,
    "asin": np.arcsin,
    "acos": np.arccos,
    "atan": np.arctan,
    "atan2": np.arctan2,
    "exp": np.exp,
    "log": np.log,
    "sqrt": np.sqrt,
    "abs": np.abs,
    "min": np.minimum,
    "max": np.maximum,
}


def _ufl_functions() -> dict:
    import ufl

    atan2 = getattr(ufl, "atan2", None) or getattr(ufl, "atan_2")  # UFL 2022 names it atan_2
    return {
        "sin": ufl.sin,
        "cos": ufl.cos,
        "tan": ufl.tan,
        "asin": ufl.asin,
        "acos": ufl.acos,
        "atan": ufl.atan,
        "atan2": atan2,
        "exp": ufl.exp,
        "log": ufl.ln,
        "sqrt": ufl.sqrt,
        "abs": abs,
        "min": ufl.min_value,
        "max": ufl.max_value,
    }


def _evaluate(tree, env, functions, literal=False):
    kind = tree[0]
    if kind == "num":
        hook = None if literal else functions.get("__number__")
        return hook(tree[1]) if hook else tree[1]
    if kind == "var":
        return env[tree[1]]
    if kind == "neg":
        return -_evaluate(tree[1], env, functions, literal)
    if kind == "call":
        args = [_evaluate(a, env, functions, literal) for a in tree[2]]
        f = functions[tree[1]]
        out = args[0]
        if tree[1] in ("min", "max"):
            for a in args[1:]:
                out = f(out, a)
            return out
        return f(*args)
    _, op, a, b = tree
    # an exponent's numbers stay numbers: x^2 stays a square for the compiler
    a, b = _evaluate(a, env, functions), _evaluate(b, env, functions, literal or op == "^")
    if op == "+":
        return a + b
    if op == "-":
        return a - b
    if op == "*":
        return a * b
    if op == "/":
        return a / b
    return a**b


#: the functions whose argument sets a period: sin and cos repeat every 2π, tan every π
_PERIODIC = {"sin": 2 * math.pi, "cos": 2 * math.pi, "tan": math.pi}


def periods_in_time(formula: Formula) -> list[float]:
    """The periods in ``t`` that the formula's ``sin``, ``cos`` and ``tan`` can be read
    to have: those whose argument is linear in ``t`` (``sin(2*pi*5*t + 1)``: 0.2),
    evaluated with every other variable at 0.  Arguments that are not linear in t
    (``sin(t^2)``) or do not move are left out."""
    found = []

    def walk(tree):
        if tree[0] == "call":
            if tree[1] in _PERIODIC:
                arg = tree[2][0]
                env = {name: 0.0 for name in formula.names}
                try:
                    with np.errstate(all="ignore"):
                        values = [
                            float(_evaluate(arg, {**env, "t": t}, _NUMPY)) for t in (0.0, 1.0, 2.0)
                        ]
                except (KeyError, ValueError, ZeroDivisionError):
                    values = [math.nan] * 3
                rate = values[1] - values[0]
                linear = abs(values[2] - 2 * values[1] + values[0]) <= 1e-9 * max(
                    1.0, *map(abs, values)
                )
                if all(map(math.isfinite, values)) and linear and rate != 0.0:
                    found.append(_PERIODIC[tree[1]] / abs(rate))
            for a in tree[2]:
                walk(a)
        elif tree[0] == "neg":
            walk(tree[1])
        elif tree[0] == "bin":
            walk(tree[2])
            walk(tree[3])

    if "t" in formula.names:
        walk(formula.tree)
    return found
