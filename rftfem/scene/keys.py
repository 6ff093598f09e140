"""The scene's own tables and the checks across them.

:data:`SCHEMA` is the whole scene's schema: the file-level tables ``title``,
``[shell]``, ``[time]``, ``[output]``, ``[parameters]`` and ``[solver]`` are
defined here, ``[mesh]`` in :mod:`rftfem.scene.mesh_keys`, and every effect
brings its own keys (:mod:`rftfem.model.effects`). :func:`cross_check` makes the
checks that involve more than one key once the tables are validated; reading
a scene (:mod:`rftfem.scene.reading`) calls it. The reference in docs/scenes.md
is generated from :data:`SCHEMA` (``python -m rftfem.reference``).
"""

from __future__ import annotations

from rftfem.errors import SceneError
from rftfem.model import effects
from rftfem.scene.bodies import BODY_KEY
from rftfem.scene.bodies import SCHEMA as BODIES
from rftfem.scene.material_keys import PART_MATERIAL, SHELL_MATERIAL, check_material
from rftfem.scene.mesh_keys import MESH, check_mesh
from rftfem.scene.schema import (
    FACTORIZATIONS,
    MATRIX_TYPES,
    MAX_STEPS,
    POSITIVE,
    TANGENTS,
    Array,
    Bool,
    Free,
    Int,
    Leaf,
    Num,
    Parameters,
    Str,
    Table,
    Vec,
    check_factorization,
    check_matrix_type,
    check_tangent,
    check_unique,
    fmt,
)
from rftfem.scene.selectors import check_on_body, check_region_ref
from rftfem.scene.time_rules import check_periodic, resolved_scheme

__all__ = ["SCHEMA", "cross_check"]


