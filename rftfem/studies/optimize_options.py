"""The options of ``rftfem optimize`` (rftfem/studies/optimize.py) and its --help."""

from __future__ import annotations

from typing import TYPE_CHECKING

from rftfem.studies import executors
from rftfem.studies.optimize_methods import METHODS

if TYPE_CHECKING:
    import argparse

__all__ = ["add_arguments", "DESCRIPTION", "EPILOG", "DEFAULT_METHOD", "DEFAULT_BUDGET"]

DEFAULT_METHOD = "cobyla"
DEFAULT_BUDGET = 40

DESCRIPTION = """\
Search scene parameters (--vary KEY=LO:HI) for the best value of an objective
written in the quantity language of `rftfem collect`, with optional constraints.
Every evaluation is an ordinary run folder; a failed run is recorded and
penalised. Writes optimize.csv (every evaluation), best.toml (the best scene,
ready to run) and optimize.png (objective and parameters against evaluation)."""

EPILOG = """\
objective and constraints: formulas (+ - * / ^, abs, sqrt, min, max, ...) of the
quantities of `rftfem collect`: COLUMN@TIME, rate(COLUMN, A, B), mean(...),
max(...), min(...), spin(PROBE_A, PROBE_B, AXIS, A, B), steady(NAME), and of
scene(KEY), a number of the run's scene (a design's cost)
methods: cobyla (default), nelder-mead, powell, l-bfgs-b, grid
examples:
  rftfem optimize demos/end_shear.toml --vary shell.thickness=0.05:0.2 \\
      --objective 'tip_uz@end + 0.4*scene(shell.thickness)' \\
      --set 'load.0.value=[0,0,0.004]' --set time.dt=1
  rftfem optimize demos/swimming_sheet.toml --vary motion.0.amplitude=0.05:0.3 \\
      --objective 'steady(front_ux_rate)' --maximize \\
      --constraint 'steady(drag_power)<=2e-5' --budget 20
  rftfem optimize demos/three_link_stroke.toml --vary motion.1.phase=-3:-0.15 \\
      --objective '-rate(centre_uy, 1, 3)/mean(drag_power, 1, 3)' --maximize
  rftfem optimize demos/thickness_design.toml --vary-field shell.thickness=0.05:0.2 \
      --constraint mass=start --maximize \
      --objective 'atan((tip_uz@end - back_uz@end)/(0.5 + tip_ux@end - back_ux@end))'
--vary-field: the values of a material field on its profile grid (the scene's
profile, or a strip's node lines) are the variables, with exact gradients
(static scenes); l-bfgs-b, or slsqp with constraints on mass or volume
(=, <=, >=; a number or 'start'); writes best-KEY.csv and best.toml reading it
exit status: 0 optimisation written (also when runs failed), 2 bad option or scene"""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    import argparse

    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    parser.epilog = EPILOG
    parser.add_argument("scene", metavar="SCENE.toml", help="the scene file")
    _add_variable_options(parser)
    _add_objective_options(parser)
    _add_method_options(parser)
    # --set, --out, --jobs, --np, --reuse, --executor...
    executors.add_arguments(
        parser,
        "optimize",
        "evaluations",
        jobs_note=", where the method has several to make (grid; l-bfgs-b's differences)",
        reuse_note="; failed runs count as finished (resumes an optimisation)",
    )


def _add_variable_options(parser: argparse.ArgumentParser) -> None:
    """--vary and --vary-field: what the search varies."""
    parser.add_argument(
        "--vary",
        metavar="KEY=LO:HI",
        action="append",
        default=[],
        help="a scalar scene key and its interval (LO:HI:log for a log "
        "scale; load.0.value.1 for a component); repeatable",
    )
    parser.add_argument(
        "--vary-field",
        metavar="KEY=LO:HI",
        default=None,
        dest="vary_field",
        help="instead of --vary: the values of a material field (shell."
        "thickness, shell.E, shell.nu, shell.density) on its profile grid, "
        "each in [LO, HI], with exact gradients (static scenes); "
        "constraints 'mass=start', 'volume<=V'",
    )


def _add_objective_options(parser: argparse.ArgumentParser) -> None:
    """--objective, its sense and the constraints."""
    parser.add_argument(
        "--objective",
        metavar="EXPR",
        default=None,
        help="what to optimise: a formula of collect's quantities",
    )
    sense = parser.add_mutually_exclusive_group()
    sense.add_argument("--maximize", action="store_true", help="seek the largest objective")
    sense.add_argument(
        "--minimize", action="store_true", help="seek the smallest objective (the default)"
    )
    parser.add_argument(
        "--constraint",
        metavar="EXPR<=V",
        action="append",
        default=[],
        help="EXPR<=V or EXPR>=V, EXPR as the objective; repeatable",
    )


def _add_method_options(parser: argparse.ArgumentParser) -> None:
    """--method and --budget."""
    parser.add_argument(
        "--method",
        metavar="NAME",
        default=None,
        help=f"{', '.join(METHODS)} (default {DEFAULT_METHOD}; with "
        "--vary-field l-bfgs-b, or slsqp with constraints)",
    )
    parser.add_argument(
        "--budget",
        metavar="N",
        type=int,
        default=DEFAULT_BUDGET,
        help=f"at most N runs (default {DEFAULT_BUDGET})",
    )
