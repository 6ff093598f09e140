"""The ``rftfem`` command line (docs/scenes.md "Command line"):

    rftfem run SCENE.toml [--out DIR] [--set KEY=VALUE ...] [--quiet] [PETSc options]
    rftfem check SCENE.toml [--set KEY=VALUE ...]

Exit status: 0 success; 2 bad scene or bad option (one line on stderr, no
traceback); 3 the run failed numerically (outputs so far are kept).

For ``run``, arguments that start with one dash and a letter (``-snes_monitor``,
``-ksp_type preonly``) are PETSc options: they are collected, each with its value
when the next token does not start with '-', and handed to the simulation.

Heavy modules (the simulation, dolfinx, mpi4py) are imported only when needed, so
``rftfem check`` on a bad scene answers at once. Under MPI only rank 0 prints and
every rank returns the same status.
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from rftfem import __version__
from rftfem.errors import RunFailed, RunInterrupted, SceneError

if TYPE_CHECKING:
    from rftfem.outputs.console import Console

_PETSC_OPTION = re.compile(r"^-[A-Za-z]")


class _UsageError(Exception):
    """Raised by the parser instead of printing a multi-line usage block."""


class _Parser(argparse.ArgumentParser):
    def error(self, message: str):  # one line, exit status 2 (handled in main)
        raise _UsageError(f"{self.prog}: error: {' '.join(message.split())}")


def _build_parser() -> _Parser:
    parser = _Parser(
        prog="rftfem",
        description="Large-rotation shells in viscous fluid (RFT drag, magnetic couples) "
        "on FEniCSx. A scene is one TOML file (see docs/scenes.md).",
        allow_abbrev=False,
    )
    parser.add_argument("--version", action="version", version=f"rftfem {__version__}")
    sub = parser.add_subparsers(
        dest="command", metavar="COMMAND", required=True, parser_class=_Parser
    )
    _add_run_command(sub)
    _add_check_command(sub)
    _add_commands_with_own_options(sub)
    return parser


def _add_run_command(sub: argparse._SubParsersAction) -> None:
    """``rftfem run``: the scene, its output folder, overrides, quiet and restart."""
    from rftfem.scene.overrides import add_override_arguments

    run = sub.add_parser(
        "run",
        help="run a scene",
        allow_abbrev=False,
        description="Run a scene and write probes.csv, steps.csv, summary.json and fields. "
        "Extra options with a single dash (-snes_monitor, -ksp_type preonly) "
        "are passed to PETSc.",
        epilog="exit status: 0 ok, 2 bad scene or option, 3 the run failed numerically, "
        "130/143 stopped by SIGINT/SIGTERM (after its step; outputs closed)",
    )
    run.add_argument("scene", metavar="SCENE.toml", help="the scene file")
    run.add_argument(
        "--out",
        metavar="DIR",
        type=Path,
        default=None,
        help="output folder (default: results/<scene file stem>)",
    )
    add_override_arguments(run)
    run.add_argument(
        "--quiet", action="store_true", help="plain log lines instead of a progress bar"
    )
    run.add_argument(
        "--restart",
        metavar="DIR",
        type=Path,
        default=None,
        help="go on from the last checkpoint in the results folder DIR "
        "(output.checkpoint_every), appending to its outputs; the scene "
        "may differ only in time.end and how the run is watched",
    )


def _add_check_command(sub: argparse._SubParsersAction) -> None:
    """``rftfem check``: the scene and its overrides."""
    from rftfem.scene.overrides import add_override_arguments

    check = sub.add_parser(
        "check",
        help="validate a scene and print its active effects",
        allow_abbrev=False,
        description="Validate a scene (including its mesh) and print the active effects "
        "and the time scheme.",
        epilog="exit status: 0 ok, 2 bad scene or option",
    )
    check.add_argument("scene", metavar="SCENE.toml", help="the scene file")
    add_override_arguments(check)


def _add_commands_with_own_options(sub: argparse._SubParsersAction) -> None:
    """``render``, ``collect``, ``study``, ``sweep`` and ``optimize``: each module adds
    its own options to its command."""
    # render and collect own their options (light modules: pyvista and the
    # simulation are imported only when the command runs)
    from rftfem.outputs import collect, render_cli
    from rftfem.studies import optimize, study, sweep

    for module, name, help_text, epilog in (
        (
            render_cli,
            "render",
            "draw a finished run as a picture (PNG) or a film (MP4, GIF)",
            "exit status: 0 ok, 2 bad option or results folder",
        ),
        (
            collect,
            "collect",
            "one table row per run folder of a parameter study",
            "exit status: 0 ok, 2 bad option or folder",
        ),
        (study, "study", "what accuracy costs: a scene at successive refinements", None),
        (sweep, "sweep", "a scene over a grid of values of any keys, by any executor", None),
        (optimize, "optimize", "search scene parameters for the best value of a quantity", None),
    ):
        module.add_arguments(
            sub.add_parser(
                name,
                help=help_text,
                allow_abbrev=False,
                description=module.DESCRIPTION,
                epilog=epilog,
            )
        )


def _split_petsc(argv: list[str]) -> tuple[list[str], list[str]]:
    """Separate PETSc options (``-name [value]``) from the arguments of ``run``.

    Only tokens after the ``run`` command are considered; the values of
    ``--out``/``--set`` and everything after ``--`` are left alone. A value is
    taken when the next token does not start with '-' (and is not a .toml file,
    so ``rftfem run -snes_monitor scene.toml`` keeps its scene).
    """
    try:
        start = next(i for i, tok in enumerate(argv) if not tok.startswith("-"))
    except StopIteration:
        return argv, []
    if argv[start] != "run":
        return argv, []
    rest, petsc = list(argv[: start + 1]), []
    i = start + 1
    while i < len(argv):
        tok = argv[i]
        if tok == "--":
            rest.extend(argv[i:])
            break
        if tok in ("--out", "--set", "--unset") and i + 1 < len(argv):
            rest.extend(argv[i : i + 2])
            i += 2
            continue
        if _PETSC_OPTION.match(tok) and tok != "-h":
            petsc.append(tok)
            nxt = argv[i + 1] if i + 1 < len(argv) else None
            if nxt is not None and not nxt.startswith("-") and not nxt.endswith(".toml"):
                petsc.append(nxt)
                i += 1
        else:
            rest.append(tok)
        i += 1
    return rest, petsc


def _glue_values(argv: list[str]) -> list[str]:
    """``--set VALUE`` as ``--set=VALUE``: argparse would take a value that starts
    with '-' (``--set -x=1``) for an option and answer with its own usage error, where
    the scene reader names the bad key."""
    out, i = [], 0
    while i < len(argv):
        if argv[i] == "--":
            return out + argv[i:]
        if argv[i] in ("--set", "--unset") and i + 1 < len(argv):
            out.append(f"{argv[i]}={argv[i + 1]}")
            i += 2
            continue
        out.append(argv[i])
        i += 1
    return out


def _default_out(scene_file: str) -> Path:
    return Path("results") / Path(scene_file).stem


def _cmd_run(args, petsc_args: list[str], console: Console) -> int:
    from rftfem.scene.reading import load_scene

    out_dir = (
        args.out
        if args.out is not None
        else (args.restart if args.restart is not None else _default_out(args.scene))
    )
    try:
        scene = load_scene(args.scene, args.overrides)
        from rftfem.integration.simulation import run as run_simulation

        console.refresh()  # the simulation brought in mpi4py
        run_simulation(
            scene,
            out_dir=out_dir,
            quiet=bool(args.quiet),
            petsc_args=petsc_args,
            signals=True,
            restart=args.restart,
        )
        status = 0
    except SceneError as exc:
        console.refresh()
        console.err(f"rftfem: error: {exc}")
        status = SceneError.exit_status
    except RunFailed as exc:
        console.refresh()
        console.err(f"rftfem: {exc}; outputs so far are in {out_dir}")
        status = RunFailed.exit_status
    except RunInterrupted as exc:
        console.refresh()
        console.err(f"rftfem: {exc}; outputs so far are in {out_dir}")
        status = exc.exit_status
    if status == 0 and not args.quiet:
        console.out(f"rftfem: done, outputs in {out_dir}")
    return console.agree(status)


def _cmd_check(args, console: Console) -> int:
    from rftfem.scene import scales
    from rftfem.scene.reading import active_effects, load_scene

    try:
        scene = load_scene(args.scene, args.overrides)
        try:
            from rftfem.integration.model_setup import check_report
        except ImportError:  # the simulation module is not there: a scene-only check

            def check_report(scene):
                return active_effects(scene), [], []

        effects, groups, mesh_lines = check_report(scene)  # mesh and fluid lines
        console.refresh()
    except SceneError as exc:
        console.refresh()
        console.err(f"rftfem: error: {exc}")
        return console.agree(SceneError.exit_status)
    console.out(f"scene OK: {scene['title']}")
    console.out("active effects: " + ", ".join(effects))
    fluid_lines = [line for line in mesh_lines if line.startswith("fluid: ")]
    for line in mesh_lines:
        if line not in fluid_lines:
            console.out(line)
    if scene.get("fluid"):
        wall = ", wall" if scene["fluid"].get("wall") else ""
        operator = scene["fluid"].get("operator", "auto")
        wall += f", {operator} operator" if operator != "auto" else ""
        console.out(f"fluid: {scene['fluid'].get('model', 'rft')}{wall}")
    for line in fluid_lines:
        console.out(line)
    console.out(f"scheme: {scene['time']['scheme']}")
    if groups:
        console.out("scales:")
    for line in scales.format_groups(groups):
        console.out(line)
    for line in scales.aliasing_warnings(scene):
        console.out("warning: " + line)
    return console.agree(0)


def _cmd_tool(args, petsc_args: list[str], console: Console) -> int:
    """``render`` and ``collect``: post-processing of results folders (serial)."""
    if petsc_args:
        console.err(f"rftfem {args.command}: error: unrecognized arguments: {' '.join(petsc_args)}")
        return 2
    if args.command == "render":
        from rftfem.outputs.render_cli import main as tool
    else:
        from rftfem.outputs.collect import main as tool
    try:
        return tool(args, console)
    except SceneError as exc:
        console.err(f"rftfem {args.command}: error: {exc}")
        return SceneError.exit_status


def _cmd_many(args, petsc_args: list[str], console: Console) -> int:
    """``study``, ``sweep`` and ``optimize``: many runs of a scene (PETSc options go to
    each)."""
    if args.command == "study":
        from rftfem.studies.study import main as tool
    elif args.command == "sweep":
        from rftfem.studies.sweep import main as tool
    else:
        from rftfem.studies.optimize import main as tool
    try:
        return tool(args, petsc_args, console)
    except SceneError as exc:
        console.err(f"rftfem {args.command}: error: {exc}")
        return SceneError.exit_status


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``rftfem`` and ``python -m rftfem``; returns the exit status."""
    from rftfem.outputs.console import Console

    argv = list(sys.argv[1:] if argv is None else argv)
    console = Console()
    rest, petsc_args = _split_petsc(argv)
    rest = _glue_values(rest)
    try:
        args = _build_parser().parse_args(rest)
    except _UsageError as exc:
        console.err(str(exc))
        return 2
    except SystemExit as exc:  # --help, --version
        return exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 2)
    try:
        if args.command == "run":
            return _cmd_run(args, petsc_args, console)
        if args.command in ("render", "collect"):
            return _cmd_tool(args, petsc_args, console)
        if args.command in ("study", "optimize", "sweep"):
            return _cmd_many(args, petsc_args, console)
        return _cmd_check(args, console)
    except KeyboardInterrupt:
        console.err("rftfem: interrupted")
        return 130
    except MemoryError:
        # under a memory limit (ulimit, a batch job's): one line, not a traceback; with
        # no limit the kernel may stop the process first, and nothing can be said
        console.refresh()
        print(
            "rftfem: error: out of memory while setting up or running the scene: fewer "
            "cells (mesh.divisions) or more processes",
            file=sys.stderr,
            flush=True,
        )
        if console.comm is not None and console.comm.size > 1:
            console.comm.Abort(2)  # the other processes would wait in a collective call
        return 2
    except Exception:
        # A bug, not a bad scene: keep the traceback. Under MPI with several ranks,
        # abort the job so the other ranks do not wait forever in a collective call.
        console.refresh()
        if console.comm is not None and console.comm.size > 1:
            import traceback

            traceback.print_exc()
            sys.stderr.flush()
            console.comm.Abort(1)
        raise
