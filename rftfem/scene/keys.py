"""The scene's own tables and the checks across them.

:data:`SCHEMA` is the whole scene's schema: the file-level tables ``title``,
``[shell]``, ``[output]``, ``[parameters]`` and ``[solver]`` are defined here,
``[mesh]`` in :mod:`rftfem.scene.mesh_keys`, ``[time]`` in
:mod:`rftfem.scene.time_keys`, and every effect brings its own keys
(:mod:`rftfem.model.effects`). :func:`cross_check` makes the checks that involve
more than one key once the tables are validated; reading a scene
(:mod:`rftfem.scene.reading`) calls it. The reference in docs/scenes.md is
generated from :data:`SCHEMA` (``python -m rftfem.reference``).
"""

from __future__ import annotations

from rftfem.errors import SceneError
from rftfem.model import effects
from rftfem.scene.bodies import BODY_KEY
from rftfem.scene.bodies import SCHEMA as BODIES
from rftfem.scene.material_keys import PART_MATERIAL, SHELL_MATERIAL, check_material
from rftfem.scene.mesh_keys import MESH, check_mesh
from rftfem.scene.schema import (
    Array,
    Bool,
    Free,
    Int,
    Leaf,
    Parameters,
    Str,
    Table,
    Vec,
    check_unique,
)
from rftfem.scene.selectors import check_on_body, check_region_ref
from rftfem.scene.solver_keys import (
    FACTORIZATIONS,
    MATRIX_TYPES,
    TANGENTS,
    check_factorization,
    check_matrix_type,
    check_tangent,
)
from rftfem.scene.time_keys import TIME, check_time
from rftfem.scene.time_rules import check_periodic

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
        "time": TIME,
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
    mesh, shell = scene["mesh"], scene["shell"]

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

    check_time(scene)
    effects.check(scene)  # each effect's own keys
    check_periodic(scene)

    # probes
    probes = scene["output"]["probes"]
    check_unique(probes, "name", "output.probes", "probe")
    for i, probe in enumerate(probes):
        check_on_body(probe["at"], f"output.probes.{i}.at", "probe", scene)
