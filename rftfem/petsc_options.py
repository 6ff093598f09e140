"""The one place where PETSc options are chosen (docs/model.md §7).

Precedence, lowest first: the defaults below, the scene's ``[solver]`` table, the
command line (``rftfem run scene.toml -snes_monitor -ksp_type gmres``).  All
options live under one prefix per problem so several solvers can coexist.
"""

from __future__ import annotations

from petsc4py import PETSc

from rftfem import compat
from rftfem.scene.schema import (
    FACTORIZATIONS,
    MATRIX_TYPES,
    TANGENTS,
    check_factorization,
    check_matrix_type,
    check_tangent,
)

PREFIX = "rftfem_"

#: The tangent's PETSc matrix type unless ``[solver] mat_type`` says otherwise: a
#: block of (u, θ) rows per node (rftfem/model/shell_model.py), inserted a node pair at a time (10×
#: faster than entry by entry); PETSc's LU and MUMPS factorise it as it is
#: (docs/performance.md, "What a Jacobian costs")
MATRIX_TYPE = MATRIX_TYPES[0]  # "baij"

#: Relative to the scene's driving force (see ``Model.reference_force``).
ATOL_FACTOR = 1e-7
#: Relative to the elastic force scale (``Model.elastic_force``): below this a
#: residual that Newton stops reducing is round-off (solver.StepSolver._converged)
ROUNDOFF_FACTOR = 1e-10
#: Relative to the membrane force ``E t W``, in units of the machine epsilon: the
#: same, for stiff membranes.  Residuals stalled at 2 to 60 ε E t W (the swimming
#: sheet, the roll-up at L/t = 1e4 and 1e5); 100 ε leaves a margin.
MEMBRANE_ROUNDOFF_FACTOR = 100 * 2.220446049250313e-16
#: above this many unknowns ``factorization = "auto"`` keeps the factorisation across
#: steps: there one MUMPS factorisation costs several Jacobian assemblies (at 59k
#: unknowns 2 s against 0.4 s), below it a direct solve is as cheap as a GMRES one
#: (docs/performance.md)
REUSE_ABOVE = 20_000
#: a kept factorisation is made again at the next tangent once a linear solve took
#: more GMRES iterations than this (docs/model.md §7.7)
REUSE_ITERATIONS = 20
#: serial runs up to this many unknowns factorise with PETSc's own LU, above it (and
#: under mpirun) with MUMPS: a MUMPS factorisation has a fixed cost of about 1.4 ms
#: (at 315 unknowns PETSc's takes 0.05 ms), PETSc's grows faster and does not pivot.
#: A solve that fails with PETSc's LU is made again with MUMPS, which the run then
#: keeps (solver.py; docs/performance.md)
PETSC_LU_UP_TO = 5_000
#: the Krylov options of the policies that keep a factorisation: a relative tolerance
#: that leaves Newton's convergence quadratic (its residual, not the linear solve,
#: decides when a step is done; at 59k unknowns 1e-8 took 20 % fewer GMRES iterations
#: than 1e-10 and the same Newton iterations), a limit past which a stale
#: factorisation is given up and the solve made again with a fresh one, and SNES told
#: to keep the preconditioner (the solver drops it when it wants new factors)
KRYLOV = {
    "ksp_type": "gmres",
    "ksp_rtol": 1e-8,
    "ksp_atol": 0.0,
    "ksp_max_it": 40,
    "ksp_gmres_restart": 40,
    "snes_lag_preconditioner": -2,
}


#: with a nonlocal effect (Stokes flow) the tangent is a shell matrix, solved by GMRES
#: preconditioned by the factors of its local part (coupled.py): as many iterations
#: as the nonlocal part's spectrum needs (tens on the rigid disk), within one restart
NONLOCAL_KRYLOV = {
    "ksp_type": "gmres",
    "ksp_rtol": 1e-10,
    "ksp_atol": 0.0,
    "ksp_max_it": 400,
    "ksp_gmres_restart": 400,
}


def tangent(scene_solver: dict | None = None, command_line: list[str] | None = None) -> str:
    """The Newton tangent a run asks for: ``solver.tangent`` in the scene, replaced by
    ``-tangent`` on the command line; one of ``TANGENTS``."""
    value = (scene_solver or {}).get("tangent", TANGENTS[0])
    value = parse_command_line(command_line or []).get("tangent", value)
    return check_tangent(value)


