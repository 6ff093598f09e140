"""The generated parts of docs/scenes.md: the scene keys and the command line.

    python -m rftfem.reference           # rewrite the generated parts
    python -m rftfem.reference --check   # exit 1 if they are out of date

docs/scenes.md is hand-written except between marker comments::

    <!-- generated: scene keys -->
    ...
    <!-- end generated -->

The "scene keys" part (:mod:`rftfem.scene.key_reference`) comes from walking
:data:`rftfem.scene.keys.SCHEMA`: every key's full path (``mesh.length``,
``[[motion]].amplitude``), the values it accepts (the validator's ``expected``
text), its default, unit and meaning (the ``doc`` and ``unit`` of the schema
node). A key without ``doc``, or an optional key whose
default is nothing and that does not say what it gets instead (``default_doc``),
is an error: :class:`UndocumentedKey`. The "command line" part is the
``format_help()`` of :func:`rftfem.cli._build_parser` and of each subcommand,
formatted at a fixed width so that it does not depend on the terminal.

Importing this module needs neither dolfinx nor MPI.
"""

from __future__ import annotations

import argparse
import difflib
import os
import sys
from pathlib import Path

# the "scene keys" part, its names importable from here as before
from rftfem.scene.key_reference import (  # noqa: F401
    REGENERATE,
    UndocumentedKey,
    _array_item,
    _toml,
    documented_paths,
    scene_keys_markdown,
    walk,
)

#: docs/scenes.md of the source tree this module belongs to
DOC_PATH = Path(__file__).resolve().parents[1] / "docs" / "scenes.md"
#: the generated parts, by name; each sits between ``<!-- generated: NAME -->`` and END
PARTS = ("scene keys", "command line")
END = "<!-- end generated -->"
#: the width the help texts are formatted at (the COLUMNS argparse sees)
HELP_COLUMNS = 80


def start_marker(part: str) -> str:
    return f"<!-- generated: {part} -->"


# ---------------------------------------------------------------- command line


def _help(parser: argparse.ArgumentParser) -> str:
    """``parser.format_help()`` at HELP_COLUMNS columns, without trailing blanks."""
    saved = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = str(HELP_COLUMNS)
    try:
        text = parser.format_help()
    finally:
        if saved is None:
            del os.environ["COLUMNS"]
        else:
            os.environ["COLUMNS"] = saved
    return "\n".join(line.rstrip() for line in text.strip("\n").splitlines())


def command_line_markdown(parser: argparse.ArgumentParser | None = None) -> str:
    """The "command line" part: the help of ``rftfem`` and of each subcommand."""
    if parser is None:
        from rftfem.cli import _build_parser

        parser = _build_parser()
    out = [
        f"<!-- do not edit by hand: {REGENERATE} rewrites this part from the "
        "command-line parser -->",
        "",
    ]
    parsers = [(parser.prog, parser)]
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            parsers += [(sub.prog, sub) for sub in action.choices.values()]
    for prog, p in parsers:
        out += [f"### `{prog}`", "", "```text", _help(p), "```", ""]
    return "\n".join(out).rstrip("\n")


# --------------------------------------------------------------- the document


#: the function that writes each generated part
GENERATORS = {"scene keys": scene_keys_markdown, "command line": command_line_markdown}


def generate() -> dict[str, str]:
    """The current text of every generated part, by name."""
    return {name: GENERATORS[name]() for name in PARTS}


def _span(text: str, part: str) -> tuple[int, int]:
    """Start and end offsets of the body of ``part`` in ``text`` (between the markers)."""
    start = start_marker(part)
    if text.count(start) != 1:
        raise ValueError(
            f"expected exactly one line '{start}' in the document, found {text.count(start)}"
        )
    i = text.index(start) + len(start)
    j = text.find(END, i)
    if j < 0:
        raise ValueError(f"no '{END}' after '{start}'")
    return i, j


def extract(text: str) -> dict[str, str]:
    """The generated parts as they stand in a document's ``text``."""
    out = {}
    for part in PARTS:
        i, j = _span(text, part)
        out[part] = text[i:j].strip("\n")
    return out


def replace(text: str, parts: dict[str, str]) -> str:
    """``text`` with the body of each generated part replaced."""
    for part, body in parts.items():
        i, j = _span(text, part)
        text = text[:i] + "\n" + body + "\n" + text[j:]
    return text


def stale_parts(text: str, parts: dict[str, str] | None = None) -> list[str]:
    """The names of the parts whose text in ``text`` differs from what is generated now."""
    parts = generate() if parts is None else parts
    found = extract(text)
    return [name for name in PARTS if found[name] != parts[name]]


def diff(text: str, parts: dict[str, str] | None = None, limit: int = 40) -> str:
    """A unified diff (at most ``limit`` lines) of the stale parts, document -> generated."""
    parts = generate() if parts is None else parts
    found = extract(text)
    lines: list[str] = []
    for name in PARTS:
        if found[name] != parts[name]:
            lines += difflib.unified_diff(
                found[name].splitlines(),
                parts[name].splitlines(),
                f"docs/scenes.md ({name})",
                f"generated ({name})",
                lineterm="",
                n=1,
            )
    if len(lines) > limit:
        lines = lines[:limit] + [f"... ({len(lines) - limit} more lines)"]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m rftfem.reference",
        description="Rewrite the generated parts of docs/scenes.md (scene keys from "
        "the schema, command line from rftfem/cli.py).",
    )
    ap.add_argument(
        "--check", action="store_true", help="change nothing; exit 1 if the document is out of date"
    )
    ap.add_argument("--file", type=Path, default=DOC_PATH, help=f"default: {DOC_PATH}")
    args = ap.parse_args(argv)
    try:
        text = args.file.read_text(encoding="utf-8")
        parts = generate()
        stale = stale_parts(text, parts)
    except (OSError, ValueError) as exc:
        print(f"scene_reference: error: {exc}", file=sys.stderr)
        return 2
    if args.check:
        if stale:
            print(
                f"{args.file}: out of date ({', '.join(stale)}); regenerate with "
                f"{REGENERATE}\n{diff(text, parts)}",
                file=sys.stderr,
            )
            return 1
        print(f"{args.file}: up to date")
        return 0
    if stale:
        args.file.write_text(replace(text, parts), encoding="utf-8")
        print(f"{args.file}: rewrote {', '.join(stale)}")
    else:
        print(f"{args.file}: up to date")
    return 0


if __name__ == "__main__":
    sys.exit(main())
