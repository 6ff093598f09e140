"""``rftfem optimize --vary-field``: options, the search (rftfem/studies/optimize_fields.py)
and its outputs (best-KEY.csv, best.toml, optimize.png)."""

from __future__ import annotations

import shutil
import time
import tomllib
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from rftfem.errors import SceneError
from rftfem.studies import objective as objectives
from rftfem.studies.optimize_fields import (
    optimize_field,
    parse_field_constraint,
    parse_vary_field,
    run_quantities,
)

if TYPE_CHECKING:
    import argparse
    from typing import Any

    from rftfem.outputs.formulas import Objective
    from rftfem.studies.optimize_field_design import FieldConstraint, FieldDesign

__all__ = ["main"]


def main(args: argparse.Namespace, petsc_args: list[str], console: Any) -> int:
    method, constraints = _method_and_constraints(args)
    args.method = method
    objective, design = _objective_and_design(args, console)
    out = _out_folder(args)
    sign = -1.0 if args.maximize else 1.0
    console.out(
        f"rftfem optimize: {method} over the "
        f"{len(design.start)} values of {design.key} in [{design.lo:g}, {design.hi:g}] "
        f"({'maximise' if sign < 0 else 'minimise'} {args.objective}"
        + "".join(f"; {c.text}" for c in constraints)
        + f"; at most {args.budget} runs; gradients by the adjoint) in {out}"
    )
    t0 = time.perf_counter()
    best, why, evaluations = optimize_field(
        args, design, objective, constraints, sign, out, petsc_args, console
    )
    console.out(
        f"rftfem optimize: {why}; {len(evaluations)} runs in {time.perf_counter() - t0:.0f} s"
    )
    drawn = _plot(design, evaluations, best, sign, out / "optimize.png", args.objective)
    if best is None:
        console.err(f"rftfem optimize: no run met the constraints; optimize.csv in {out}")
        return 0
    _write_and_report_best(args, design, best, evaluations[0], out, drawn, console)
    return 0


def _method_and_constraints(args: argparse.Namespace) -> tuple[str, list[FieldConstraint]]:
    """The options a field search takes checked; its method (l-bfgs-b, or slsqp with
    constraints) and the mass and volume constraints."""
    if args.vary:
        raise SceneError("--vary-field: not with --vary (one search over a field's values)")
    if args.objective is None:
        raise SceneError(
            "--objective: give the quantity to optimise (e.g. --objective 'tip_uz@end')"
        )
    if args.budget < 1:
        raise SceneError(f"--budget: expected at least 1 run, found {args.budget}")
    if args.np != 1 or args.jobs != 1 or args.executor != "local":
        raise SceneError(
            "--vary-field: the runs and their gradients are taken in this "
            "process, one at a time (no --np, --jobs or --executor)"
        )
    if args.reuse:
        raise SceneError("--reuse: not with --vary-field (each search runs its evaluations afresh)")
    constraints = [parse_field_constraint(c) for c in args.constraint]
    method = (args.method or ("slsqp" if constraints else "l-bfgs-b")).strip().lower()
    method = method.replace("_", "-").replace("lbfgsb", "l-bfgs-b")
    if method not in ("l-bfgs-b", "slsqp"):
        raise SceneError(
            f"--method {args.method}: --vary-field searches with l-bfgs-b "
            "(bounds) or slsqp (bounds and constraints)"
        )
    if method == "l-bfgs-b" and constraints:
        raise SceneError(
            "--constraint: l-bfgs-b takes bounds only; with --vary-field and a "
            "constraint the method is slsqp (the default)"
        )
    return method, constraints


