"""The outputs of ``rftfem optimize`` besides optimize.csv: best.toml and optimize.png."""

from __future__ import annotations

import math
import tomllib
from pathlib import Path
from typing import TYPE_CHECKING

from rftfem.scene import toml_writer
from rftfem.studies.optimize_evaluations import Evaluation, Evaluator

if TYPE_CHECKING:
    from typing import Any


def write_best(ev: Evaluator, best: Evaluation, path: Path, command: str) -> None:
    """The best evaluation's scene (the scene file with its overrides) as TOML."""
    from rftfem.scene.reading import apply_override

    raw = tomllib.loads(Path(ev.scene_file).read_text(encoding="utf-8"))
    for text in ev.overrides_of(best.x):
        apply_override(raw, text)
    folder = Path(ev.scene_file).resolve().parent
    for table, key in _file_keys(raw):  # relative to the scene file: keep them found
        table[key] = str((folder / Path(table[key]).expanduser()).resolve())
    header = (
        f"The best evaluation of: {command}\n"
        f"{best.folder.name}: objective {best.objective!r} ({best.status}); "
        + ", ".join(f"{p.key} = {v!r}" for p, v in zip(ev.params, best.x))
    )
    path.write_text(toml_writer.document(raw, header), encoding="utf-8")


def _file_keys(raw: dict) -> list[tuple[dict, str]]:
    """``(table, key)`` of every file a scene names (read relative to its folder):
    ``mesh.file`` and each ``magnetic.parts`` entry's ``profile``."""
    tables = [(raw.get("mesh") or {}, "file")]
    tables += [
        (part, "profile")
        for part in (raw.get("magnetic") or {}).get("parts") or []
        if isinstance(part, dict)
    ]
    return [(table, key) for table, key in tables if isinstance(table.get(key), str)]


def plot(ev: Evaluator, path: Path, title: str) -> bool:
    """The objective against the evaluation (the best so far as a line) and each
    parameter's trace; False without matplotlib or evaluations."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return False
    evs = ev.evaluations
    if not evs:
        return False
    n = len(ev.params)
    fig, axes = plt.subplots(1 + n, 1, figsize=(7, 2.6 + 1.6 * n), sharex=True, squeeze=False)
    _plot_objective(axes[0][0], ev, title)
    for j, p in enumerate(ev.params):
        ax = axes[1 + j][0]
        ax.plot([e.index for e in evs], [e.x[j] for e in evs], ".-", color="C2", lw=0.8)
        ax.set_ylabel(p.key, fontsize=8)
        if p.log:
            ax.set_yscale("log")
        ax.grid(True, alpha=0.3)
    axes[-1][0].set_xlabel("evaluation")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return True


def _plot_objective(ax: Any, ev: Evaluator, title: str) -> None:
    """The objectives of the feasible and infeasible evaluations, the best so far as a
    line and the failed runs as dotted verticals."""
    evs = ev.evaluations
    ok = [e for e in evs if e.objective is not None]
    feasible = [e for e in ok if e.status == "ok"]
    if feasible:
        ax.plot(
            [e.index for e in feasible],
            [e.objective for e in feasible],
            "o",
            color="C0",
            label="evaluation",
        )
    bad = [e for e in ok if e.status == "infeasible"]
    if bad:
        ax.plot(
            [e.index for e in bad],
            [e.objective for e in bad],
            "s",
            mfc="none",
            color="C1",
            label="violates a constraint",
        )
    best_so_far, line = None, []
    for e in evs:
        if e.status == "ok" and (
            best_so_far is None or ev.sign * e.objective < ev.sign * best_so_far
        ):
            best_so_far = e.objective
        line.append(best_so_far)
    if best_so_far is not None:
        ax.step(
            [e.index for e in evs],
            [math.nan if v is None else v for v in line],
            where="post",
            color="k",
            lw=1,
            label="best so far",
        )
    failed = [e for e in evs if e.objective is None]
    for e in failed:
        ax.axvline(e.index, color="C3", lw=0.8, ls=":")
    if failed:
        ax.plot([], [], color="C3", ls=":", label="failed run")
    ax.set_ylabel("objective")
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=8)
    ax.grid(True, alpha=0.3)


__all__ = ["write_best", "plot"]
