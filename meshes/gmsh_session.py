"""The gmsh plumbing every builder shares: a rank-0 gmsh session that leaves someone
else's gmsh as it found it, and the collective step that turns the rank-0 gmsh model
of a :class:`Recipe` into a distributed dolfinx mesh, a :class:`~rftfem.meshes.Body`.
"""

from __future__ import annotations

import math
import os
import sys
from contextlib import contextmanager, nullcontext
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from rftfem.compat import create_meshtags, gmsh_model_to_mesh
from rftfem.errors import SceneError

if TYPE_CHECKING:
    from collections.abc import Callable

    from mpi4py import MPI

    from . import Body

# --- gmsh session (rank 0) ---------------------------------------------------


def _import_gmsh():
    # TODO(compat): importing gmsh 4.8 sets SIGINT to SIG_DFL (Ctrl-C would kill
    # the run without cleanup or outputs); put Python's handler back.
    import signal
    import threading

    main = threading.current_thread() is threading.main_thread()
    handler = signal.getsignal(signal.SIGINT) if main else None
    import gmsh

    if main and handler is not None and signal.getsignal(signal.SIGINT) is not handler:
        signal.signal(signal.SIGINT, handler)
    return gmsh


def _gmsh_is_initialized(gmsh) -> bool | None:
    """Whether gmsh is initialized, or None where that cannot be asked safely."""
    # TODO(compat): gmsh >= 4.9 has isInitialized(); gmsh 4.8 (Debian 12) does
    # not, and any call into an uninitialized gmsh 4.8 may exit the process with
    # status 1 (its error handler reads options that only initialize() sets): it
    # did, in about one launch of two in some sequences, with nothing printed.
    if hasattr(gmsh, "isInitialized"):
        return bool(gmsh.isInitialized())
    return None


@contextmanager
def _stderr_silenced():
    """File descriptor 2 to /dev/null for the block (messages printed by C++)."""
    sys.stderr.flush()
    saved = os.dup(2)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 2)
            yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)


def _gmsh_initialize(gmsh) -> None:
    # TODO(compat): gmsh >= 4.11 takes interruptible= (True replaces Python's
    # SIGINT handler, so Ctrl-C would kill the run without cleanup); 4.8 does not.
    import inspect

    kwargs = {"readConfigFiles": False}
    if "interruptible" in inspect.signature(gmsh.initialize).parameters:
        kwargs["interruptible"] = False
    gmsh.initialize(**kwargs)


class _GmshSession:
    """A fresh, current gmsh model for the ``with`` block; everything restored after.

    Initializes gmsh only if nobody has (and then finalizes it on exit);
    otherwise leaves it initialized, removes only its own model, restores the
    previously current model and every option it set (``options``, plus a
    silent terminal).  With gmsh 4.8, which cannot be asked whether it is
    initialized, initialize() is called every time (a no-op when it is) and gmsh
    is left initialized.
    """

    _count = 0

    def __init__(self, options: dict[str, float] | None = None):
        self.options = {"General.Terminal": 0.0, **(options or {})}

    def __enter__(self):
        gmsh = _import_gmsh()
        self.gmsh = gmsh
        known = _gmsh_is_initialized(gmsh)
        if known is None:
            # gmsh 4.8: initialize() on an initialized gmsh changes nothing but a warning
            # on stderr ("already initialized", silenced), so it is called every time
            # and gmsh is never finalized here (whoever else initialized it keeps their
            # models; whoever finalized it gets it back)
            self.started = False
            with _stderr_silenced():
                _gmsh_initialize(gmsh)
        else:
            self.started = not known
            if self.started:
                _gmsh_initialize(gmsh)
        self.saved = {k: gmsh.option.getNumber(k) for k in self.options}
        for k, v in self.options.items():
            gmsh.option.setNumber(k, v)
        self.previous = gmsh.model.getCurrent()
        _GmshSession._count += 1
        self.name = f"rftfem-{os.getpid()}-{_GmshSession._count}"
        gmsh.model.add(self.name)
        return gmsh

    def __exit__(self, *exc):
        gmsh = self.gmsh
        try:
            if self.name in gmsh.model.list():
                gmsh.model.setCurrent(self.name)
                gmsh.model.remove()
        finally:
            if self.started:
                gmsh.finalize()
            else:
                for k, v in self.saved.items():
                    gmsh.option.setNumber(k, v)
                if self.previous in gmsh.model.list():
                    gmsh.model.setCurrent(self.previous)
        return False


