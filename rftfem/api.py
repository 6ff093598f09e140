"""rftfem from Python: scenes as objects that validate every change, and runs.

The functions here are what ``import rftfem`` offers (docs/python.md)::

    scene = rftfem.load_scene("demos/swimming_sheet.toml", set={"time.end": 2.0})
    scene["magnetic.field.frequency"] = 8.0     # checked now, as --set would be
    result = rftfem.run(scene, out="results/x")  # a rftfem.Result

A :class:`Scene` keeps the scene's raw table (what a TOML file would hold, with
the changes made to it) and the completed scene that the command line would
run; every change re-validates the whole scene, so a change is either accepted
as a whole or refused with the command line's one-line :class:`SceneError`. A
scene pickles as its raw table and folder, and is checked again when unpickled.
"""

from __future__ import annotations

import copy
import os
import warnings
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Iterable, Mapping

from rftfem.errors import RunFailed, RunInterrupted, RunWarning, SceneError
from rftfem.scene import toml_writer
from rftfem.scene.overrides import lookup
from rftfem.scene.python_changes import apply_changes, key_path
from rftfem.scene.reading import (
    complete_scene,
    parse_scene_text,
    read_scene_file,
    set_key,
    unset_key,
    unset_text,
)

if TYPE_CHECKING:  # (the run's Result and the MPI communicator are loaded when used)
    from mpi4py import MPI

    from rftfem.result import Result

__all__ = ["Scene", "load_scene", "scene_from_dict", "scene_from_toml", "run"]

_ABSENT = object()  # what lookup gives for a key the scene has no place for


