"""What ``--reuse`` compares (``rftfem sweep``, ``study`` and ``optimize``): a run
folder is kept only when it holds a finished run (summary.json status ``ok``;
for ``optimize`` ``failed`` too) made from the same content as the run the
command would start now, whatever the scene file is called or where it is.

The key (:func:`key_of`) is a SHA-256 over:

- the completed scene: the scene file read, the sweep's and the point's
  ``--set``/``--unset`` applied, every default filled in, the time scheme
  resolved, as :func:`rftfem.scene.reading.load_scene` gives it to the run; less
  its bookkeeping entries (``_path``, ``_folder``, ``_overrides``, ``_raw``).
  Every value the run sees counts (the title too); what the completed scene does
  not show does not: the file's comments, layout and key order, how a value is
  spelled (``1e4`` or ``10000.0``), a default written out or left out, a value
  of the file that an override replaces;
- the bytes of every file the scene names by path: ``mesh.file`` (kind "gmsh")
  and every ``profile`` (a material value's ``{ profile = "f.csv" }`` in
  ``[shell]`` or ``shell.parts``, ``magnetic.parts.N.profile``). A file's digest
  stands in the key in place of its name: its content counts, not its name or
  folder (a file that cannot be read is keyed as missing);
- the PETSc options of the command line (every run is given them).

Not covered: rftfem's own code and the stack it runs on, the number of processes
(``--np``), the executor. A run folder whose ``reuse.json`` is missing (a folder
from before keys were compared, or a run cut short before its key was written)
is not reused: its run is made again, and the command says so (:func:`report`).

A command keys each run (a sweep's combination, a study's level, an optimisation's
evaluation) before it starts it and writes ``reuse.json`` into its folder once the
run has ended well (for ``optimize``, or failed with a summary), and only when the
key is still the same then: a scene or file edited while the command ran leaves
the runs it may have reached unkeyed, so a later ``--reuse`` runs them again.
"""

from __future__ import annotations

import hashlib
import json
import os
import time
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from collections.abc import Iterable, Sequence
    from typing import Any

#: the file in a run folder that holds the key of the run it holds
KEY_FILE = "reuse.json"
#: the completed scene's bookkeeping, not given to the run as values
_BOOKKEEPING = ("_path", "_folder", "_overrides", "_raw")
#: file digests already computed: (path, size, mtime, ctime, inode) -> digest
_DIGESTS: dict = {}


def files_read(scene: dict) -> dict[str, Path]:
    """The files a completed ``scene`` names by path, by their key (``mesh.file``,
    ``shell.thickness.profile``, ``magnetic.parts.0.profile``)."""
    folder = Path(scene.get("_folder") or ".")
    found = {}
    mesh = scene.get("mesh") or {}
    if mesh.get("kind") == "gmsh" and mesh.get("file"):
        found["mesh.file"] = folder / Path(mesh["file"]).expanduser()

    def walk(node, path):
        if isinstance(node, dict):
            for k, v in node.items():
                if k == "profile" and isinstance(v, str):
                    found[f"{path}.{k}"] = folder / Path(v).expanduser()
                else:
                    walk(v, f"{path}.{k}" if path else str(k))
        elif isinstance(node, list):
            for i, v in enumerate(node):
                walk(v, f"{path}.{i}")

    walk({k: v for k, v in scene.items() if k not in _BOOKKEEPING}, "")
    return found


def _digest(path: Path) -> str:
    """The SHA-256 of the file's bytes; kept for the file's size and times, once
    these are 2 s old (an edit within a clock tick of the last leaves them as they
    were)."""
    try:
        st = os.stat(path)
        stamp = (str(Path(path).resolve()), st.st_size, st.st_mtime_ns, st.st_ctime_ns, st.st_ino)
        if stamp in _DIGESTS:
            return _DIGESTS[stamp]
        digest = hashlib.sha256(Path(path).read_bytes()).hexdigest()
        if time.time_ns() - max(st.st_mtime_ns, st.st_ctime_ns) > 2_000_000_000:
            _DIGESTS[stamp] = digest
        return digest
    except OSError:
        return "missing"


def _text(obj) -> str:
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), default=repr)


