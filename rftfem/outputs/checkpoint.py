"""Checkpoints of a run, and what a restart reads (docs/scenes.md, "Checkpoints and
restart").

``output.checkpoint_every = N`` writes, after every N-th step, everything a run
needs to go on as if it had never stopped: the iterate and the last state
(u, v, a), the nodal triads of every colour, the last two steps' increments
(the next step's prediction), the forces kept for the α-weighted residual, the
time, the step, the counts, the scheme's memory (BDF2's last step) and the
error control's next step.  Fields are kept as each process's own arrays, so a
restart needs the same number of processes on the same mesh (checked: every
rank stores a digest of its local mesh nodes).

A checkpoint is a folder ``checkpoint/step-NNNNNNNN`` holding ``rank-K.npz`` per
process and ``meta.json``.  It is written under a temporary name and renamed
once complete (``meta.json`` last, then the rename), so a run killed while
writing leaves a temporary folder that no restart reads; the latest two
complete checkpoints are kept.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from rftfem import __version__
from rftfem.errors import SceneError
from rftfem.outputs.writers import json_default

if TYPE_CHECKING:
    from typing import Any

    from mpi4py import MPI

FOLDER = "checkpoint"
KEEP = 2
#: 2: the unknowns are stored node by node, (u, θ¹, θ², ...) per node (rftfem/model/shell_model.py);
#: format 1 held u and θ as separate blocks of a mixed space
FORMAT = 2

#: scene keys a restart may change: they do not change the physics of the steps
#: already taken (time.end extends a run; the rest are how it is watched or solved)
MAY_DIFFER = (
    "title",
    "time.end",
    "time.max_steps",
    "time.max_cuts",
    "time.output_every",
    "output.checkpoint_every",
    "output.render",
)


def _name(step: int) -> str:
    return f"step-{step:08d}"


def mesh_digest(model: Any) -> str:
    """A digest of this process's mesh nodes, in their local order."""
    x = np.ascontiguousarray(model.mesh.geometry.x, dtype=np.float64)
    return hashlib.sha256(x.tobytes()).hexdigest()[:16]


def write(out_dir: Path, step: int, arrays: dict, meta: dict, comm: MPI.Comm) -> Path:
    """Write one checkpoint atomically; return its folder.  Collective."""
    root = Path(out_dir) / FOLDER
    final = root / _name(step)
    tmp = root / (_name(step) + ".tmp")
    if comm.rank == 0:
        if tmp.exists():
            shutil.rmtree(tmp)
        tmp.mkdir(parents=True)
    comm.Barrier()
    path = tmp / f"rank-{comm.rank}.npz"
    with open(path, "wb") as f:
        np.savez(f, **arrays)
        f.flush()
        os.fsync(f.fileno())
    digests = comm.gather(meta.pop("mesh_digest"), root=0)
    comm.Barrier()
    if comm.rank == 0:
        meta = dict(
            meta, format=FORMAT, rftfem=__version__, mpi_size=comm.size, mesh_digests=digests
        )
        with open(tmp / "meta.json", "w", encoding="utf-8") as f:
            json.dump(meta, f, indent=1, default=json_default)
            f.flush()
            os.fsync(f.fileno())
        if final.exists():
            shutil.rmtree(final)
        os.replace(tmp, final)
        _fsync_dir(root)
        for old in complete(root)[:-KEEP]:
            shutil.rmtree(old, ignore_errors=True)
    comm.Barrier()
    return final


def complete(root: Path) -> list[Path]:
    """The complete checkpoints under ``root``, oldest first."""
    if not root.is_dir():
        return []
    found = [
        p
        for p in root.iterdir()
        if p.is_dir()
        and p.name.startswith("step-")
        and not p.name.endswith(".tmp")
        and (p / "meta.json").is_file()
    ]
    return sorted(found, key=lambda p: p.name)


def latest(out_dir: Path, comm: MPI.Comm) -> tuple[Path, dict]:
    """The last complete checkpoint of a results folder and its meta (rank 0 reads,
    every rank gets it); a one-line SceneError if there is none or it does not fit."""
    where = Path(out_dir)
    found = None
    if comm.rank == 0:
        done = complete(where / FOLDER)
        if done:
            try:
                found = (str(done[-1]), json.loads((done[-1] / "meta.json").read_text()))
            except (OSError, ValueError) as exc:
                found = ("", f"{done[-1] / 'meta.json'} unreadable ({exc})")
    found = comm.bcast(found, root=0)
    if found is None:
        raise SceneError(
            f"--restart {where}: no complete checkpoint in {where / FOLDER} "
            "(output.checkpoint_every writes them)"
        )
    path, meta = found
    if not path:
        raise SceneError(f"--restart {where}: {meta}")
    if meta.get("format") != FORMAT:
        raise SceneError(
            f"--restart {where}: checkpoint format {meta.get('format')!r}, "
            f"this rftfem reads {FORMAT}"
        )
    if meta["mpi_size"] != comm.size:
        raise SceneError(
            f"--restart {where}: the checkpoint was written by {meta['mpi_size']} "
            f"process(es) and this run has {comm.size}; restart it with "
            f"mpirun -n {meta['mpi_size']}"
            if meta["mpi_size"] > 1
            else f"--restart {where}: the checkpoint was written by one process and "
            f"this run has {comm.size}; restart it without mpirun"
        )
    return Path(path), meta


def read_arrays(path: Path, comm: MPI.Comm, digest: str, meta: dict) -> dict:
    """This process's arrays of a checkpoint, after checking that its mesh is the
    one they were written on."""
    if meta["mesh_digests"][comm.rank] != digest:
        raise SceneError(
            f"--restart {path.parent.parent}: the mesh of process {comm.rank} "
            "differs from the checkpoint's (another mesh, or another partition)"
        )
    with np.load(path / f"rank-{comm.rank}.npz") as data:
        return {k: data[k].copy() for k in data.files}


def scene_difference(saved: dict, scene: dict) -> str | None:
    """The first scene key (dotted path) whose value differs between the checkpointed
    scene and this one, with both values; None if only keys of MAY_DIFFER differ."""
    for path, a, b in _differences(saved, scene, ""):
        if path not in MAY_DIFFER:
            return f"{path} (checkpoint: {_show(a)}, scene: {_show(b)})"
    return None


def _differences(a, b, path):
    if isinstance(a, dict) and isinstance(b, dict):
        for key in sorted(set(a) | set(b)):
            if key.startswith("_"):
                continue
            yield from _differences(a.get(key), b.get(key), f"{path}.{key}" if path else key)
    elif isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        for i, (x, y) in enumerate(zip(a, b)):
            yield from _differences(x, y, f"{path}.{i}")
    elif _plain_value(a) != _plain_value(b):
        yield path, a, b


def _plain_value(v):
    """A value as JSON gives it back (tuples as lists, numpy scalars as numbers)."""
    return json.loads(json.dumps(v, default=json_default))


def _show(v) -> str:
    return "absent" if v is None else json.dumps(v, default=json_default)


def _fsync_dir(path: Path):
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    finally:
        os.close(fd)
