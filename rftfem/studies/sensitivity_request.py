"""What rftfem/studies/sensitivity.py can differentiate: the keys (scalar scene parameters)
and the objectives of a gradient request, checked against a loaded scene before
any run (one-line SceneErrors naming what is supported)."""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import TYPE_CHECKING

from rftfem.errors import SceneError

if TYPE_CHECKING:
    from collections.abc import Callable, Sequence

    import ufl
    from petsc4py import PETSc

    from rftfem.studies.sensitivity import _Adjoint

#: the material keys and the Model's field each one sets (Model._init_materials)
MATERIAL_FIELDS = {"E": "E", "nu": "nu", "thickness": "t", "density": "rho"}
#: what can be differentiated, for the messages
KEYS_SUPPORTED = (
    "shell.E, shell.nu, shell.thickness, shell.density, the same of "
    "shell.parts.N, load.N.value.I (component I of a vector load), load.N.value "
    "(a pressure), magnetic.parts.N.magnetization or magnetic.field.strength"
)
OBJECTIVES_SUPPORTED = (
    "PROBE_ux@end, PROBE_uy@end, PROBE_uz@end (PROBE one of "
    "output.probes), centroid_x@end, centroid_y@end, centroid_z@end or "
    "elastic_energy@end"
)
BODY_OBJECTIVES = ("centroid_x", "centroid_y", "centroid_z", "elastic_energy")
#: the two values a material key is set to, to find the cells it decides: exact in
#: binary, admissible for every material key (ν < 1/2)
PROBE_VALUES = (0.25, 0.125)


# --- the request: keys and objective ------------------------------------------------


@dataclass(frozen=True)
class Key:
    """A differentiable scene value: ``kind`` is "material", "load", "strength" or
    "magnetization"; ``index`` the part or load, ``name`` the material key,
    ``component`` the component of a vector load (None: a scalar)."""

    text: str
    kind: str
    index: int | None = None
    name: str = ""
    component: int | None = None


def parse_key(text: str) -> Key:
    """A gradient key's syntax (the scene decides the rest, ``check_request``)."""
    m = re.fullmatch(r"shell\.(?:parts\.(\d+)\.)?(E|nu|thickness|density)", text)
    if m:
        return Key(text, "material", None if m[1] is None else int(m[1]), m[2])
    m = re.fullmatch(r"load\.(\d+)\.value(?:\.([012]))?", text)
    if m:
        return Key(text, "load", int(m[1]), "value", None if m[2] is None else int(m[2]))
    m = re.fullmatch(r"magnetic\.parts\.(\d+)\.magnetization", text)
    if m:
        return Key(text, "magnetization", int(m[1]), "magnetization")
    if text == "magnetic.field.strength":
        return Key(text, "strength", name="strength")
    raise SceneError(f"gradient key '{text}': expected one of {KEYS_SUPPORTED}")


def _entries(scene: dict, path: str) -> list:
    node = scene
    for part in path.split("."):
        node = (node or {}).get(part) or []
    return node


def _check_key(scene: dict, key: Key) -> None:
    """The key against the scene: the entry exists and its value is differentiable."""

    def fail(why: str):
        raise SceneError(f"gradient key '{key.text}': {why}")

    if key.kind in ("material", "load", "magnetization") and key.index is not None:
        table = {"material": "shell.parts", "load": "load", "magnetization": "magnetic.parts"}[
            key.kind
        ]
        n = len(_entries(scene, table))
        if key.index >= n:
            fail(
                f"index {key.index} out of range, the scene has {n} [[{table}]] "
                f"entr{'y' if n == 1 else 'ies'}"
            )
    if key.kind == "material":
        holder = scene["shell"] if key.index is None else scene["shell"]["parts"][key.index]
        if isinstance(holder.get(key.name), (str, dict)):
            fail(
                "the value is a field (a formula or profile); its gradient is one value "
                "per cell or profile point (rftfem optimize --vary-field)"
            )
        if key.name in ("E", "nu") and scene["shell"]["material"] == "orthotropic":
            fail("the shell is orthotropic; E and nu are not used")
    if key.kind == "load":
        load = scene["load"][key.index]
        vector = isinstance(load.get("value"), list)
        if "value" not in load:
            fail(f"a load of kind '{load['kind']}' has no value")
        if vector and key.component is None:
            fail(
                f"the value of a '{load['kind']}' load is a vector; give its component "
                f"(load.{key.index}.value.0, .1 or .2)"
            )
        if not vector and key.component is not None:
            fail(
                f"the value of a '{load['kind']}' load is a number; the key is "
                f"load.{key.index}.value"
            )
    if key.kind in ("magnetization", "strength") and not scene.get("magnetic"):
        fail("the scene has no [magnetic]")
    if key.kind == "magnetization":
        part = scene["magnetic"]["parts"][key.index]
        if not isinstance(part["magnetization"], (int, float)):
            fail("only a part magnetized by a plain number (no formula, no profile) is supported")
        if part["magnetization"] <= 0 or any(isinstance(v, str) for v in part["direction"]):
            fail(
                "the magnetization must be a number > 0 (a part at 0 is left out of the "
                "forms) with a direction of numbers"
            )
    if key.kind == "strength" and scene["magnetic"]["field"]["kind"] != "rotating":
        fail('the strength is a value of the field of kind "rotating" only')