def factorization(
    scene_solver: dict | None = None, command_line: list[str] | None = None, unknowns: int = 0
) -> str:
    """When the tangent's factorisation is made: ``solver.factorization`` in the scene,
    replaced by ``-factorization`` on the command line; "auto" is resolved by the
    global number of ``unknowns`` (``REUSE_ABOVE``)."""
    value = (scene_solver or {}).get("factorization", FACTORIZATIONS[0])
    value = check_factorization(parse_command_line(command_line or []).get("factorization", value))
    if value == "auto":
        return "reused" if unknowns > REUSE_ABOVE else "every-iteration"
    return value


def matrix_type(options: dict) -> str:
    """The tangent's matrix type: ``mat_type`` of the merged ``options`` (the scene's
    ``[solver]`` or ``-mat_type``), else ``MATRIX_TYPE``."""
    return check_matrix_type(str(options.get("mat_type", MATRIX_TYPE)))


def lu_package(unknowns: int, processes: int) -> str | None:
    """The LU a run's tangent is factorised with by default: PETSc's own for serial
    runs up to ``PETSC_LU_UP_TO`` unknowns, MUMPS otherwise; None (PETSc's, the only
    one there is) where PETSc has no MUMPS."""
    if not compat.has_mumps():
        return None
    return "petsc" if processes == 1 and unknowns <= PETSC_LU_UP_TO else "mumps"


def user_sets(
    key: str, scene_solver: dict | None = None, command_line: list[str] | None = None
) -> bool:
    """Whether the scene's ``[solver]`` or the command line gives ``key``."""
    return key in (scene_solver or {}) or key in parse_command_line(command_line or [])


def defaults(
    reference_force: float,
    factorization: str = "every-iteration",
    lu: str | None = "mumps",
    nonlocal_tangent: bool = False,
) -> dict:
    """Newton with full steps and a direct solver.

    PETSc's default backtracking line search stalls on large-rotation shells
    (the first full Newton step overshoots, the residual grows, ``bt`` backtracks
    to tiny steps), so the line search is ``basic`` (full steps) and the time
    loop cuts the step instead.  The divergence tolerance is off for the same
    reason.  Besides the residual tests, a state whose distance from the solution
    is below 1e-10 of its own size counts as converged (the last Newton step
    shows it, or the solver estimates it from the last two): near round-off the
    residual of a stiff membrane (E t ~ 1e5 N/mm) cannot fall below ~1e-9 N
    however small the load.
    The residual test is absolute, in units of the forces that drive the body
    (no relative test: the first residual of a predicted step is the
    prediction's elastic misfit, not a force scale), and every solve takes at
    least one Newton update: a prediction can meet the tolerance without being
    the answer.
    The Jacobian is non-symmetric (drag and magnetic couples are
    non-conservative): LU, by ``lu`` (``lu_package``: PETSc's own for small serial
    runs, MUMPS for the others) where PETSc has MUMPS.  A ``factorization`` that
    keeps it ("every-step", "reused") solves with GMRES preconditioned by the kept
    factors (``KRYLOV``); the solver decides when to factorise (solver.py).
    """
    opts = {
        "snes_type": "newtonls",
        "snes_linesearch_type": "basic",
        "snes_rtol": 0.0,  # relative to a predicted start's misfit: meaningless
        "snes_atol": ATOL_FACTOR * reference_force,
        "snes_stol": 1e-10,
        "snes_max_it": 25,
        "snes_force_iteration": True,
        "snes_divergence_tolerance": compat.petsc_unlimited(),
        "ksp_type": "preonly",
        "pc_type": "lu",
    }
    if lu is not None and compat.has_mumps():
        opts["pc_factor_mat_solver_type"] = lu
    if factorization != "every-iteration":
        opts.update(KRYLOV)
    if nonlocal_tangent:
        opts.update(NONLOCAL_KRYLOV)
    return opts


def direct_solver(A: PETSc.Mat) -> PETSc.KSP:
    """A KSP that solves with ``A`` exactly (LU, MUMPS where PETSc has it), for the
    auxiliary projections of the model; not influenced by user options.  The
    factorisation is computed at the first solve and reused."""
    ksp = PETSc.KSP().create(A.getComm())
    ksp.setOperators(A)
    ksp.setType("preonly")
    ksp.getPC().setType("lu")
    if compat.has_mumps():
        ksp.getPC().setFactorSolverType("mumps")
    return ksp


def _value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    return str(v)


