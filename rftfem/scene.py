"""Scenes: read a TOML scene, apply ``--set`` overrides, validate, fill defaults.

The keys are the user-facing contract documented in docs/scenes.md, whose "Scene
keys" part is generated from :data:`SCHEMA` (``python -m rftfem.scene_reference``).
This module owns the file-level rules: reading the file, ``--set``, the tables
``title``, ``[shell]``, ``[time]``, ``[output]`` and ``[solver]`` with their cross
checks (``[mesh]`` lives in :mod:`rftfem.scene_mesh`). Every effect component
(:mod:`rftfem.effects`) brings its own keys (``[fluid]``, ``[magnetic]``,
``[[hinge]]``, ``[[boundary]]``, ``[[motion]]``, and its ``[[load]]`` kinds) and
checks them. :func:`load_scene` returns a plain nested ``dict``
(JSON-serialisable, so it can be echoed in summary.json) in which every key of
the schema is present:

- scalars and arrays get their documented default;
- optional arrays of tables (``boundary``, ``load``, ``motion``, ``hinge``,
  ``mesh.regions``, ``shell.parts``, ``output.probes``) default to ``[]``;
- the optional effect tables ``fluid`` and ``magnetic`` are ``None`` when the
  scene does not have them (``if scene["fluid"]:`` switches the effect);
- keys that only apply to another variant are ``None`` (``mesh.file`` unless
  ``kind = "gmsh"``, ``mesh.link_width`` and ``mesh.hinge_stiffness`` unless
  ``kind = "three-link"``, ``load.N.table`` unless ``ramp = "table"``,
  ``motion.N.values`` unless ``kind = "table"``); a ``[[load]]`` entry has the
  keys of its kind only;
- ``mesh.width`` is the body's width: 1.0 by default, ``3 * link_width`` for
  ``kind = "three-link"``;
- a ``shell.parts`` entry inherits every material value it does not set
  (E, nu, thickness, density) from ``[shell]``;
- ``time.scheme`` holds the resolved scheme (never ``"auto"``);
- ``mesh.file`` is an absolute path; ``scene["_path"]`` is the absolute path of
  the scene file.

Every problem raises :class:`rftfem.errors.SceneError` with a one-line message
that names the full key path (``load.0.value``), what was expected and what was
found. Checks that need the mesh (gmsh physical-group names, a ``where`` that
matches no dof) are left to the model and its components. Scenes are data:
nothing in them is evaluated.
"""

from __future__ import annotations

import os
import re
import tomllib
from pathlib import Path
from typing import Any, Iterable

from rftfem import effects, steady
from rftfem.errors import SceneError
from rftfem.schema import (FACTORIZATIONS, MATRIX_TYPES, MAX_STEPS, NONNEGATIVE, POSITIVE,
                           TANGENTS, Array, Bool, Free, Int, Leaf, Num, Parameters, Str, Table, Vec,
                           check_factorization, check_matrix_type, check_tangent, check_unique,
                           err, fmt, join, section, suggest, validate_table)
from rftfem.scene_mesh import MESH, check_mesh
from rftfem.selectors import check_on_body, check_region_ref, hinge_line
from rftfem.timeint import resolved_scheme
from rftfem.validators import scene_parameters

__all__ = ["load_scene", "apply_override", "set_key", "read_scene_file",
           "parse_scene_text", "complete_scene", "with_overrides", "active_effects", "resolved_scheme", "hinge_line",
           "SCHEMA"]

_BARE_WORD_RE = re.compile(r"""^[A-Za-z_./~][^\s"'\[\]{},#]*$""")

_PART_MATERIAL = ("E", "nu", "thickness", "density")

_INHERITED = "inherited from [shell]"