def key_of(scene: dict, petsc_args: Sequence[str] = ()) -> dict:
    """The key of a run of the completed ``scene`` given ``petsc_args``: its parts
    (``scene``, ``files``, ``petsc``, digests) and ``key``, the digest of them all."""
    files = {name: _digest(path) for name, path in files_read(scene).items()}
    # a copy (the scene itself is left as it was) whose file names are keyed by content
    values = json.loads(_text({k: v for k, v in scene.items() if k not in _BOOKKEEPING}))
    for name in files:
        *path, last = name.split(".")
        node = values
        for part in path:
            node = node[int(part)] if isinstance(node, list) else node[part]
        node[last] = "a file: its digest in files"
    parts = {
        "scene": hashlib.sha256(_text(values).encode()).hexdigest(),
        "files": files,
        "petsc": hashlib.sha256(_text(list(petsc_args)).encode()).hexdigest(),
    }
    return {"key": hashlib.sha256(_text(parts).encode()).hexdigest(), **parts}


def unchanged(
    key: dict, scene_file: str | Path, overrides: Sequence[str], petsc_args: Sequence[str] = ()
) -> bool:
    """Whether the scene file with ``overrides`` (and the files it names) still has
    ``key``; a scene that no longer loads has not."""
    from rftfem.errors import SceneError
    from rftfem.scene.reading import load_scene

    try:
        return key_of(load_scene(str(scene_file), list(overrides)), petsc_args) == key
    except SceneError:
        return False


def write_key(folder: Path, key: dict) -> None:
    (Path(folder) / KEY_FILE).write_text(json.dumps(key, indent=1) + "\n", encoding="utf-8")


def status_of(folder: Path) -> str | None:
    """The status of the run in ``folder`` (summary.json's), or None without one."""
    try:
        summary = json.loads((Path(folder) / "summary.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return summary.get("status") if isinstance(summary, dict) else None


def why_not_reused(folder: Path, key: dict, finished: Sequence[str] = ("ok",)) -> str | None:
    """None when ``folder`` holds a finished run (its status one of ``finished``) with
    ``key``; else why not: ``""`` when it holds no finished run (nothing to say), else
    what differs."""
    folder = Path(folder)
    if status_of(folder) not in finished:
        return ""
    try:
        kept = json.loads((folder / KEY_FILE).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return (
            f"no {KEY_FILE}: a run from before --reuse compared content, or one cut "
            "short before its key was written"
        )
    if kept.get("key") == key["key"]:
        return None
    what = [
        f"the content of {name}"
        for name in sorted(set(key["files"]) | set(kept.get("files", {})))
        if kept.get("files", {}).get(name) != key["files"].get(name)
    ]
    if kept.get("scene") != key["scene"]:
        what.insert(0, "the completed scene")
    if kept.get("petsc") != key["petsc"]:
        what.append("the PETSc options")
    return (", ".join(what) + " changed since") if what else "its key differs"


def reused(
    folder: Path, key: dict | None, reuse: bool, finished: Sequence[str] = ("ok",)
) -> tuple[bool, str]:
    """Whether ``--reuse`` keeps the run in ``folder`` (a finished run with ``key``), and
    else the note to report (:func:`report`; "" when there is nothing to say)."""
    why = why_not_reused(folder, key, finished) if reuse and key is not None else ""
    if why is None:
        return True, ""
    return False, f"finished run(s) run again, not reused ({why})" if why else ""


def keep_key(
    folder: Path,
    key: dict | None,
    scene_file: str | Path,
    overrides: Sequence[str],
    petsc_args: Sequence[str],
    command: str,
) -> str:
    """After a run in ``folder`` ended well: write ``key`` there if the scene (and the
    files it names) still has it; else the note to report."""
    if key is not None and unchanged(key, scene_file, overrides, petsc_args):
        write_key(folder, key)
        return ""
    return (
        "run(s) not keyed for --reuse, the scene or a file it names changed while "
        f"the {command} ran"
    )


def report(notes: Iterable[tuple[str, str]], console: Any, command: str) -> None:
    """One line on stderr per note of :func:`reused` and :func:`keep_key`, with how many
    runs it is and the first one's folder; ``notes`` are (note, folder name) pairs."""
    notes = list(notes)
    for note in dict.fromkeys(n for n, _ in notes if n):
        which = [name for n, name in notes if n == note]
        console.err(f"rftfem {command}: {len(which)} {note}; the first: {which[0]}")


__all__ = [
    "KEY_FILE",
    "files_read",
    "key_of",
    "unchanged",
    "write_key",
    "why_not_reused",
    "status_of",
    "reused",
    "keep_key",
    "report",
]