def _objective_and_design(args: argparse.Namespace, console: Any) -> tuple[Objective, FieldDesign]:
    """The static scene's objective (quantities the adjoint differentiates) and the
    field's grid; a formula's sampling is noted."""
    from rftfem.scene.reading import load_scene, resolved_scheme
    from rftfem.studies.sensitivity_request import supports

    scene = load_scene(args.scene, args.overrides)
    if resolved_scheme(scene) != "static":
        raise SceneError(
            '--vary-field: field gradients are for static scenes (time.scheme = "static")'
        )
    objective = objectives.parse(args.objective)
    texts, _ = run_quantities(objective)
    if not texts or not all(supports([], text, scene) for text in texts):
        raise SceneError(
            f"--objective '{args.objective}': --vary-field needs a formula of "
            "quantities the adjoint differentiates (probes' displacements at "
            "end, centroid_x|y|z@end, elastic_energy@end)"
        )
    design = parse_vary_field(args.vary_field, scene)
    if isinstance(scene["shell"][design.name], str):  # a formula becomes a profile
        console.err(
            f"rftfem optimize: note: {design.key}'s formula is sampled at the "
            f"{len(design.start)} grid points, linear between them: the search "
            "starts from that profile, not from the formula itself"
        )
    return objective, design


def _out_folder(args: argparse.Namespace) -> Path:
    """DIR made, without the evaluations of an earlier search."""
    out = (
        args.out if args.out is not None else Path("results") / f"optimize-{Path(args.scene).stem}"
    )
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise SceneError(f"--out {out}: {exc.strerror or exc}") from None
    for old in out.glob("eval-[0-9]*"):
        shutil.rmtree(old, ignore_errors=True)
    return out


def _write_and_report_best(
    args: argparse.Namespace,
    design: FieldDesign,
    best: Any,
    start: Any,
    out: Path,
    drawn: bool,
    console: Any,
) -> None:
    """best-KEY.csv and best.toml, and the lines that say them."""
    design.write(best.values, out / f"best-{design.name}.csv")
    _write_best(args, design, best, out)
    console.out(
        f"best: {best.folder.name}, objective {best.objective:.8g} (start "
        f"{start.objective:.8g}); mass {best.totals['mass']:.6g}, volume "
        f"{best.totals['volume']:.6g}"
    )
    console.err(
        f"rftfem optimize: optimize.csv, best-{design.name}.csv, best.toml"
        + (", optimize.png" if drawn else "")
        + f" in {out}"
    )


def _write_best(args, design, best, out: Path) -> None:
    """The scene with the best values: its key reads best-KEY.csv (next to it)."""
    from rftfem.scene import toml_writer
    from rftfem.scene.reading import apply_override
    from rftfem.studies.optimize_report import _file_keys

    raw = tomllib.loads(Path(args.scene).read_text(encoding="utf-8"))
    for text in args.overrides:
        apply_override(raw, text)
    folder = Path(args.scene).resolve().parent
    for table, key in _file_keys(raw):
        table[key] = str((folder / Path(table[key]).expanduser()).resolve())
    raw.setdefault("shell", {})[design.name] = {"profile": f"best-{design.name}.csv"}
    header = (
        f"The best evaluation of rftfem optimize --vary-field {args.vary_field}: "
        f"{best.folder.name}, objective {best.objective!r}"
    )
    (out / "best.toml").write_text(toml_writer.document(raw, header), encoding="utf-8")


def _plot(design, evaluations, best, sign, path: Path, title: str) -> bool:
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return False
    ok = [e for e in evaluations if e.status == "ok"]
    if not ok:
        return False
    fig, (a, b) = plt.subplots(2, 1, figsize=(7, 6))
    a.plot([e.index for e in ok], [e.objective for e in ok], "o-", ms=3)
    a.set_xlabel("evaluation")
    a.set_ylabel("objective")
    a.set_title(title, fontsize=9)
    a.grid(True, alpha=0.3)
    x = design.points[:, 0]
    order = np.argsort(x, kind="stable")
    b.plot(x[order], evaluations[0].values[order], ".--", color="0.5", label="start")
    if best is not None:
        b.plot(x[order], best.values[order], "o-", ms=3, label=best.folder.name)
    b.set_xlabel("X")
    b.set_ylabel(design.key)
    b.legend(fontsize=8)
    b.grid(True, alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return True