SCHEMA = Table(
    {
        "title": Leaf(
            Str(),
            required=True,
            doc="A free-text name of the scene; `rftfem check` and the first log line "
            "of a run show it.",
        ),
        "mesh": MESH,
        "body": BODIES,
        "shell": Table(
            {
                **{k: v for k, v in SHELL_MATERIAL.items() if k != "fibre"},
                "axis": Leaf(
                    Vec(nonzero=True),
                    [1.0, 0.0, 0.0],
                    doc="The material axis E1* in reference coordinates (normalised). A "
                    "material direction only: the anisotropic drag frame (C1 along the "
                    "axis as the body carries it, C2 across it in the surface), "
                    "anisotropic friction, the fibre's default. The shell's rotations "
                    "do not need it, so it may be along the normal somewhere (a closed "
                    "body), unless an effect that needs it is on there (then named).",
                ),
                "fibre": SHELL_MATERIAL["fibre"],
                "parts": Array(
                    Table(
                        {
                            "region": Leaf(
                                Str(name=True),
                                required=True,
                                doc="The region (of `[[mesh.regions]]`, a built-in three-link "
                                "region or a gmsh physical surface); one part per region.",
                            ),
                            **PART_MATERIAL,
                        }
                    ),
                    doc="Material values that differ on a region; a part takes what it leaves out "
                    "from [shell].",
                ),
            },
            required=True,
            doc="The material (isotropic or orthotropic, plane stress) and thickness of the "
            "shell; each value a number or a field over the body.",
        ),
        "time": Table(
            {
                "end": Leaf(
                    POSITIVE,
                    1.0,
                    unit="time",
                    doc="The time the run stops at; linear load ramps reach their full value "
                    'there. With scheme = "static" time is only a load parameter.',
                ),
                "dt": Leaf(
                    POSITIVE,
                    0.01,
                    unit="time",
                    doc="The nominal step, at most `end`: the run makes ceil(end / dt) steps, "
                    "the last one ending at `end`. A step that fails is halved and "
                    "retried, then grown back. With arc-length: the first step's "
                    "increment of the load factor.",
                ),
                "scheme": Leaf(
                    Str(
                        (
                            "auto",
                            "generalized-alpha",
                            "hht",
                            "backward-euler",
                            "bdf2",
                            "static",
                            "arc-length",
                        )
                    ),
                    "auto",
                    doc='The time integrator. "generalized-alpha" and "hht" are second '
                    'order and need density; "backward-euler" (first order) and '
                    '"bdf2" (second order, variable steps) are for drag without '
                    'inertia; "static" steps the loads with no velocity '
                    '(refused with [fluid]); "arc-length" follows the static '
                    "equilibrium path with the load factor as an unknown, through "
                    "limit points and snap-backs (refused with [fluid]; time is then "
                    'the load factor λ). "auto" takes generalized-alpha with '
                    "density, backward-euler with [fluid] alone, static otherwise.",
                ),
                "start": Leaf(
                    Str(("rest", "equilibrium")),
                    "rest",
                    doc='How a run in time starts. "rest": in its initial state, at '
                    "rest: the reference, or the shape the t = 0 motions impose "
                    "with the rest of the body in elastic equilibrium; loads on at "
                    "t = 0 act from the first step on (a free plate in drag under a "
                    "constant force F has u(t) = F t / (C A) at every row). "
                    '"equilibrium": at rest in static equilibrium with the t = 0 '
                    "loads as well, to release a pre-loaded body (a load table that "
                    "drops to 0 after t = 0). Static runs always start in "
                    "equilibrium with their t = 0 loads.",
                ),
                "rho_inf": Leaf(
                    Num(0.0, 1.0),
                    0.9,
                    doc="Generalized-alpha's spectral radius at infinite frequency: 1 "
                    "damps nothing, smaller values damp the highest frequencies "
                    "more. Used by generalized-alpha only.",
                ),
                "alpha": Leaf(
                    Num(-1.0 / 3.0, 0.0),
                    -0.05,
                    doc="The α of the HHT scheme; 0 is the trapezoidal rule, more "
                    "negative values damp high frequencies. Used by hht only.",
                ),
                "output_every": Leaf(
                    Int(1),
                    1,
                    doc="Write a row of probes.csv and body.csv, and the fields, "
                    "every this many nominal steps (and after the last one).",
                ),
                "until": Leaf(
                    Str(("end", "periodic")),
                    "end",
                    doc='When the run stops: "end" at time.end; "periodic" once the '
                    "period means of every probes.csv and body.csv column (the drift "
                    "over a period for positions) have settled, extrapolated from "
                    "successive periods (Aitken), to steady_tolerance; time.end is then "
                    "the latest it may stop. summary.json's `steady` holds the values.",
                ),
                "period": Leaf(
                    POSITIVE,
                    None,
                    unit="time",
                    default_doc="from the travelling-wave motions or the rotating field",
                    doc='The period of time.until = "periodic"; dt must divide it.',
                ),
                "steady_tolerance": Leaf(
                    POSITIVE,
                    1e-3,
                    doc='time.until = "periodic": how closely two successive '
                    "periods' extrapolated steady values must agree, "
                    "relative to each column's value (or its swing over "
                    "a period, if larger).",
                ),
                "max_steps": Leaf(
                    Int(1),
                    1000,
                    doc='With scheme = "arc-length": the run stops after this many '
                    "steps if the load factor has not reached `end` by then.",
                ),
                "max_cuts": Leaf(
                    Int(0),
                    8,
                    doc="How many times one nominal step may be halved before the "
                    "run fails (exit status 3); a failed attempt may halve it "
                    "several times at once.",
                ),
                "tolerance": Leaf(
                    POSITIVE,
                    None,
                    default_doc="none: fixed steps of `dt`",
                    doc="Error-controlled steps: the largest local error a step may "
                    "make, relative to the body's size for displacements (and in "
                    "radians for rotations), estimated from the step's distance "
                    "to its prediction. `dt` is then the first step, steps grow "
                    "and shrink within [`dt_min`, `dt_max`], and outputs still "
                    "fall every `output_every` × `dt`. Not with static.",
                ),
                "dt_min": Leaf(
                    POSITIVE,
                    None,
                    unit="time",
                    default_doc="dt × 1e-6 (with `tolerance` only)",
                    doc="The smallest step the error control may take; a step that "
                    "needs a smaller one fails the run (exit status 3).",
                ),
                "dt_max": Leaf(
                    POSITIVE,
                    None,
                    unit="time",
                    default_doc="end (with `tolerance` only)",
                    doc="The largest step the error control may take.",
                ),
                "max_rotation": Leaf(
                    POSITIVE,
                    0.2,
                    unit="rad",
                    doc="The most any director may turn within one converged step "
                    "of a scheme with velocity (not static); a step that turns "
                    "one further is halved, as it would skip fast motion.",
                ),
            },
            required=True,
            doc="Time span, step and integration scheme.",
        ),
        "output": Table(
            {
                "probes": Array(
                    Table(
                        {
                            "name": Leaf(
                                Str(name=True),
                                required=True,
                                doc="The probe's columns in probes.csv are NAME_ux, NAME_uy, "
                                "NAME_uz; unique.",
                            ),
                            "at": Leaf(
                                Vec(),
                                required=True,
                                unit="length",
                                doc="The material point, in reference coordinates; on a strip or "
                                "three-link body it must lie on the body (z = 0); on a gmsh "
                                "body within 5 % of a cell's size of its surface (the nearest "
                                "point is taken).",
                            ),
                            "body": BODY_KEY,
                        }
                    ),
                    doc="Material points whose displacement goes to probes.csv.",
                ),
                "fields": Leaf(
                    Bool(),
                    True,
                    doc="Write fields.xdmf and fields.h5 (displacement, director, "
                    "magnetization) for ParaView.",
                ),
                "render": Leaf(
                    Str(("none", "png", "mp4", "gif")),
                    "none",
                    doc="When the run ends (also when it fails), draw render.png, "
                    "render.mp4 or render.gif in the output folder with `rftfem "
                    'render` and its defaults; "none" draws nothing. Needs '
                    "`output.fields = true`; a drawing that fails only warns.",
                ),
                "checkpoint_every": Leaf(
                    Int(0),
                    0,
                    doc="Every this many steps, write the state a run needs "
                    "to go on into checkpoint/ (the last two are kept); "
                    "`rftfem run SCENE --restart DIR` continues from the "
                    "last. 0 writes none.",
                ),
            },
            doc="What a run writes besides steps.csv, body.csv and summary.json.",
        ),
        **effects.scene_keys(),
        "load": effects.load_schema(),
        "parameters": Parameters(
            doc="Named numbers for the scene's formulas (the magnetization "
            "and its direction, a field's components): a design "
            "variable written once, used in several formulas, and "
            "changed by one `--set` (as `rftfem optimize --vary` does). "
            "Each use is replaced by the number when the scene is read."
        ),
        "solver": Free(
            doc="PETSc options of the nonlinear solve, named without prefix or dash "
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
            "take no block matrix, such as hypre); `-mat_type aij`."
        ),
    },
    doc="The top level of the scene file.",
)

