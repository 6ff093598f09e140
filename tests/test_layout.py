"""The package's layout (docs/development.md, "The packages"): which package may
import which at module level, no import cycles, no module over 400 lines and no
function over 60 (as ruff formats them).

Imports inside functions are left out: they are how a module reaches a heavier
or higher one only when it needs it (dolfinx, pyvista, the simulation)."""

from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "rftfem"

#: what each part may import at module level, besides itself (docs/development.md)
ALLOWED = {
    "errors": set(),
    "compat": set(),
    "scene": {"errors", "compat"},
    "petsc_options": {"errors", "compat", "scene"},
    "outputs": {"errors", "compat", "scene"},
    "model": {"errors", "compat", "scene", "petsc_options", "forms", "model.effects"},
    "model.effects": {"errors", "compat", "scene", "petsc_options", "forms", "model"},
    "integration": {
        "errors",
        "compat",
        "scene",
        "petsc_options",
        "forms",
        "meshes",
        "model",
        "model.effects",
        "outputs",
    },
    "studies": {
        "errors",
        "compat",
        "scene",
        "petsc_options",
        "model",
        "model.effects",
        "integration",
        "outputs",
    },
    "api": {"errors", "scene"},
    "result": {"errors"},
    "cli": {"errors"},
    "reference": {"errors", "scene"},
    "__main__": {"cli"},
}
#: the exceptions: reading a scene gathers the keys every effect owns (the effects'
#: registry is the scene's schema: model/effects/__init__.py)
EXCEPTIONS = {
    ("rftfem.scene.keys", "rftfem.model.effects"),
    ("rftfem.scene.reading", "rftfem.model.effects"),
}
#: the longest module and the longest function (``def`` to its last line, nested
#: functions counted on their own), in rftfem/, forms/ and meshes/
MOST_LINES = 400
MOST_FUNCTION_LINES = 60
#: the Model class: it composes its parts rather than growing
MODEL_LINES = 300


def modules() -> dict[str, Path]:
    out = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = ("rftfem",) + path.relative_to(PACKAGE).with_suffix("").parts
        out[".".join(parts).removesuffix(".__init__")] = path
    return out


def module_level_imports(path: Path, known: dict) -> set[str]:
    """The rftfem modules ``path`` imports at module level (``from pkg import mod`` is
    an import of the module ``pkg.mod``, not of the package's __init__)."""
    out = set()
    for node in ast.parse(path.read_text(encoding="utf-8")).body:
        if (
            isinstance(node, ast.ImportFrom)
            and node.level == 0
            and node.module
            and node.module.split(".")[0] == "rftfem"
        ):
            subs = {f"{node.module}.{a.name}" for a in node.names}
            if subs <= set(known):
                out |= subs
            else:
                out.add(node.module)
        elif isinstance(node, ast.ImportFrom) and node.level:
            raise AssertionError(f"{path}: a relative import (rftfem imports absolutely)")
        elif isinstance(node, ast.Import):
            out |= {a.name for a in node.names if a.name.split(".")[0] == "rftfem"}
    return {m for m in out if m in known}


def part(module: str) -> str:
    """The part of the layout a module belongs to: a subpackage, or a top-level module."""
    parts = module.split(".")[1:]
    if not parts:
        return "__init__"
    if parts[0] == "model" and len(parts) > 1 and parts[1] == "effects":
        return "model.effects"
    return parts[0]


GRAPH = {m: module_level_imports(p, modules()) - {m} for m, p in modules().items()}


def test_every_part_imports_only_what_it_may():
    wrong = []
    for module, deps in GRAPH.items():
        mine = part(module)
        if mine == "__init__":
            assert not deps, "rftfem/__init__.py imports lazily (module __getattr__)"
            continue
        assert mine in ALLOWED, f"{module}: a part docs/development.md does not list"
        for dep in deps:
            theirs = part(dep)
            # the package's own __init__ (its __version__) imports nothing: anyone may
            if (
                theirs not in (mine, "__init__")
                and theirs not in ALLOWED[mine]
                and (module, dep) not in EXCEPTIONS
            ):
                wrong.append(f"{module} -> {dep}")
    assert not wrong, "imports against the layout:\n" + "\n".join(sorted(wrong))


