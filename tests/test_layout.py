"""The package's layout (docs/development.md, "The packages"): which package may
import which at module level, no import cycles, and no module much over 400 lines.

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
    "integration": {"errors", "compat", "scene", "petsc_options", "forms", "meshes", "model",
                    "model.effects", "outputs"},
    "studies": {"errors", "compat", "scene", "petsc_options", "model", "model.effects",
                "integration", "outputs"},
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
MOST_LINES = 410


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
        if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module \
                and node.module.split(".")[0] == "rftfem":
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
            if theirs not in (mine, "__init__") and theirs not in ALLOWED[mine] and \
                    (module, dep) not in EXCEPTIONS:
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


def test_no_module_much_over_400_lines():
    long = {m: n for m, p in modules().items()
            if (n := len(p.read_text(encoding="utf-8").splitlines())) > MOST_LINES}
    assert not long, f"modules over {MOST_LINES} lines: {long}"


def test_the_layout_test_sees_the_whole_package():
    """The parts above cover every module, and the graph is not empty (a parser that
    found no imports would pass the tests above)."""
    assert {part(m) for m in GRAPH} - {"__init__"} <= set(ALLOWED)
    assert sum(len(d) for d in GRAPH.values()) > 150
    assert "rftfem.model.shell_model" in GRAPH["rftfem.integration.simulation"]