#: the order the reference lists the top-level keys in; an effect's key not named
#: here comes before [output]
_READING_ORDER = (
    "title",
    "parameters",
    "mesh",
    "shell",
    "hinge",
    "time",
    "boundary",
    "load",
    "motion",
    "fluid",
    "magnetic",
)
SCHEMA.fields = dict(
    sorted(
        SCHEMA.fields.items(),
        key=lambda item: (
            _READING_ORDER.index(item[0])
            if item[0] in _READING_ORDER
            else len(_READING_ORDER) + (item[0] in ("output", "solver")) + (item[0] == "solver")
        ),
    )
)


# ---------------------------------------------------------------- cross checks


def cross_check(scene: dict) -> None:
    """The checks across keys of a validated scene (in place: parts inherit their
    material values from [shell], error control gets its step bounds)."""
    mesh, shell, time = scene["mesh"], scene["shell"], scene["time"]

    check_mesh(mesh)
    output = scene["output"]
    if output["render"] != "none" and not output["fields"]:
        raise SceneError(
            f'output.render = "{output["render"]}" draws the fields: it needs output.fields = true'
        )

    # shell parts: region references, inherited material values
    for i, part in enumerate(shell["parts"]):
        check_region_ref(part["region"], f"shell.parts.{i}.region", scene)
    check_material(shell)
    check_unique(shell["parts"], "region", "shell.parts", "region")

    # rftfem's own keys of [solver] (petsc_options is not imported here: PETSc would
    # start MPI in a process that may launch mpirun, as `rftfem study --np` does)
    check_tangent((scene.get("solver") or {}).get("tangent", TANGENTS[0]))
    check_factorization((scene.get("solver") or {}).get("factorization", FACTORIZATIONS[0]))
    check_matrix_type((scene.get("solver") or {}).get("mat_type", MATRIX_TYPES[0]))

    # time
    if time["dt"] > time["end"]:
        raise SceneError(
            f"time.dt: expected a number <= time.end = {fmt(time['end'])}, found {fmt(time['dt'])}"
        )
    if time["end"] / time["dt"] > MAX_STEPS:
        raise SceneError(
            f"time.dt: expected at most {MAX_STEPS:.0e} steps up to time.end = "
            f"{fmt(time['end'])}, found dt = {fmt(time['dt'])} "
            f"({time['end'] / time['dt']:.1e} steps)"
        )

    if time["tolerance"] is None:
        for key in ("dt_min", "dt_max"):
            if time[key] is not None:
                raise SceneError(
                    f"time.{key}: bounds the error-controlled step; it needs time.tolerance"
                )
    else:
        if resolved_scheme(scene) in ("static", "arc-length"):
            raise SceneError(
                "time.tolerance: the scheme is static (load steps have no time "
                "error to control); remove time.tolerance or use a scheme in time"
            )
        if time["dt_min"] is None:
            time["dt_min"] = time["dt"] * 1e-6
        if time["dt_max"] is None:
            time["dt_max"] = time["end"]
        if not time["dt_min"] <= time["dt"] <= time["dt_max"]:
            raise SceneError(
                f"time.dt: the first step must lie within [time.dt_min, "
                f"time.dt_max] = [{fmt(time['dt_min'])}, {fmt(time['dt_max'])}], "
                f"found {fmt(time['dt'])}"
            )

    effects.check(scene)  # each effect's own keys
    check_periodic(scene)

    # probes
    probes = scene["output"]["probes"]
    check_unique(probes, "name", "output.probes", "probe")
    for i, probe in enumerate(probes):
        check_on_body(probe["at"], f"output.probes.{i}.at", "probe", scene)
