"""Fuzzed input: valid scenes mutated at random must give exit status 0 or 2 from
``rftfem check`` (2 with one line naming a key), and 0, 2 or 3 from a short
``rftfem run`` — never a traceback, a hang or another status.

Mutations (hypothesis): any key of a shipped demo scene gets a value of another
type, an edge number (0, -1, ±1e308, 1e-308, nan, ±inf, 2^70), a string (unicode
included), an array of another length, a table, or is deleted; unknown keys are
added; arrays and tables grow huge; ``--set`` gets random paths and values.
Each example runs ``rftfem.cli.main`` in this process (the exit status it returns
and what it prints), so a Python exception escaping it fails the test with its
traceback.  About one valid mutant in eight is also run for two or three steps.

The default profile tries 150 scenes and runs only mutants whose forms are
compiled already (15 s with a warm JIT cache); the ``slow`` one, run by
``./dev.sh test-full``, tries 1500 and runs any.  What the fuzzer found is kept as fixtures
in tests/scenes_bad/.

Reproducible: hypothesis draws from FUZZ_SEED, a fresh seed each run unless the
environment sets RFTFEM_FUZZ_SEED; the seed is printed at the start of the module
and with a falsifying example, and ``RFTFEM_FUZZ_SEED=<seed> ./dev.sh test
tests/test_fuzz.py`` draws the same scenes again.  Each ``rftfem check`` and each
short run of a mutant has a wall-time limit (EXAMPLE_LIMIT, SIGALRM): past it the
test fails with ExampleTimedOut naming the demo, the ``--set`` arguments and the
scene file.
"""

from __future__ import annotations

import contextlib
import io
import json
import math
import os
import random
import re
import signal
import tomllib
from pathlib import Path

# installed by scripts/setup.sh on both stacks: missing, the test fails (no silent skip)
import hypothesis
import pytest
from conftest import DEMOS
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from rftfem import cli
from rftfem.scene import toml_writer
from rftfem.scene.keys import SCHEMA

#: hypothesis's seed: RFTFEM_FUZZ_SEED if set, else a fresh one for this run
FUZZ_SEED = int(os.environ.get("RFTFEM_FUZZ_SEED") or random.SystemRandom().randrange(2**32))
#: wall-time limit (s) of one `rftfem check` or short run of a mutant, form compilation
#: included (the slow profile's runs compile new forms; the default one's need not,
#: but compile with a cold JIT cache, and one such run outlasted 300 s on two cores
#: shared with other runs): a hang fails its example instead of the CI job
EXAMPLE_LIMIT = {"default": 900.0, "slow": 1800.0}


@pytest.fixture(scope="module", autouse=True)
def print_seed(request):
    """The seed of this run, printed past pytest's capture (on every run)."""
    line = (
        f"\ntest_fuzz: hypothesis seed {FUZZ_SEED}; RFTFEM_FUZZ_SEED={FUZZ_SEED} "
        "draws these scenes again"
    )
    capture = request.config.pluginmanager.getplugin("capturemanager")
    if capture is not None:
        with capture.global_and_fixture_disabled():
            print(line)
    else:
        print(line)


BASES = {p.stem: tomllib.loads(p.read_text(encoding="utf-8")) for p in sorted(DEMOS.glob("*.toml"))}
# every top key of the scene (read from the schema, so a new key is covered), plus the
# two sources an error may name instead
TOP_KEYS = (*SCHEMA.fields, "--set", "scene file")
EDGE_NUMBERS = [
    0,
    -1,
    0.0,
    -0.0,
    1e308,
    -1e308,
    1e-308,
    math.nan,
    math.inf,
    -math.inf,
    2**70,
    -(2**70),
    1,
    3,
    1e-12,
]

scalars = st.one_of(
    st.booleans(),
    st.integers(min_value=-(2**70), max_value=2**70),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from(EDGE_NUMBERS),
    st.text(alphabet=st.characters(blacklist_categories=("Cs",)), max_size=12),
)
values = st.one_of(
    scalars,
    st.lists(scalars, max_size=5),
    st.lists(st.floats(-10, 10), min_size=1, max_size=5),
    st.dictionaries(st.text(min_size=1, max_size=6), scalars, max_size=3),
)


# --- a scene back to TOML ------------------------------------------------------


def to_toml(table: dict) -> str:
    return toml_writer.document(table)


# --- mutations -----------------------------------------------------------------


def _paths(node, path=()):
    """Every (container, key) of a scene, tables and arrays included."""
    if isinstance(node, dict):
        for k, v in node.items():
            yield node, k, path + (k,)
            yield from _paths(v, path + (k,))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            yield node, i, path + (i,)
            yield from _paths(v, path + (i,))