SCHEMA = Table({
    "title": Leaf(Str(), required=True,
                   doc="A free-text name of the scene; `rftfem check` and the first log line "
                       "of a run show it."),
    "mesh": MESH,
    "shell": Table({
        "thickness": Leaf(POSITIVE, 0.1, unit="length", doc="Shell thickness."),
        "E": Leaf(POSITIVE, 1.2e6, unit="force/length²", doc="Young's modulus."),
        "nu": Leaf(Num(-1.0, 0.5, lo_open=True, hi_open=True), 0.0,
                    doc="Poisson's ratio."),
        "density": Leaf(NONNEGATIVE, 0.0, unit="mass/length³",
                         doc="Mass per volume, with mass in force·time²/length (t/mm³ for "
                             "N, mm, s). Above 0 (here or in a part) the body has inertia "
                             "and the automatic scheme is generalized-alpha."),
        "axis": Leaf(Vec(nonzero=True), [1.0, 0.0, 0.0],
                      doc="The material axis E1* in reference coordinates (normalised, not "
                          "along the normal). The drag frame follows it: C1 acts along the "
                          "axis as the body carries it, C2 across it in the surface."),
        "parts": Array(Table({
            "region": Leaf(Str(name=True), required=True,
                            doc="The region (of `[[mesh.regions]]`, a built-in three-link "
                                "region or a gmsh physical surface); one part per region."),
            "E": Leaf(POSITIVE, unit="force/length²", default_doc=_INHERITED,
                       doc="Young's modulus on the region."),
            "nu": Leaf(Num(-1.0, 0.5, lo_open=True, hi_open=True), default_doc=_INHERITED,
                        doc="Poisson's ratio on the region."),
            "thickness": Leaf(POSITIVE, unit="length", default_doc=_INHERITED,
                               doc="Thickness on the region."),
            "density": Leaf(NONNEGATIVE, unit="mass/length³", default_doc=_INHERITED,
                             doc="Density on the region."),
        }), doc="Material values that differ on a region; a part takes what it leaves out "
                "from [shell]."),
    }, required=True,
        doc="The material (isotropic, plane stress) and thickness of the shell."),
    "time": Table({
        "end": Leaf(POSITIVE, 1.0, unit="time",
                     doc='The time the run stops at; linear load ramps reach their full value '
                         'there. With scheme = "static" time is only a load parameter.'),
        "dt": Leaf(POSITIVE, 0.01, unit="time",
                    doc="The nominal step, at most `end`: the run makes ceil(end / dt) steps, "
                        "the last one ending at `end`. A step that fails is halved and "
                        "retried, then grown back. With arc-length: the first step's "
                        "increment of the load factor."),
        "scheme": Leaf(Str(("auto", "generalized-alpha", "hht", "backward-euler", "bdf2",
                            "static", "arc-length")),
                        "auto",
                        doc='The time integrator. "generalized-alpha" and "hht" are second '
                            'order and need density; "backward-euler" (first order) and '
                            '"bdf2" (second order, variable steps) are for drag without '
                            'inertia; "static" steps the loads with no velocity '
                            '(refused with [fluid]); "arc-length" follows the static '
                            "equilibrium path with the load factor as an unknown, through "
                            "limit points and snap-backs (refused with [fluid]; time is then "
                            'the load factor λ). "auto" takes generalized-alpha with '
                            "density, backward-euler with [fluid] alone, static otherwise."),
        "start": Leaf(Str(("rest", "equilibrium")), "rest",
                       doc='How a run in time starts. "rest": in its initial state, at '
                           "rest: the reference, or the shape the t = 0 motions impose "
                           "with the rest of the body in elastic equilibrium; loads on at "
                           "t = 0 act from the first step on (a free plate in drag under a "
                           'constant force F has u(t) = F t / (C A) at every row). '
                           '"equilibrium": at rest in static equilibrium with the t = 0 '
                           "loads as well, to release a pre-loaded body (a load table that "
                           "drops to 0 after t = 0). Static runs always start in "
                           "equilibrium with their t = 0 loads."),
        "rho_inf": Leaf(Num(0.0, 1.0), 0.9,
                         doc="Generalized-alpha's spectral radius at infinite frequency: 1 "
                             "damps nothing, smaller values damp the highest frequencies "
                             "more. Used by generalized-alpha only."),
        "alpha": Leaf(Num(-1.0 / 3.0, 0.0), -0.05,
                       doc="The α of the HHT scheme; 0 is the trapezoidal rule, more "
                           "negative values damp high frequencies. Used by hht only."),
        "output_every": Leaf(Int(1), 1,
                              doc="Write a row of probes.csv and body.csv, and the fields, "
                                  "every this many nominal steps (and after the last one)."),
        "until": Leaf(Str(("end", "periodic")), "end",
                       doc='When the run stops: "end" at time.end; "periodic" once the '
                           "period means of every probes.csv and body.csv column (the drift "
                           "over a period for positions) have settled, extrapolated from "
                           "successive periods (Aitken), to steady_tolerance; time.end is then "
                           "the latest it may stop. summary.json's `steady` holds the values."),
        "period": Leaf(POSITIVE, None, unit="time",
                        default_doc="from the travelling-wave motions or the rotating field",
                        doc='The period of time.until = "periodic"; dt must divide it.'),
        "steady_tolerance": Leaf(POSITIVE, 1e-3,
                                  doc='time.until = "periodic": how closely two successive '
                                      "periods' extrapolated steady values must agree, "
                                      "relative to each column's value (or its swing over "
                                      "a period, if larger)."),
        "max_steps": Leaf(Int(1), 1000,
                           doc='With scheme = "arc-length": the run stops after this many '
                               "steps if the load factor has not reached `end` by then."),
        "max_cuts": Leaf(Int(0), 8,
                          doc="How many times one nominal step may be halved before the "
                              "run fails (exit status 3); a failed attempt may halve it "
                              "several times at once."),
        "tolerance": Leaf(POSITIVE, None, default_doc="none: fixed steps of `dt`",
                           doc="Error-controlled steps: the largest local error a step may "
                               "make, relative to the body's size for displacements (and in "
                               "radians for rotations), estimated from the step's distance "
                               "to its prediction. `dt` is then the first step, steps grow "
                               "and shrink within [`dt_min`, `dt_max`], and outputs still "
                               "fall every `output_every` × `dt`. Not with static."),
        "dt_min": Leaf(POSITIVE, None, unit="time",
                        default_doc="dt × 1e-6 (with `tolerance` only)",
                        doc="The smallest step the error control may take; a step that "
                            "needs a smaller one fails the run (exit status 3)."),
        "dt_max": Leaf(POSITIVE, None, unit="time",
                        default_doc="end (with `tolerance` only)",
                        doc="The largest step the error control may take."),
        "max_rotation": Leaf(POSITIVE, 0.2, unit="rad",
                              doc="The most any director may turn within one converged step "
                                  "of a scheme with velocity (not static); a step that turns "
                                  "one further is halved, as it would skip fast motion."),
    }, required=True, doc="Time span, step and integration scheme."),
    "output": Table({
        "probes": Array(Table({
            "name": Leaf(Str(name=True), required=True,
                          doc="The probe's columns in probes.csv are NAME_ux, NAME_uy, "
                              "NAME_uz; unique."),
            "at": Leaf(Vec(), required=True, unit="length",
                        doc="The material point, in reference coordinates; on a strip or "
                            "three-link body it must lie on the body (z = 0)."),
        }), doc="Material points whose displacement goes to probes.csv."),
        "fields": Leaf(Bool(), True,
                        doc="Write fields.xdmf and fields.h5 (displacement, director, "
                            "magnetization) for ParaView."),
        "render": Leaf(Str(("none", "png", "mp4", "gif")), "none",
                        doc="When the run ends (also when it fails), draw render.png, "
                            "render.mp4 or render.gif in the output folder with `rftfem "
                            'render` and its defaults; "none" draws nothing. Needs '
                            "`output.fields = true`; a drawing that fails only warns."),
        "checkpoint_every": Leaf(Int(0), 0,
                                  doc="Every this many steps, write the state a run needs "
                                      "to go on into checkpoint/ (the last two are kept); "
                                      "`rftfem run SCENE --restart DIR` continues from the "
                                      "last. 0 writes none."),
    }, doc="What a run writes besides steps.csv, body.csv and summary.json."),
    **effects.scene_keys(),
    "load": effects.load_schema(),
    "parameters": Parameters(doc="Named numbers for the scene's formulas (the magnetization "
                                  "and its direction, a field's components): a design "
                                  "variable written once, used in several formulas, and "
                                  "changed by one `--set` (as `rftfem optimize --vary` does). "
                                  "Each use is replaced by the number when the scene is read."),
    "solver": Free(doc="PETSc options of the nonlinear solve, named without prefix or dash "
                        "(snes_rtol, ksp_type, pc_type, ...). They replace rftfem's defaults; "
                        "PETSc options on the `rftfem run` command line replace them in "
                        "turn. Three keys are rftfem's own: `tangent`, the Newton tangent, "
                        '"mixed-point" (default: membrane and shear forces in the geometric '
                        'stiffness linearized from the last iterate) or "exact" '
                        "(docs/model.md §7.4); `-tangent exact` on the command line. Then "
                        "`factorization`, when the tangent's LU factorisation is made: "
                        '"every-iteration" (direct solves), "every-step" (once a step, '
                        'GMRES on the current tangent), "reused" (kept across steps until '
                        'GMRES needs more than 20 iterations) or "auto" (default: '
                        '"every-iteration" up to 20 000 unknowns, "reused" above; '
                        "docs/model.md §7.7); `-factorization reused` on the command line. "
                        '`mat_type`, how the tangent is stored: "baij" (default: a block per '
                        'pair of nodes) or "aij" (single entries, for preconditioners that '
                        "take no block matrix, such as hypre); `-mat_type aij`."),
}, doc="The top level of the scene file.")