def test_no_import_cycles():
    index, low, stack, on, cycles = {}, {}, [], set(), []

    def visit(v, counter=[0]):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in GRAPH[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                cycles.append(sorted(component))

    for v in GRAPH:
        if v not in index:
            visit(v)
    assert not cycles, f"import cycles: {cycles}"


def source_files() -> list[Path]:
    """Every module of rftfem/, forms/ and meshes/ (installed as rftfem.forms and
    rftfem.meshes)."""
    root = PACKAGE.parent
    return [p for d in ("rftfem", "forms", "meshes") for p in sorted((root / d).rglob("*.py"))]


def test_no_module_over_400_lines():
    """Broke: before the splits of this check's commit, it failed naming 26
    modules (the longest rftfem/studies/study.py, 472 lines)."""
    paths = source_files()
    assert len(paths) > 100
    long = {
        str(p.relative_to(PACKAGE.parent)): n
        for p in paths
        if (n := len(p.read_text(encoding="utf-8").splitlines())) > MOST_LINES
    }
    assert not long, f"modules over {MOST_LINES} lines: {long}"


def test_no_function_over_60_lines():
    """A function, method or nested function longer than the cap is split into
    named steps (docs/development.md, "The packages").

    Broke: before the splits of this check's commit, it failed naming 46
    functions (the longest ``optimize_field``, 155 lines)."""
    long = []
    for path in source_files():
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                if (n := node.end_lineno - node.lineno + 1) > MOST_FUNCTION_LINES:
                    where = path.relative_to(PACKAGE.parent)
                    long.append(f"{where}:{node.lineno} {node.name}: {n} lines")
    assert not long, f"{len(long)} functions over {MOST_FUNCTION_LINES} lines:\n" + "\n".join(long)


def test_the_layout_test_sees_the_whole_package():
    """The parts above cover every module, and the graph is not empty (a parser that
    found no imports would pass the tests above)."""
    assert {part(m) for m in GRAPH} - {"__init__"} <= set(ALLOWED)
    assert sum(len(d) for d in GRAPH.values()) > 150
    assert "rftfem.model.shell_model" in GRAPH["rftfem.integration.model_setup"]


# --- the demos, forms/ and meshes/ --------------------------------------------------
# forms/ and meshes/ are installed as rftfem.forms and rftfem.meshes (pyproject.toml's
# package-dir) but live beside rftfem/, so the graph above does not see them.

ROOT = PACKAGE.parent
#: the standard library's top-level modules (both stacks' Pythons have the list)
STDLIB = set(__import__("sys").stdlib_module_names)


def imports(path: Path, everywhere: bool = False) -> list[tuple[int, str]]:
    """(level, module) of each import of ``path``: at module level, or ``everywhere``
    (inside functions too); ``from m import a, b`` gives ``m.a`` and ``m.b``, a
    relative ``from . import x`` level 1 and ``x``."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    out = []
    for node in ast.walk(tree) if everywhere else tree.body:
        if isinstance(node, ast.Import):
            out += [(0, a.name) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            out += [(node.level, f"{base}.{a.name}".strip(".")) for a in node.names]
    return out


def public_names() -> set[str]:
    """The names ``import rftfem`` offers: rftfem/__init__.py's ``_PUBLIC`` and
    ``__version__`` (read, not imported: the current stack's import loads MPI)."""
    for node in ast.parse((PACKAGE / "__init__.py").read_text(encoding="utf-8")).body:
        if isinstance(node, ast.Assign) and [getattr(t, "id", None) for t in node.targets] == [
            "_PUBLIC"
        ]:
            return {"__version__", *ast.literal_eval(node.value)}
    raise AssertionError("rftfem/__init__.py: no _PUBLIC table of the public names")


def demo_api_uses(path: Path, public: set[str]) -> list[str]:
    """What ``path`` takes from rftfem that is not its public API: an import below
    the top level (``rftfem.integration.simulation``, also inside a function), a
    non-public name imported from it, or an attribute of the imported package
    (``rftfem.outputs``) that is not public."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    wrong, aliases = [], set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                if a.name == "rftfem":
                    aliases.add(a.asname or a.name)
                elif a.name.startswith("rftfem."):
                    wrong.append(f"line {node.lineno}: import {a.name}")
        elif (
            isinstance(node, ast.ImportFrom)
            and node.module
            and node.module.split(".")[0] == "rftfem"
        ):
            if node.module != "rftfem":
                wrong.append(f"line {node.lineno}: from {node.module} import ...")
            else:
                wrong += [
                    f"line {node.lineno}: from rftfem import {a.name}"
                    for a in node.names
                    if a.name not in public
                ]
    for node in ast.walk(tree):
        if (
            isinstance(node, ast.Attribute)
            and isinstance(node.value, ast.Name)
            and node.value.id in aliases
            and node.attr not in public
        ):
            wrong.append(f"line {node.lineno}: {node.value.id}.{node.attr}")
    return wrong


def test_demos_use_only_the_public_api():
    """A newcomer copies the demos: they reach rftfem through ``import rftfem`` and
    its public names (docs/python.md) only, never a module inside the package, not
    even inside a function.

    Broke: ``from rftfem.outputs.quantities import read_csv`` added inside
    demos/sheet_robot.py's ``swim`` → failed, naming it; the demos as they were
    before (issue 63) failed with 20 such imports in 9 demos."""
    public = public_names()
    assert {"run", "load_scene", "Result"} <= public
    demos = sorted((ROOT / "demos").glob("*.py"))
    wrong = [f"{p.relative_to(ROOT)} {w}" for p in demos for w in demo_api_uses(p, public)]
    assert not wrong, "demos reaching inside rftfem:\n" + "\n".join(wrong)
    # the check sees the demos that run scenes from Python
    users = [p.stem for p in demos if any(m == "rftfem" for _, m in imports(p, True))]
    assert {"three_link", "scallop", "sheet_robot", "magnetic_snap"} <= set(users)


def test_forms_import_only_ufl():
    """forms/ is UFL in, UFL out: its modules import ufl, the standard library (math)
    and each other (relative imports), anywhere, also inside functions; never
    dolfinx, basix, petsc4py, mpi4py or the rest of rftfem.

    Broke: ``import dolfinx`` inside a function added to forms/gravity.py → failed
    ("gravity.py: dolfinx")."""
    wrong, relative = [], 0
    for path in sorted((ROOT / "forms").glob("*.py")):
        for level, module in imports(path, everywhere=True):
            top = module.split(".")[0]
            if level == 1:  # from .kinematics import unit: another forms module
                relative += 1
            elif level or not (
                top in {"ufl", "numpy"} or top in STDLIB or module.startswith("rftfem.forms.")
            ):
                wrong.append(f"{path.name}: {'.' * level}{module}")
    assert not wrong, "forms/ imports beyond UFL:\n" + "\n".join(wrong)
    assert relative >= 4  # the parser sees forms' imports of each other


def test_meshes_import_only_gmsh_numpy_errors_and_compat():
    """meshes/ builds a Body below the model: at module level its modules import the
    standard library, numpy, gmsh, each other, ``rftfem.errors`` and ``rftfem.compat``
    (its one way to dolfinx), and no other part of rftfem, nor dolfinx, ufl or
    petsc4py themselves; mpi4py and scipy come inside functions.

    Broke: ``import ufl`` added at module level to meshes/three_link.py → failed
    ("three_link.py: ufl")."""
    wrong, seen = [], set()
    for path in sorted((ROOT / "meshes").glob("*.py")):
        for level, module in imports(path):
            top = module.split(".")[0]
            seen.add(module)
            if level == 1:  # from .strip import build_strip: another meshes module
                continue
            if level or not (
                top in {"numpy", "gmsh"}
                or top in STDLIB
                or module.startswith(("rftfem.errors.", "rftfem.compat.", "rftfem.meshes."))
            ):
                wrong.append(f"{path.name}: {'.' * level}{module}")
    assert not wrong, "meshes/ imports against the layout:\n" + "\n".join(wrong)
    assert {
        "rftfem.errors.SceneError",
        "rftfem.compat.gmsh_model_to_mesh",
        "gmsh_file.read_gmsh",
    } <= seen


# --- type hints ---------------------------------------------------------------------


def unannotated(path: Path) -> list[str]:
    """The public functions and methods of a module (names without a leading
    underscore, and ``__init__``/``__call__``, outside private classes) that lack an
    annotation of a parameter (``self``/``cls`` aside) or of the return (``__init__``
    aside).  Functions nested in functions are not its interface."""
    out = []

    def visit(node, owner: str | None, private: bool):
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.ClassDef):
                visit(child, child.name, private or child.name.startswith("_"))
            elif isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)):
                name = child.name
                if private or (name.startswith("_") and name not in ("__init__", "__call__")):
                    continue
                a = child.args
                params = a.posonlyargs + a.args + a.kwonlyargs
                if owner and params and params[0].arg in ("self", "cls"):
                    params = params[1:]
                params += [p for p in (a.vararg, a.kwarg) if p is not None]
                bare = [p.arg for p in params if p.annotation is None]
                if child.returns is None and name != "__init__":
                    bare.append("return")
                if bare:
                    where = f"{owner}.{name}" if owner else name
                    out.append(f"{path.relative_to(ROOT)}:{child.lineno} {where}: {bare}")

    visit(ast.parse(path.read_text(encoding="utf-8")), None, False)
    return out


def test_public_functions_are_annotated():
    """Every public function and method of rftfem/, forms/ and meshes/ has its
    parameters and return annotated (docs/development.md, "The packages").

    Broke: the return annotation of ``rftfem.forms.drag.drag_traction`` removed →
    failed, naming it."""
    paths = [p for d in ("rftfem", "forms", "meshes") for p in sorted((ROOT / d).rglob("*.py"))]
    assert len(paths) > 100
    bare = [line for p in paths for line in unannotated(p)]
    assert not bare, f"{len(bare)} public functions without annotations:\n" + "\n".join(bare)


def test_the_install_lists_every_package():
    """pyproject.toml's ``packages`` names every folder of rftfem/ that is a package
    (an editable install finds one left out; a wheel leaves it behind).

    Broke: "rftfem.compat" taken out of the list → failed, naming it."""
    import tomllib

    with open(ROOT / "pyproject.toml", "rb") as f:
        listed = set(tomllib.load(f)["tool"]["setuptools"]["packages"])
    found = {
        ".".join(("rftfem",) + p.parent.relative_to(PACKAGE).parts).rstrip(".")
        for p in PACKAGE.rglob("__init__.py")
    }
    assert found - listed == set(), f"packages pyproject.toml leaves out: {found - listed}"
    assert {"rftfem.forms", "rftfem.meshes"} <= listed


def test_the_model_class_stays_under_300_lines():
    """:class:`~rftfem.model.shell_model.Model` composes its parts (triads,
    directors, step state, measures) rather than growing: under 300 lines.

    Broke: the cap set to 290 → failed at 297 lines."""
    tree = ast.parse((PACKAGE / "model" / "shell_model.py").read_text(encoding="utf-8"))
    (model,) = [n for n in tree.body if isinstance(n, ast.ClassDef) and n.name == "Model"]
    assert model.end_lineno - model.lineno + 1 < MODEL_LINES