def _table(scene: dict, key: str) -> dict:
    """``scene[key]`` as a table (an earlier mutation may have made it something else)."""
    if not isinstance(scene.get(key), dict):
        scene[key] = {}
    return scene[key]


@st.composite
def mutants(draw):
    name = draw(st.sampled_from(sorted(BASES)))
    scene = json.loads(json.dumps(BASES[name]))  # a deep copy
    sets = []
    for _ in range(draw(st.integers(1, 3))):
        places = list(_paths(scene))
        kind = draw(
            st.sampled_from(
                ["value", "value", "value", "delete", "unknown", "length", "huge", "set"]
            )
        )
        if kind == "set" or not places:
            known = [".".join(map(str, p)) for *_, p in places] or ["title"]
            path = draw(
                st.one_of(
                    st.integers(0, len(known) - 1).map(known.__getitem__), st.text(max_size=15)
                )
            )
            suffix = draw(st.sampled_from(["", ".x", ".0", ".99", "..", "."]))
            text = draw(st.one_of(st.builds(toml_writer.value, values), st.text(max_size=10)))
            sets.append(f"{path}{suffix}={text}")
            continue
        # an index, not sampled_from(places): hypothesis writes the repr of what it
        # samples from, and after a "huge" mutation that repr took gigabytes
        container, key, _ = places[draw(st.integers(0, len(places) - 1))]
        if kind == "value":
            container[key] = draw(values)
        elif kind == "delete":
            if isinstance(container, dict):
                del container[key]
            else:
                container.pop(key)
        elif kind == "unknown":
            target = container[key] if isinstance(container[key], dict) else container
            if isinstance(target, dict):
                target[draw(st.text(min_size=1, max_size=8))] = draw(values)
        elif kind == "length":
            if isinstance(container[key], list):
                n = draw(st.integers(0, 6))
                container[key] = (
                    (container[key] * 3)[:n]
                    if container[key]
                    else draw(st.lists(scalars, min_size=n, max_size=n))
                )
            else:
                container[key] = [container[key]] * draw(st.integers(0, 4))
        elif kind == "huge":
            what = draw(st.sampled_from(["array", "tables", "divisions", "string"]))
            if what == "array":
                container[key] = [0.5] * 5000
            elif what == "tables":
                probe = {"name": "p", "at": [0.0, 0.0, 0.0]}
                _table(scene, "output")["probes"] = [dict(probe, name=f"p{i}") for i in range(2000)]
            elif what == "divisions":
                _table(scene, "mesh")["divisions"] = draw(
                    st.sampled_from([[10**9, 4], [100000, 100000], [2**70, 1], [4000, 1]])
                )
            else:
                container[key] = "é" * 100000
    return name, scene, sets


class ExampleTimedOut(BaseException):
    """A mutant's `rftfem check` or short run outlasted its time limit.  Not an
    Exception: hypothesis lets it through at once instead of shrinking the example,
    each shrink step of which could take the whole limit again."""


def _main(args: list[str], what: str, limit: float) -> tuple[int, str]:
    """``rftfem.cli.main(args)`` here, its exit status and stderr; past ``limit``
    seconds of wall time (SIGALRM) ExampleTimedOut, saying ``what`` ran."""
    fired = []

    def expire(signum, frame):
        fired.append(signum)
        raise ExampleTimedOut(what)

    def timed_out():
        return ExampleTimedOut(f"`rftfem {args[0]}` did not end within {limit:g} s: {what}")

    err = io.StringIO()
    previous = signal.signal(signal.SIGALRM, expire)
    try:
        signal.setitimer(signal.ITIMER_REAL, limit)
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            status = cli.main(args)
    except BaseException:
        if fired:  # raised inside a PETSc callback, it may come out as another error
            raise timed_out() from None
        raise
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)
    if fired:  # caught on the way and turned into an exit status
        raise timed_out()
    return status, err.getvalue()