#: the order the reference lists the top-level keys in; an effect's key not named
#: here comes before [output]
_READING_ORDER = ("title", "parameters", "mesh", "shell", "hinge", "time", "boundary", "load", "motion",
                  "fluid", "magnetic")
SCHEMA.fields = dict(sorted(SCHEMA.fields.items(), key=lambda item: (
    _READING_ORDER.index(item[0]) if item[0] in _READING_ORDER else
    len(_READING_ORDER) + (item[0] in ("output", "solver")) + (item[0] == "solver"))))


# ---------------------------------------------------------------- cross checks


def _cross_check(scene: dict) -> None:
    mesh, shell, time = scene["mesh"], scene["shell"], scene["time"]

    check_mesh(mesh)
    output = scene["output"]
    if output["render"] != "none" and not output["fields"]:
        raise SceneError(f'output.render = "{output["render"]}" draws the fields: '
                         "it needs output.fields = true")

    # shell parts: region references, inherited material values
    for i, part in enumerate(shell["parts"]):
        check_region_ref(part["region"], f"shell.parts.{i}.region", scene)
        for key in _PART_MATERIAL:
            if part[key] is None:
                part[key] = shell[key]
    check_unique(shell["parts"], "region", "shell.parts", "region")

    # rftfem's own keys of [solver] (petsc_options is not imported here: PETSc would
    # start MPI in a process that may launch mpirun, as `rftfem study --np` does)
    check_tangent((scene.get("solver") or {}).get("tangent", TANGENTS[0]))
    check_factorization((scene.get("solver") or {}).get("factorization", FACTORIZATIONS[0]))
    check_matrix_type((scene.get("solver") or {}).get("mat_type", MATRIX_TYPES[0]))

    # time
    if time["dt"] > time["end"]:
        raise SceneError(f"time.dt: expected a number <= time.end = {fmt(time['end'])}, "
                         f"found {fmt(time['dt'])}")
    if time["end"] / time["dt"] > MAX_STEPS:
        raise SceneError(f"time.dt: expected at most {MAX_STEPS:.0e} steps up to time.end = "
                         f"{fmt(time['end'])}, found dt = {fmt(time['dt'])} "
                         f"({time['end'] / time['dt']:.1e} steps)")

    if time["tolerance"] is None:
        for key in ("dt_min", "dt_max"):
            if time[key] is not None:
                raise SceneError(f"time.{key}: bounds the error-controlled step; it needs "
                                 "time.tolerance")
    else:
        if resolved_scheme(scene) in ("static", "arc-length"):
            raise SceneError("time.tolerance: the scheme is static (load steps have no time "
                             "error to control); remove time.tolerance or use a scheme in time")
        if time["dt_min"] is None:
            time["dt_min"] = time["dt"] * 1e-6
        if time["dt_max"] is None:
            time["dt_max"] = time["end"]
        if not time["dt_min"] <= time["dt"] <= time["dt_max"]:
            raise SceneError(f"time.dt: the first step must lie within [time.dt_min, "
                             f"time.dt_max] = [{fmt(time['dt_min'])}, {fmt(time['dt_max'])}], "
                             f"found {fmt(time['dt'])}")

    effects.check(scene)  # each effect's own keys
    steady.check(scene)

    # probes
    probes = scene["output"]["probes"]
    check_unique(probes, "name", "output.probes", "probe")
    for i, probe in enumerate(probes):
        check_on_body(probe["at"], f"output.probes.{i}.at", "probe", scene)


