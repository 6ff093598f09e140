"""Changes made to a scene from Python (:class:`rftfem.Scene`): dotted keys to values,
made in the raw table as ``--set`` and ``--unset`` make them, with their override texts."""

from __future__ import annotations

import copy
from typing import Any, Mapping

from rftfem.errors import SceneError
from rftfem.scene import toml_writer
from rftfem.scene.reading import set_key, unset_key, unset_text


def _override_text(key: str, value: Any) -> str:
    """``key=value`` as it would be typed after ``--set`` (for summary.json)."""
    try:
        return f"{key}={toml_writer.value(value)}"
    except (TypeError, ValueError):
        return f"{key}={value!r}"


def apply_changes(raw: dict, changes: Mapping[str, Any], what: str = "Scene.update") -> list[str]:
    """Make ``changes`` (dotted keys to values) in the raw table; their override texts.
    A value None removes the key, as ``--unset`` does (TOML has no null)."""
    if not isinstance(changes, Mapping):
        raise SceneError(
            f"{what}: expected a dict of dotted keys to values "
            f"({{'time.dt': 0.01}}), found {type(changes).__name__}"
        )
    texts = []
    for key, value in changes.items():
        key_path(key)
        try:
            if value is None:
                unset_key(raw, key)
                texts.append(unset_text(key))
            else:
                value = _plain(copy.deepcopy(value))
                set_key(raw, key, value)
                texts.append(_override_text(key, value))
        except SceneError as exc:
            raise SceneError(_python_form(str(exc), key)) from None
    return texts


def _python_form(message: str, key: str) -> str:
    """A --set/--unset message as Python's: ``scene["KEY"]: ...``."""
    for prefix in (f"--set {key}: ", f"--unset {key}: ", "--set: ", "--unset: "):
        if message.startswith(prefix):
            return f'scene["{key}"]: ' + message[len(prefix) :]
    return message


def _plain(value: Any) -> Any:
    """Tuples and numpy arrays as lists, numpy scalars as Python numbers: the values a
    TOML scene holds (``scene["mesh.divisions"] = (20, 4)``)."""
    if isinstance(value, tuple) or type(value).__module__ == "numpy":
        value = value.tolist() if hasattr(value, "tolist") else list(value)
    if isinstance(value, list):
        return [_plain(v) for v in value]
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    return value


def key_path(key: str) -> list[str]:
    """The parts of a dotted key (``shell.thickness``); SceneError if it is not one."""
    if not isinstance(key, str) or not key or any(not p for p in key.split(".")):
        raise SceneError(f"expected a dotted key path like shell.thickness, found {key!r}")
    return key.split(".")