class Scene:
    """A validated scene. ``scene["a.b.c"]`` reads a value of the completed scene
    (defaults filled in); ``scene["a.b.c"] = v`` changes it and validates the scene
    again, raising :class:`SceneError` (and changing nothing) if it is refused.
    Arrays of tables take an index: ``scene["load.0.value"]``."""

    def __init__(
        self,
        raw: Mapping,
        folder: str | os.PathLike = ".",
        path: str | os.PathLike | None = None,
        overrides: Iterable[str] = (),
    ):
        if not isinstance(raw, Mapping):
            raise SceneError(
                f"a scene: expected a table (dict) of keys, found {type(raw).__name__}"
            )
        self._raw = copy.deepcopy(dict(raw))
        self._folder = str(Path(folder).expanduser().resolve())
        self._path = None if path is None else str(Path(path).expanduser().resolve())
        self._overrides = list(overrides)
        self._scene = complete_scene(self._raw, self._folder, self._path, self._overrides)

    # --- reading ---------------------------------------------------------------

    def __getitem__(self, key: str) -> Any:
        key_path(key)
        node = lookup(self._scene, key, absent=_ABSENT)  # None in a table it does not have
        if node is _ABSENT:
            # let the schema name what is wrong (unknown key, index out of range)
            try:
                set_key(copy.deepcopy(self._raw), key, None)
            except SceneError as exc:
                text = str(exc)
                raise SceneError(
                    text[len("--set: ") :] if text.startswith("--set: ") else text
                ) from None
            return None
        return copy.deepcopy(node)

    def get(self, key: str, default: Any = None) -> Any:
        """``scene[key]``, or ``default`` where the scene has no value there."""
        value = self[key]
        return default if value is None else value

    def __contains__(self, key: str) -> bool:
        try:
            return self[key] is not None
        except SceneError:
            return False

    @property
    def title(self) -> str:
        return self._scene["title"]

    @property
    def path(self) -> Path | None:
        """The scene file it was read from (None for a scene from a dict or text)."""
        return None if self._path is None else Path(self._path)

    @property
    def folder(self) -> Path:
        """Where relative file names (mesh.file, profiles) are read from."""
        return Path(self._folder)

    @property
    def overrides(self) -> list[str]:
        """The changes made since the scene was read, as ``--set`` texts."""
        return list(self._overrides)

    def to_dict(self) -> dict:
        """The completed scene, every key with its value (as summary.json echoes it)."""
        return {k: copy.deepcopy(v) for k, v in self._scene.items() if not k.startswith("_")}

    def raw(self) -> dict:
        """The scene's own table: what its TOML file holds, with the changes made."""
        return copy.deepcopy(self._raw)

    def to_toml(self) -> str:
        """The scene's own table as TOML text (``scene_from_toml`` reads it back)."""
        return toml_writer.document(self._raw)

    def save(self, path: str | os.PathLike) -> Path:
        """Write :meth:`to_toml` to ``path``; relative file names keep working if it
        lies in :attr:`folder`."""
        path = Path(path)
        path.write_text(self.to_toml(), encoding="utf-8")
        return path

    # --- changing --------------------------------------------------------------

    def __setitem__(self, key: str, value: Any) -> None:
        self.update({key: value})

    def __delitem__(self, key: str) -> None:
        """``del scene["fluid.drag"]``: remove a key the scene sets (its default, or
        nothing, then applies), as ``--unset`` does; KeyError if the scene does not
        set it."""
        if not self._remove(key):
            raise KeyError(key)

    _NO_DEFAULT = object()

    def pop(self, key: str, default: Any = _NO_DEFAULT) -> Any:
        """Remove ``key`` and return the value the scene had set there (``default``, or
        KeyError, if it set none)."""
        removed = self._remove(key)
        if removed:
            return removed[0]
        if default is Scene._NO_DEFAULT:
            raise KeyError(key)
        return default

    def _remove(self, key: str) -> list:
        key_path(key)
        raw = copy.deepcopy(self._raw)
        removed = unset_key(raw, key)
        if removed:
            overrides = [*self._overrides, unset_text(key)]
            scene = complete_scene(raw, self._folder, self._path, overrides)
            self._raw, self._scene, self._overrides = raw, scene, overrides
        return removed

    def update(self, changes: Mapping[str, Any] | None = None, **_: Any) -> None:
        """Make several changes at once and validate once (for changes that only
        agree together, such as time.dt and time.end)."""
        if _:
            raise TypeError(
                "Scene.update takes a dict of dotted keys: scene.update({'time.dt': 0.01})"
            )
        raw = copy.deepcopy(self._raw)
        texts = apply_changes(raw, {} if changes is None else changes)
        overrides = [*self._overrides, *texts]
        scene = complete_scene(raw, self._folder, self._path, overrides)
        self._raw, self._scene, self._overrides = raw, scene, overrides

    def copy(self) -> "Scene":
        return copy.deepcopy(self)

    def with_values(self, changes: Mapping[str, Any]) -> "Scene":
        """A copy with ``changes`` made (this scene unchanged)."""
        other = self.copy()
        other.update(changes)
        return other

    # --- the rest --------------------------------------------------------------

    def check(self) -> list[str]:
        """What ``rftfem check`` checks beyond the keys: build the body and the
        model (no forms compiled) so that selectors, regions and probes meet the
        mesh; return the active effects. Raises :class:`SceneError` as check does."""
        from rftfem.integration.model_setup import check

        return check(self.completed())

    def completed(self) -> dict:
        """The completed scene dict that the simulation takes (a copy)."""
        return copy.deepcopy(self._scene)

    def __getstate__(self) -> dict:
        return {
            "raw": self._raw,
            "folder": self._folder,
            "path": self._path,
            "overrides": self._overrides,
        }

    def __setstate__(self, state: dict) -> None:
        self._raw, self._folder = state["raw"], state["folder"]
        self._path, self._overrides = state["path"], state["overrides"]
        self._scene = complete_scene(self._raw, self._folder, self._path, self._overrides)

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Scene) and self.to_dict() == other.to_dict()

    def __repr__(self) -> str:
        where = f" from {self._path}" if self._path else ""
        changed = f", {len(self._overrides)} change(s)" if self._overrides else ""
        return f"<rftfem.Scene {self.title!r}{where}{changed}>"


def load_scene(path: str | os.PathLike, set: Mapping[str, Any] | None = None) -> Scene:
    """Read the scene file ``path``, with the changes ``set`` (dotted keys to
    values, as ``--set``), and validate it as ``rftfem run`` does."""
    raw = read_scene_file(path)
    texts = apply_changes(raw, {} if set is None else set, "load_scene(set=...)")
    path = Path(path).expanduser().resolve()
    return Scene(raw, path.parent, path, texts)


def scene_from_dict(data: Mapping, folder: str | os.PathLike = ".") -> Scene:
    """A scene from a nested dict shaped like the TOML file; relative file names
    are read from ``folder`` (default: the working folder)."""
    return Scene(data, folder)


