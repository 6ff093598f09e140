"""The grammar of the scene's formulas: their tokens, functions and constants, and the
parser that makes a formula's tree (:mod:`rftfem.scene.expressions` evaluates it)."""

from __future__ import annotations

import math
import re
from typing import Iterable, NoReturn

from rftfem.errors import SceneError

#: function name -> number of arguments (None: two or more)
FUNCTIONS = {
    "sin": 1,
    "cos": 1,
    "tan": 1,
    "asin": 1,
    "acos": 1,
    "atan": 1,
    "atan2": 2,
    "exp": 1,
    "log": 1,
    "sqrt": 1,
    "abs": 1,
    "min": None,
    "max": None,
}
CONSTANTS = {"pi": math.pi}

#: one token: a number, a name or an operator (with the blanks before it)
TOKEN = re.compile(
    r"\s*(?:(?P<num>(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)|(?P<name>[A-Za-z_]\w*)"
    r"|(?P<op>[-+*/^(),]))"
)


class Parser:
    """The recursive descent that turns a formula's text into its tree (``parse``),
    raising a SceneError that names the key and the place in the text."""

    def __init__(self, text: str, key: str, variables: Iterable[str]):
        self.text, self.key, self.variables = text, key, tuple(variables)
        self.tokens, self.used = [], set()
        pos = 0
        while pos < len(text):
            m = TOKEN.match(text, pos)
            if not m or m.end() == pos:
                if text[pos:].strip() == "":
                    break
                bad = text[pos:].lstrip()[0]
                where = len(text) - len(text[pos:].lstrip())
                self._raise(f"unexpected character '{bad}'", where)
            kind = m.lastgroup
            start = m.start(kind)
            self.tokens.append((kind, m.group(kind), start))
            pos = m.end()
        self.i = 0

    def _raise(self, what: str, where: int) -> NoReturn:
        allowed = ", ".join(self.variables) if self.variables else "none"
        raise SceneError(
            f"{self.key}: {what} at position {where + 1} in formula "
            f"'{self.text}' (variables allowed here: {allowed})"
        )

    def fail(self, what: str) -> NoReturn:
        tok = self.peek()
        self._raise(what, tok[2] if tok else len(self.text))

    def peek(self) -> tuple[str, str, int] | None:
        return self.tokens[self.i] if self.i < len(self.tokens) else None

    def take(self, op: str | None = None) -> tuple[str, str, int]:
        tok = self.peek()
        if tok is None:
            self._raise("unexpected end" + (f" (expected '{op}')" if op else ""), len(self.text))
        if op is not None and tok[1] != op:
            self.fail(f"expected '{op}', found '{tok[1]}'")
        self.i += 1
        return tok

    def expression(self) -> tuple:
        tree = self.term()
        while self.peek() and self.peek()[1] in "+-" and self.peek()[0] == "op":
            op = self.take()[1]
            tree = ("bin", op, tree, self.term())
        return tree

    def term(self) -> tuple:
        tree = self.unary()
        while self.peek() and self.peek()[1] in ("*", "/"):
            op = self.take()[1]
            if self.peek() and self.peek()[1] == "*":
                self.fail("'**' is not a power here: write '^'")
            tree = ("bin", op, tree, self.unary())
        return tree

    def unary(self) -> tuple:
        tok = self.peek()
        if tok and tok[0] == "op" and tok[1] in "+-":
            self.take()
            inner = self.unary()
            return ("neg", inner) if tok[1] == "-" else inner
        return self.power()

    def power(self) -> tuple:
        base = self.atom()
        if self.peek() and self.peek()[1] == "^":
            self.take()
            return ("bin", "^", base, self.unary())
        return base

    def atom(self) -> tuple:
        tok = self.peek()
        if tok is None:
            self._raise("unexpected end (expected a number, a name or '(')", len(self.text))
        kind, text, where = tok
        if kind == "num":
            self.take()
            return ("num", float(text))
        if kind == "name":
            self.take()
            if self.peek() and self.peek()[1] == "(":
                if text not in FUNCTIONS:
                    self._raise(f"unknown function '{text}' (known: {', '.join(FUNCTIONS)})", where)
                self.take("(")
                args = [self.expression()]
                while self.peek() and self.peek()[1] == ",":
                    self.take(",")
                    args.append(self.expression())
                self.take(")")
                n = FUNCTIONS[text]
                if (n is not None and len(args) != n) or (n is None and len(args) < 2):
                    want = f"{n} argument{'s' if n != 1 else ''}" if n else "two or more arguments"
                    self._raise(f"{text}() takes {want}, found {len(args)}", where)
                return ("call", text, tuple(args))
            if text in CONSTANTS:
                return ("num", CONSTANTS[text])
            if text in self.variables:
                self.used.add(text)
                return ("var", text)
            if text in FUNCTIONS:
                self._raise(f"function '{text}' without its arguments", where)
            if text in ("X", "Y", "Z", "x", "y", "z", "t"):
                self._raise(f"variable '{text}' is not allowed here", where)
            self._raise(f"unknown name '{text}'", where)
        if text == "(":
            self.take("(")
            tree = self.expression()
            self.take(")")
            return tree
        self._raise(f"unexpected '{text}'", where)
