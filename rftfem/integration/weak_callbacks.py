"""PETSc callbacks that do not keep their owner alive.

A PETSc object keeps the Python callables it is given (a SNES its residual and
Jacobian, a KSP its monitor, a python matrix its context) in C, where Python's
garbage collector cannot see them.  A solver that holds its SNES and hands it its
own bound methods therefore makes a cycle the collector can never free: the solver,
its model, their meshes and PETSc objects stay alive with their MPI communicators
(about 25 a run).  MPICH gives a process 2048 communicators, so a process that
ran some 80 simulations without closing them aborted.

The callables made here reach their object through a weak reference: the object
is freed as soon as Python drops it, and its PETSc objects with it.
"""

from __future__ import annotations

import weakref
from collections.abc import Callable


def weak_method(method: Callable) -> Callable:
    """``method`` (a bound method) called through a weak reference to its object."""
    ref = weakref.WeakMethod(method)
    name = method.__qualname__

    def call(*args, **kwargs):
        bound = ref()
        if bound is None:
            raise ReferenceError(f"{name}: called by PETSc after its object was freed")
        return bound(*args, **kwargs)

    return call


class WeakContext:
    """A PETSc python-matrix (or -preconditioner) context that forwards to ``target``
    through a weak reference: ``Mat().createPython(sizes, WeakContext(self))``."""

    def __init__(self, target: object):
        self._target = weakref.ref(target)

    def __getattr__(self, name: str):
        target = self._target()
        if target is None:
            raise AttributeError(name)
        return getattr(target, name)
