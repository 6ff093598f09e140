"""One process that builds many models (an in-process sweep, an optimisation, this
test suite) frees the finished ones as it goes: each holds about 20 MPI
communicators, and MPICH gives a process 2048 (rftfem/integration/model_setup.py,
``_release_finished_models``)."""

from __future__ import annotations

import gc
import weakref

from conftest import CANTILEVER, free_communicators, write_scene
from mpi4py import MPI

from rftfem.integration import model_setup
from rftfem.scene.reading import load_scene

BUILDS = 40
#: communicators a model of the small cantilever may hold (about 20 measured)
PER_MODEL = 30


def test_finished_models_are_freed_while_the_collector_sleeps(tmp_path):
    """With Python's cyclic collector off (as good as off in a process with many
    objects, where full collections come rarely), 40 models built and dropped leave
    at most COLLECT_EVERY alive, and hold no more communicators than those (counted
    where the MPI library runs out: MPICH's 2048). Broke: the collection left out of
    build_model → all 40 alive."""
    scene = load_scene(write_scene(tmp_path, CANTILEVER))
    alive = []
    gc.collect()
    before = free_communicators()
    gc.disable()
    try:
        for _ in range(BUILDS):
            model = model_setup.build_model(scene, MPI.COMM_WORLD, compile_forms=False)
            alive.append(weakref.ref(model))
            del model
        left = sum(ref() is not None for ref in alive)
        held = before - free_communicators()
    finally:
        gc.enable()
    assert 0 < left <= model_setup.COLLECT_EVERY, left
    assert held <= (model_setup.COLLECT_EVERY + 1) * PER_MODEL, held
