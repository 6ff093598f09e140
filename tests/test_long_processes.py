"""One process that builds many models (an in-process sweep, an optimisation, this
test suite) frees the finished ones as it goes: each holds about 20 MPI
communicators, and MPICH gives a process 2048 (rftfem/integration/model_setup.py,
``_release_finished_models``)."""

from __future__ import annotations

import gc
import weakref

import pytest
from conftest import CANTILEVER, free_communicators, write_scene
from mpi4py import MPI
from test_stokes import STRIP

from rftfem.integration import model_setup
from rftfem.integration.simulation import Simulation
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


@pytest.mark.parametrize("liquid", ["none", "stokes"])
def test_a_finished_simulation_dropped_unclosed_is_freed(tmp_path, liquid):
    """A Simulation run and dropped without ``close()`` (a script of the Python API,
    a test) is freed by the collector with its PETSc objects and all their
    communicators: the SNES keeps its callbacks in C, where the collector cannot see
    them, so they hold the solver only weakly (weak_callbacks.py); with Stokes flow
    also the coupled tangent's python matrix and the Krylov monitor.  (petsc4py 3.18
    lets the collector see them; 3.25 does not, and the current stack's suite ran out
    of MPICH's 2048 communicators.)  Broke, on the current stack: the residual given
    to SNES as the bound method itself → solver and model stay; the python matrix's
    context made ``self`` → the model stays."""
    if liquid == "none":
        text = CANTILEVER
    else:
        text = STRIP.format(fluid='model = "stokes"\nviscosity = 1.0')
    scene = load_scene(write_scene(tmp_path, text))
    gc.collect()
    before = free_communicators()
    sim = Simulation(scene, out_dir=None, quiet=True)
    assert (sim.solver.coupled is not None) == (liquid == "stokes")
    sim.run()
    refs = [weakref.ref(sim), weakref.ref(sim.solver), weakref.ref(sim.model)]
    del sim
    gc.collect()
    assert [ref() is None for ref in refs] == [True] * 3
    assert before - free_communicators() == 0
