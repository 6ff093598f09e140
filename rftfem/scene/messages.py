"""The wording of every scene error: a value as a message shows it, the
``PATH: expected WHAT, found VALUE`` of :func:`err`, and the :class:`Validator`
whose ``expected`` text those messages quote (:mod:`rftfem.scene.validators`)."""

from __future__ import annotations

import difflib
from typing import Any, Iterable

from rftfem.errors import SceneError


def fmt(value: Any, limit: int = 60) -> str:
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
        text = "[" + ", ".join(fmt(v, limit) for v in value) + "]"
    elif isinstance(value, dict):
        text = "{" + ", ".join(f"{k} = {fmt(v, limit)}" for k, v in value.items()) + "}"
    elif value is None:
        text = "nothing"
    else:
        text = str(value)
    if len(text) > limit:
        text = text[: limit - 3] + "..."
    return text


def found(value: Any) -> str:
    """'the string "abc"', 'the boolean true', '-0.1', 'a table', ..."""
    if isinstance(value, bool):
        return "the boolean " + fmt(value)
    if isinstance(value, str):
        return "the string " + fmt(value)
    if isinstance(value, dict):
        return "a table"
    if isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
        return f"an array of {len(value)} table(s)"
    if isinstance(value, (int, float, list)):
        return fmt(value)
    return f"a {type(value).__name__.replace('datetime', 'date-time')} value {fmt(value)}"


def one_of(options: Iterable[str]) -> str:
    opts = [f'"{o}"' for o in options]
    if len(opts) <= 2:
        return " or ".join(opts)
    return ", ".join(opts[:-1]) + " or " + opts[-1]


def suggest(word: str, options: Iterable[str], prefix: str = "") -> str:
    close = difflib.get_close_matches(word, list(options), n=1, cutoff=0.6)
    return f" (did you mean '{prefix}{close[0]}'?)" if close else ""


def err(path: str, expected: str, value: Any, extra: str = "") -> SceneError:
    return SceneError(f"{path}: expected {expected}, found {found(value)}{extra}")


def join(path: str, key: str | int) -> str:
    return f"{path}.{key}" if path else str(key)


# A validator is a callable (value, path) -> normalised value with an ``expected``
# text used for "missing required key" messages (the kinds: rftfem.scene.validators).


class Validator:
    expected = "a value"

    def __call__(self, value: Any, path: str) -> Any:  # pragma: no cover - abstract
        raise NotImplementedError

    def describe(self, name: str) -> str:
        """The accepted values of a key called ``name`` (for the scene reference)."""
        return self.expected