def _is_number(text: str) -> bool:
    """A value such as ``-2`` or ``-1e-3`` (not an option name)."""
    try:
        float(text)
    except ValueError:
        return False
    return True


def parse_command_line(args: list[str]) -> dict:
    """PETSc's command-line options as a dict: ``["-snes_monitor", "-ksp_type", "gmres"]``
    -> ``{"snes_monitor": "", "ksp_type": "gmres"}``."""
    out, i = {}, 0
    while i < len(args):
        key = args[i].lstrip("-")
        if key.startswith(PREFIX):
            key = key[len(PREFIX) :]
        if i + 1 < len(args) and (not args[i + 1].startswith("-") or _is_number(args[i + 1])):
            out[key] = args[i + 1]
            i += 2
        else:
            out[key] = ""
            i += 1
    return out


def merged(
    reference_force: float,
    scene_solver: dict | None = None,
    command_line: list[str] | None = None,
    factorization: str = "every-iteration",
    lu: str | None = "mumps",
    nonlocal_tangent: bool = False,
) -> dict:
    """Defaults (for the resolved ``factorization`` and LU package, and a tangent with
    a ``nonlocal_tangent`` part), then the scene's ``[solver]``, then command-line
    options."""
    opts = defaults(reference_force, factorization, lu, nonlocal_tangent)
    for key, value in (scene_solver or {}).items():
        if value is False:
            opts.pop(key, None)
        else:
            opts[key] = "" if value is True else value
    opts.update(parse_command_line(command_line or []))
    for own in ("tangent", "factorization"):  # rftfem's, not PETSc's
        opts.pop(own, None)
    return opts


def apply(opts: dict, prefix: str = PREFIX) -> None:
    """Write ``opts`` into PETSc's options database under ``prefix``."""
    db = PETSc.Options()
    for key, value in opts.items():
        db[prefix + key] = _value(value)


def clear(opts: dict, prefix: str = PREFIX) -> None:
    """Remove ``opts`` from the database (so runs in one process don't leak options)."""
    db = PETSc.Options()
    for key in opts:
        if db.hasName(prefix + key):
            db.delValue(prefix + key)


#: MUMPS's INFOG(1) when the factorisation outgrew its estimated workspace (-8, -9:
#: main work array; -11, -14: integer and real arrays of the solve phase)
MUMPS_WORKSPACE_ERRORS = (-8, -9, -11, -14)
#: the most percent of extra workspace (ICNTL(14), MUMPS's default 20) a retry asks for
MUMPS_WORKSPACE_MAX = 640


def grow_factor_workspace(ksp: PETSc.KSP, opts: dict, prefix: str = PREFIX) -> bool:
    """After a failed linear solve: if MUMPS ran out of its estimated workspace (the
    thin roll-up at L/t = 1e5: numerical pivoting on a stiffness ratio of 1e10 made
    more fill than the analysis foresaw; INFOG(1) = -9), double its extra workspace
    ICNTL(14) in ``opts`` and the options database, drop the factorisation (a new one
    reads the option) and return True; else False.  Set on the existing factor, the
    option did not reach the next factorisation."""
    pc = ksp.getPC()
    if pc.getType() not in ("lu", "cholesky") or pc.getFactorSolverType() != "mumps":
        return False
    try:
        factor = pc.getFactorMatrix()
        if factor.getMumpsInfog(1) not in MUMPS_WORKSPACE_ERRORS:
            return False
        percent = factor.getMumpsIcntl(14)
    except PETSc.Error:
        return False
    if percent >= MUMPS_WORKSPACE_MAX:
        return False
    opts["mat_mumps_icntl_14"] = min(MUMPS_WORKSPACE_MAX, 2 * max(percent, 20))
    apply({"mat_mumps_icntl_14": opts["mat_mumps_icntl_14"]}, prefix)
    pc.reset()
    return True


def reason_name(reason: int) -> str:
    """The name of a SNES converged (or diverged) reason."""
    names = {v: k for k, v in vars(PETSc.SNES.ConvergedReason).items() if isinstance(v, int)}
    return names.get(reason, str(reason))


def petsc_message(exc: Exception) -> str:
    """The last line of PETSc's own error text (what went wrong), else the error code."""
    lines = [ln.strip() for ln in str(exc).splitlines() if ln.strip()]
    text = lines[-1] if lines else ""
    return text[4:] if text.startswith("[0] ") else (text or repr(exc))