# ------------------------------------------------------------------ public API


def apply_override(data: dict, text: str) -> None:
    """Apply one ``--set a.b.c=VALUE`` to the raw scene ``data`` (in place).

    VALUE is read as a TOML value; if it is not one but is a bare word
    (``triangle``, ``x=L``, ``plate.msh``) it is taken as a string. Arrays of
    tables are addressed by index (``load.0.value``). A path that is not in the
    schema, or an index out of range, raises SceneError naming the path. Missing
    tables on the way are created (``--set fluid.drag=[1,1,2]``).
    """
    key, sep, raw_value = text.partition("=")
    key = key.strip()
    if not sep or not key:
        raise SceneError(f"--set: expected KEY=VALUE (e.g. time.dt=0.005), found '{text}'")
    set_key(data, key, _parse_value(key, raw_value.strip()))


def set_key(data: dict, key: str, value: Any) -> None:
    """Set the dotted ``key`` of the raw scene ``data`` to the Python ``value`` (in
    place), as ``--set`` does once it has read its value; errors name ``--set`` so
    that the Python API's messages are the command line's."""
    parts = key.split(".")
    if any(not p for p in parts):
        raise SceneError(f"--set {key}: expected a dotted key path like shell.thickness, "
                         f"found an empty component")

    spec: Any = SCHEMA
    node: Any = data
    path = ""
    for n, part in enumerate(parts):
        last = n == len(parts) - 1
        here = join(path, part)
        if isinstance(spec, Table):
            if part not in spec.fields:
                raise SceneError(f"--set: unknown key '{here}'"
                                 + (suggest(part, spec.fields, path + "." if path else "")
                                    or f" (valid keys{' in ' + section(path) if path else ''}:"
                                       f" {', '.join(spec.fields)})"))
            sub = spec.fields[part]
            if last:
                node[part] = value
                return
            if isinstance(sub, Leaf):
                raise SceneError(f"--set {key}: '{here}' is a value, not a table, so "
                                 f"'{key}' does not exist")
            if part not in node:
                node[part] = [] if isinstance(sub, Array) else {}
            child = node[part]
            if isinstance(sub, Array):
                if not isinstance(child, list):
                    raise err(here, f"an array of tables [[{here}]]", child)
            elif not isinstance(child, dict):
                raise err(here, f"a table {section(here)}", child)
            spec, node, path = sub, child, here
        elif isinstance(spec, Array):
            if not re.fullmatch(r"\d+", part):
                raise SceneError(f"--set {key}: expected an index into [[{path}]] after "
                                 f"'{path}', found '{part}'")
            index = int(part)
            if index >= len(node):
                raise SceneError(f"--set {key}: index {index} out of range, the scene has "
                                 f"{len(node)} [[{path}]] entr{'y' if len(node) == 1 else 'ies'}")
            if last:
                node[index] = value
                return
            if not isinstance(node[index], dict):
                raise err(here, "a table", node[index])
            spec, node, path = spec.item, node[index], here
        elif isinstance(spec, Free):
            if not last:
                raise SceneError(f"--set {key}: '{here}' is a PETSc option, not a table")
            node[part] = value
            return