def _model_to_body(comm, prepare, options=None):
    """Collective: ``prepare(gmsh)`` on rank 0, then the dolfinx mesh on all ranks.

    ``prepare`` fills the current (fresh) gmsh model and returns a tuple of
    names (``(regions, edges)``, a file's also its points); a :class:`SceneError`
    it raises is raised on every rank (no rank is left waiting). Returns
    ``(mesh, cell_tags, facet_tags, *names)``.
    """
    root = comm.rank == 0
    with _GmshSession(options) if root else nullcontext() as gmsh:
        result = None
        if root:
            try:
                result = ("ok", prepare(gmsh))
            except SceneError as e:
                result = ("scene", str(e))
            except Exception as e:  # a bug or a gmsh failure: still tell every rank
                result = ("error", f"{type(e).__name__}: {e}")
        status, payload = comm.bcast(result, root=0)
        if status == "scene":
            raise SceneError(payload)
        if status == "error":
            raise RuntimeError(f"building the mesh with gmsh failed: {payload}")
        mesh, cell_tags, facet_tags = gmsh_model_to_mesh(gmsh.model if root else None, comm, 0, 3)
    if facet_tags is None:  # dolfinx >= 0.10 gives None when no curve is tagged
        facet_tags = _empty_meshtags(mesh, mesh.topology.dim - 1)
    return (mesh, cell_tags, facet_tags, *payload)


def _empty_meshtags(mesh, dim):
    # TODO(compat): compat.gmsh_model_to_mesh could return these itself.
    mesh.topology.create_entities(dim)
    empty = np.empty(0, dtype=np.int32)
    return create_meshtags(mesh, dim, empty, empty)


# --- recipes ------------------------------------------------------------------


def _extents(comm, mesh) -> tuple[float, float]:
    from mpi4py import MPI

    x = mesh.geometry.x
    out = []
    for k in (0, 1):
        lo = float(x[:, k].min()) if x.shape[0] else math.inf
        hi = float(x[:, k].max()) if x.shape[0] else -math.inf
        out.append(comm.allreduce(hi, op=MPI.MAX) - comm.allreduce(lo, op=MPI.MIN))
    return out[0], out[1]


@dataclass
class Recipe:
    """How to make a body in gmsh, before any dolfinx mesh: ``prepare(gmsh)`` fills
    the current model on rank 0 and returns ``(regions, edges, points, report)``
    (names → physical tags; named points' coordinates; a gmsh file's
    :class:`~.surface_checks.SurfaceReport` or None) under the gmsh ``options``.
    ``extents``: the reference body's (length, width) if known (else measured);
    ``hinges``: its built-in hinge lines' names.  :func:`realize` makes the Body;
    :mod:`.bodies` puts several recipes into one mesh."""

    prepare: Callable[[Any], tuple]
    options: dict[str, float] | None = None
    extents: tuple[float, float] | None = None
    hinges: list[str] = field(default_factory=list)


def realize(comm: MPI.Comm, recipe: Recipe) -> Body:
    """Collective: the Body of ``recipe`` (gmsh on rank 0, dolfinx on every rank)."""
    from . import Body

    mesh, cell_tags, facet_tags, regions, edges, points, report = _model_to_body(
        comm, recipe.prepare, recipe.options
    )
    length, width = recipe.extents or _extents(comm, mesh)
    return Body(
        mesh=mesh,
        cell_tags=cell_tags,
        facet_tags=facet_tags,
        regions=regions,
        edges=edges,
        points=points,
        length=length,
        width=width,
        hinges=list(recipe.hinges),
        report=report,
    )
