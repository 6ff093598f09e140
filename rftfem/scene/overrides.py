"""The command line's changes to a scene: ``--set KEY=VALUE`` and ``--unset KEY``.

Both go, in the order given, into one list of override texts (``dest="overrides"``)
that ``load_scene`` applies: a ``--set`` as ``KEY=VALUE``, an ``--unset`` as
``--unset KEY`` (``reading.unset_text``), the form summary.json records and a
sweep's child runs are given again.
"""

from __future__ import annotations

import argparse
from typing import Any

from rftfem.scene.reading import UNSET, unset_text


def add_override_arguments(parser: argparse.ArgumentParser) -> None:
    """``--set`` and ``--unset`` on a command that reads a scene."""
    parser.add_argument(
        "--set",
        metavar="KEY=VALUE",
        action="append",
        default=[],
        dest="overrides",
        help="override one scene key, VALUE in TOML syntax "
        "(e.g. --set load.0.value=[0,52.36,0]); repeatable",
    )
    parser.add_argument(
        "--unset",
        metavar="KEY",
        action="append",
        dest="overrides",
        type=unset_text,
        help="remove one scene key, so that its default (or nothing) "
        "applies (e.g. --unset fluid.drag to switch to "
        "fluid.model=stokes); repeatable",
    )


def as_arguments(texts: list[str]) -> list[str]:
    """The override texts as command-line arguments (``--set T`` / ``--unset KEY``)."""
    out = []
    for text in texts:
        out += ["--unset", text[len(UNSET) :]] if text.startswith(UNSET) else ["--set", text]
    return out


def lookup(scene: dict, key: str, absent: Any = None) -> Any:
    """The value at the dotted ``key`` (``shell.parts.0.E``: tables by name, arrays by
    index) of a scene's nested dicts and lists, a completed scene's or a raw one's;
    ``absent`` where it has none (an unknown key, an index out of range, a private
    ``_`` entry), None inside a table the scene does not have (a None on the way)."""
    node = scene
    for part in key.split("."):
        if node is None:
            return None
        if isinstance(node, dict) and part in node and not part.startswith("_"):
            node = node[part]
        elif isinstance(node, list) and part.isdigit() and int(part) < len(node):
            node = node[int(part)]
        else:
            return absent
    return node