def check_mutant(
    tmp_path: Path,
    name: str,
    scene: dict,
    sets: list[str],
    run: bool,
    new_forms: bool = True,
    limit: float = EXAMPLE_LIMIT["default"],
):
    hypothesis.note(f"RFTFEM_FUZZ_SEED={FUZZ_SEED}")
    path = tmp_path / f"{name}.toml"
    path.write_text(to_toml(scene), encoding="utf-8")
    # a mutant that points at a file of the demo folder (a gmsh mesh, a profile) finds it
    for extra in [*DEMOS.glob("*.msh"), *DEMOS.glob("*.csv")]:
        (tmp_path / extra.name).write_bytes(extra.read_bytes())
    args = [arg for s in sets for arg in ("--set", s)]
    what = (
        f"a mutant of demos/{name}.toml, --set {sets}, written to {path} "
        f"(RFTFEM_FUZZ_SEED={FUZZ_SEED} draws it again)"
    )
    status, err = _main(["check", str(path), *args], what, limit)
    hypothesis.event(f"check: exit {status}")
    assert status in (0, 2), (status, err, sets)
    if status == 2:
        lines = err.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("rftfem: error: "), (err, sets)
        assert any(k in lines[0] for k in TOP_KEYS), (lines[0], sets)
        return
    if not run:
        return
    # a short run: two or three steps (the time keys as the mutant has them)
    end = _scene_end(path, args, None if new_forms else name)
    if end is None:
        return
    out = tmp_path / "out"
    status, err = _main(
        [
            "run",
            str(path),
            "--out",
            str(out),
            "--quiet",
            *args,
            "--set",
            f"time.end={end!r}",
            "--set",
            "output.fields=false",
        ],
        what,
        limit,
    )
    hypothesis.event(f"run: exit {status}")
    assert status in (0, 2, 3), (status, err, sets)
    if status in (2, 3):
        lines = err.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("rftfem: "), (err, sets)


def _form_key(scene: dict) -> tuple:
    """What decides which forms a run compiles (material numbers do not: they are
    cellwise Functions)."""
    from rftfem.scene.reading import active_effects

    shell = scene["shell"]
    # a number is a cellwise value; a formula or profile anywhere makes the key a DG2
    # field, and an orthotropic law other forms (rftfem/model/materials.py)
    fields = tuple(
        any(isinstance(p.get(k), (str, dict)) for p in [shell, *shell["parts"]])
        for k in ("E", "nu", "thickness", "density", "E1", "E2", "G12", "nu12", "G13", "G23")
    )
    fibre = tuple(isinstance(v, str) for v in shell.get("fibre") or [])
    # RFT drag with C1 = C2 takes the form without a material axis (forms/drag.py)
    drag = (scene.get("fluid") or {}).get("drag")
    axis_free = isinstance(drag, list) and len(drag) == 3 and drag[0] == drag[1]
    return (
        tuple(active_effects(scene)),
        axis_free,
        scene["mesh"].get("cell"),
        scene["time"]["scheme"],
        (scene.get("solver") or {}).get("tangent"),
        scene["mesh"].get("kind"),
        scene["mesh"].get("file"),
        shell["material"],
        fields,
        fibre,
    )


def _scene_end(path: Path, args: list[str], same_forms_as: str | None) -> float | None:
    """time.end for two or three steps of the mutant (None: too many unknowns for a
    quick run, a dt that makes the end not a number, or, with ``same_forms_as``, a
    mutant whose forms differ from that demo's, which would take a compilation)."""
    from rftfem.scene.reading import load_scene

    scene = load_scene(path, [a for a in args if a != "--set"])
    if same_forms_as is not None:
        base = load_scene(DEMOS / f"{same_forms_as}.toml")
        if _form_key(scene) != _form_key(base):
            return None
    divisions = scene["mesh"].get("divisions") or [1, 1]
    if math.prod(divisions) > 400:
        return None
    end = min(scene["time"]["end"], 2.5 * scene["time"]["dt"])
    return end if math.isfinite(end) and end > 0 else None


# the draws come from FUZZ_SEED (hypothesis.seed below), not from the test's name
# (derandomize) nor from a database of earlier failures
PROFILE = dict(
    deadline=None,
    database=None,
    derandomize=False,
    suppress_health_check=[
        HealthCheck.function_scoped_fixture,
        HealthCheck.too_slow,
        HealthCheck.data_too_large,
    ],
)


@hypothesis.seed(FUZZ_SEED)
@settings(max_examples=150, **PROFILE)
@given(mutant=mutants(), run=st.integers(0, 7))
def test_fuzzed_scenes(tmp_path, mutant, run):
    """The CI profile: short runs only of mutants whose forms the demos' own tests
    compile, so that the test stays within a minute."""
    name, scene, sets = mutant
    check_mutant(
        tmp_path, name, scene, sets, run == 0, new_forms=False, limit=EXAMPLE_LIMIT["default"]
    )


@pytest.mark.slow
@hypothesis.seed(FUZZ_SEED)
@settings(max_examples=1500, **PROFILE)
@given(mutant=mutants(), run=st.integers(0, 7))
def test_fuzzed_scenes_long(tmp_path, mutant, run):
    name, scene, sets = mutant
    check_mutant(tmp_path, name, scene, sets, run == 0, limit=EXAMPLE_LIMIT["slow"])


def test_round_trip_of_the_demos(tmp_path):
    """The TOML writer of this test gives back every demo scene unchanged (else the
    mutants would not be what the fuzzer thinks)."""
    for name, scene in BASES.items():
        assert tomllib.loads(to_toml(scene)) == scene, name
        assert re.search(r"\S", to_toml(scene))