def scene_from_toml(text: str, folder: str | os.PathLike = ".") -> Scene:
    """A scene from TOML text; relative file names are read from ``folder``."""
    if not isinstance(text, str):
        raise SceneError(f"scene text: expected a str of TOML, found {type(text).__name__}")
    return Scene(parse_scene_text(text), folder)


def _scene_of(scene: Scene | str | os.PathLike | Mapping) -> Scene:
    if isinstance(scene, Scene):
        return scene
    if isinstance(scene, (str, os.PathLike)):
        return load_scene(scene)
    if isinstance(scene, Mapping):
        return scene_from_dict(scene)
    raise SceneError(
        f"run: expected a rftfem.Scene, a scene file or a dict, found {type(scene).__name__}"
    )


def default_out(scene: Scene) -> Path:
    """Where a run goes without ``out``: results/<scene file stem>, as the CLI."""
    return Path("results") / (scene.path.stem if scene.path is not None else "scene")


def run(
    scene: Scene | str | os.PathLike | Mapping,
    out: str | os.PathLike | None = None,
    quiet: bool = True,
    petsc: Iterable[str] | Mapping[str, Any] | None = None,
    restart: str | os.PathLike | None = None,
    comm: MPI.Comm | None = None,
) -> Result:
    """Run ``scene`` (a :class:`Scene`, a scene file or a dict) into the folder
    ``out`` and return its :class:`rftfem.Result`, as ``rftfem run`` would.

    ``quiet`` (default) prints nothing: the run's warnings are issued as
    :class:`rftfem.RunWarning` through :mod:`warnings` (and kept in the summary's
    ``warnings``); ``petsc`` takes PETSc options as on the
    command line (``["-ksp_type", "gmres"]``, or a dict without dashes);
    ``restart`` goes on from that folder's last checkpoint. A failed run raises
    :class:`RunFailed` (its ``folder`` holds the outputs written so far).  As on the
    command line, SIGINT and SIGTERM (Ctrl-C, a batch system's time limit) stop the
    run after its step, with its summary written ("interrupted") and every file
    closed, and raise :class:`RunInterrupted` (its ``folder`` too); a second signal
    stops it at once."""
    from rftfem.result import Result

    scene = _scene_of(scene)
    run_simulation = _simulation_run()
    if out is None:
        out = restart if restart is not None else default_out(scene)
    petsc = _petsc_options(petsc)
    try:
        run_simulation(
            scene.completed(),
            out_dir=Path(out),
            quiet=bool(quiet),
            petsc_args=list(petsc or []),
            comm=comm,
            signals=True,
            restart=None if restart is None else Path(restart),
            warn=_warn_at_caller if quiet else None,
        )
    except (RunFailed, RunInterrupted) as exc:
        exc.folder = Path(out)
        raise
    return Result(out)


def _simulation_run() -> Callable[..., Any]:
    """The simulation's ``run``, imported after pyvista where it can be, keeping the
    caller's ``warnings.showwarning``."""
    import sys

    if "dolfinx" not in sys.modules:
        # pyvista first, so that Result.fields and .render work in this process
        # afterwards (rftfem/outputs/compat_render.py); without pyvista, they draw elsewhere
        try:
            import rftfem.outputs.render  # noqa: F401  (pyvista with its plotting, VTK's rendering)
        except (ImportError, RuntimeError):
            pass
    shown = warnings.showwarning
    from rftfem.integration.simulation import run as run_simulation

    # the reference stack's ffcx, when first imported, sends every warning to logging,
    # past the caller's warnings.catch_warnings (pytest.warns): undo that
    warnings.showwarning = shown
    return run_simulation


def _petsc_options(
    petsc: Iterable[str] | Mapping[str, Any] | None,
) -> Iterable[str] | None:
    """``petsc`` as command-line options: a dict's keys with one dash, each followed by
    its value unless that is None or ""."""
    if isinstance(petsc, Mapping):
        args = []
        for k, v in petsc.items():
            args += [f"-{str(k).lstrip('-')}"] + ([] if v is None or v == "" else [str(v)])
        petsc = args
    return petsc


def _warn_at_caller(text: str) -> None:
    """A run's warning as a :class:`RunWarning`, issued at the line that called
    rftfem.run (the first frame outside rftfem)."""
    import sys

    frame, level = sys._getframe(1), 2
    while frame is not None and frame.f_globals.get("__name__", "").startswith("rftfem."):
        frame, level = frame.f_back, level + 1
    warnings.warn(text, RunWarning, stacklevel=level)