def _parse_value(key: str, text: str) -> Any:
    if "\n" not in text and "\r" not in text:
        try:
            parsed = tomllib.loads("v = " + text)
        except tomllib.TOMLDecodeError:
            parsed = None
        if parsed is not None and list(parsed) == ["v"]:
            return parsed["v"]
    if _BARE_WORD_RE.match(text):
        return text
    raise SceneError(f"--set {key}: expected a TOML value (a number, true/false, "
                     f"\"string\", [array] or bare word), found '{text}'")


def read_scene_file(path: str | os.PathLike) -> dict:
    """The raw TOML table of the scene file ``path`` (nothing checked but TOML)."""
    shown = str(path)
    try:
        data = Path(path).expanduser().read_bytes()
    except FileNotFoundError:
        raise SceneError(f"scene file '{shown}' not found") from None
    except IsADirectoryError:
        raise SceneError(f"scene file '{shown}': expected a TOML file, found a directory") \
            from None
    except OSError as exc:
        raise SceneError(f"cannot read scene file '{shown}': {exc.strerror or exc}") from None
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        raise SceneError(f"scene file '{shown}': expected a UTF-8 TOML file, found "
                         "binary or non-UTF-8 data") from None
    return parse_scene_text(text, f"scene file '{shown}'")


def parse_scene_text(text: str, shown: str = "scene text") -> dict:
    """The raw TOML table of a scene given as text; ``shown`` names it in errors."""
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        msg = " ".join(str(exc).split())
        raise SceneError(f"{shown} is not valid TOML: {msg}") from None