@dataclass(frozen=True)
class Objective:
    """``column@end``: a probe's displacement component or a body integral."""

    text: str
    column: str
    probe: int | None = None  # the probe's index in output.probes
    component: int | None = None


def check_request(scene: dict, keys: list[str], objective: str) -> tuple[list[Key], Objective]:
    """The parsed keys and objective, checked against ``scene``; a SceneError of one
    sentence for anything that cannot be differentiated."""
    from rftfem.outputs.quantities import parse

    if scene["time"]["scheme"] != "static":
        raise SceneError(
            f"gradients: time.scheme resolves to '{scene['time']['scheme']}'; "
            'adjoint sensitivities are for static runs (time.scheme = "static") '
            "only (docs/model.md §7.6)"
        )
    if scene.get("contact"):
        raise SceneError(
            "gradients: the scene has [[contact]], whose friction depends on the "
            "path of the load steps; adjoint sensitivities are for scenes "
            "without contact (use finite differences: rftfem study)"
        )
    parsed = [parse_key(k) for k in keys]
    for key in parsed:
        _check_key(scene, key)
    bad = SceneError(f"objective '{objective}': expected one of {OBJECTIVES_SUPPORTED}")
    try:
        q = parse(objective)
    except SceneError:
        raise bad from None
    if q.func != "at" or q.a != "end":
        raise bad
    if q.column in BODY_OBJECTIVES:
        return parsed, Objective(objective, q.column)
    names = [p["name"] for p in scene["output"]["probes"]]
    m = re.fullmatch(r"(.+)_u([xyz])", q.column)
    if m is None or m[1] not in names:
        raise SceneError(
            f"objective '{objective}': expected one of {OBJECTIVES_SUPPORTED}"
            f" (probes: {', '.join(names) or 'none'})"
        )
    return parsed, Objective(objective, q.column, names.index(m[1]), "xyz".index(m[2]))


def supports(keys: list[str], objective: str, scene: dict | None = None) -> bool:
    """Whether ``run_with_gradient`` can differentiate ``objective`` by ``keys``: their
    syntax alone, or with a loaded ``scene`` everything ``check_request`` checks."""
    try:
        if scene is not None:
            check_request(scene, list(keys), objective)
            return True
        for key in keys:
            parse_key(key)
        from rftfem.outputs.quantities import parse

        q = parse(objective)
    except SceneError:
        return False
    return (
        q.func == "at"
        and q.a == "end"
        and (q.column in BODY_OBJECTIVES or re.fullmatch(r".+_u[xyz]", q.column) is not None)
    )


def combined_objective(
    adj: _Adjoint,
    objectives: Sequence[Objective],
    combine: Callable[[list[float]], tuple[float, Sequence[float]]],
) -> tuple[float, PETSc.Vec, ufl.Form | None]:
    """``(J, ∂J/∂w, J's form or None)`` of ``J = f(J₁, J₂, ...)`` at the iterate, each
    ``J_i`` by the adjoint ``adj`` (rftfem.studies.sensitivity)."""
    parts = [adj.objective(o) for o in objectives]
    J, weights = combine([p[0] for p in parts])
    dJdw = parts[0][1]
    dJdw.scale(weights[0])
    for (_, g, _), w in zip(parts[1:], weights[1:]):
        dJdw.axpy(w, g)
        g.destroy()
    forms = [w * form for (_, _, form), w in zip(parts, weights) if form is not None]
    return J, dJdw, (sum(forms[1:], forms[0]) if forms else None)