def load_scene(path: str | os.PathLike, overrides: Iterable[str] = ()) -> dict:
    """Read, override, validate and complete the scene in ``path`` (see module doc)."""
    raw = read_scene_file(path)
    overrides = list(overrides)
    for text in overrides:
        apply_override(raw, text)
    scene_path = Path(path).expanduser().resolve()
    return complete_scene(raw, scene_path.parent, scene_path, overrides)


def complete_scene(raw: dict, folder: str | os.PathLike, path: str | os.PathLike | None = None,
                   overrides: Iterable[str] = ()) -> dict:
    """Validate and complete the raw scene table ``raw`` (left as it is): relative
    files (``mesh.file``, profiles) are read from ``folder``; ``path`` is the scene
    file, if there is one, and ``overrides`` the ``--set`` texts already applied,
    both for the record (summary.json)."""
    import copy

    kept = copy.deepcopy(raw)
    raw = copy.deepcopy(raw)  # validation fills defaults in the tables it is given
    # the [parameters] first: the formulas that use them are validated with their numbers
    parameters = SCHEMA.fields["parameters"].validate(raw.get("parameters", {}), "parameters")
    with scene_parameters(parameters):
        scene = validate_table(SCHEMA, raw, "")
        _cross_check(scene)
    scene["time"]["scheme"] = resolved_scheme(scene)

    folder = Path(folder).expanduser().resolve()
    mesh = scene["mesh"]
    if mesh["kind"] == "gmsh":
        mesh_file = (folder / Path(mesh["file"]).expanduser()).resolve()
        if not mesh_file.exists():
            raise SceneError(f"mesh.file: expected a readable gmsh mesh file, found "
                             f"'{mesh['file']}' which does not exist ({mesh_file})")
        if not mesh_file.is_file():
            raise SceneError(f"mesh.file: expected a readable gmsh mesh file, found "
                             f"'{mesh['file']}' which is not a regular file ({mesh_file})")
        try:
            with open(mesh_file, "rb") as fh:
                fh.read(1)
        except OSError as exc:
            raise SceneError(f"mesh.file: expected a readable gmsh mesh file, found "
                             f"'{mesh['file']}' which cannot be read "
                             f"({exc.strerror or exc})") from None
        mesh["file"] = str(mesh_file)
    scene["_path"] = None if path is None else str(path)
    scene["_folder"] = str(folder)
    scene["_overrides"] = list(overrides)
    scene["_raw"] = kept
    return scene


def with_overrides(scene: dict, overrides: Iterable[str]) -> dict:
    """A completed scene like ``scene`` with the ``--set`` texts ``overrides`` applied
    after its own (the scene file is not read again)."""
    import copy

    raw = copy.deepcopy(scene["_raw"])
    overrides = list(overrides)
    for text in overrides:
        apply_override(raw, text)
    return complete_scene(raw, scene["_folder"], scene["_path"],
                          [*scene.get("_overrides", []), *overrides])


def active_effects(scene: dict) -> list[str]:
    """The effects the scene asks for, in the registry's order (rftfem/effects)."""
    return effects.active_effects(scene)
