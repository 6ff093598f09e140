"""sweep.png: the quantities of a sweep against its varied keys.

One varied key: each quantity against it, a panel per quantity (each its own y
axis: the quantities of a sweep have different units). Two, both numeric: a heat
map per quantity over the grid. Otherwise small multiples: a row of panels per
quantity, one panel per combination of the keys after the first (at most 16),
the quantity against the first key. Failed runs are gaps. Keys whose values are
not numbers are drawn at evenly spaced positions with their values as labels.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from rftfem.studies.sweep import Point, Vary

MAX_PANELS = 16


def _numeric(values) -> bool:
    return all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values)


def _axis(values):
    """Positions and tick labels of a key's values."""
    if _numeric(values):
        return np.asarray(values, dtype=float), None
    return np.arange(len(values), dtype=float), [str(v) for v in values]


def _value(point, name) -> float:
    v = point.quantities.get(name) if point.status != "failed" else None
    return np.nan if v is None else float(v)


def _lines(plt, points, varies, names, by_values, x, labels):
    """Each quantity against the first key: a row of panels per quantity (each with
    its own units on its y axis), a panel per combination of the other keys (at most
    MAX_PANELS, four to a row)."""
    first, rest = varies[0], varies[1:]
    combos = [()] if not rest else list(np.ndindex(*[len(v.values) for v in rest]))
    combos = combos[:MAX_PANELS]
    cols = min(4, len(combos))
    block = (len(combos) + cols - 1) // cols  # rows of panels per quantity
    fig, axes = plt.subplots(
        block * len(names), cols, figsize=(4.5 * cols, 3.2 * block * len(names)), squeeze=False
    )
    for r, name in enumerate(names):
        for k, combo in enumerate(combos):
            ax = axes[r * block + k // cols][k % cols]
            others = tuple(v.values[i] for v, i in zip(rest, combo))
            y = [_value(by_values[(a, *others)], name) for a in first.values]
            ax.plot(x, y, "o-")
            if labels:
                ax.set_xticks(x, labels)
            ax.set_xlabel(first.key)
            ax.set_ylabel(name)
            if rest:
                ax.set_title(
                    ", ".join(
                        f"{v.key.split('.')[-1]} = {o:.4g}"
                        if isinstance(o, float)
                        else f"{v.key.split('.')[-1]} = {o}"
                        for v, o in zip(rest, others)
                    ),
                    fontsize=9,
                )
        for k in range(len(combos), block * cols):
            axes[r * block + k // cols][k % cols].axis("off")
    return fig


def plot(points: list[Point], varies: list[Vary], names: list[str], path: Path, title: str) -> bool:
    """Draw sweep.png; False when there is nothing to draw (no quantities)."""
    if not names or not points:
        return False
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    by_values = {p.values: p for p in points}
    first = varies[0]
    x, labels = _axis(first.values)
    if len(varies) == 2 and _numeric(varies[0].values) and _numeric(varies[1].values):
        fig, axes = plt.subplots(1, len(names), figsize=(5 * len(names), 4), squeeze=False)
        second = varies[1]
        for ax, name in zip(axes[0], names):
            z = np.array(
                [[_value(by_values[(a, b)], name) for a in first.values] for b in second.values]
            )
            mesh = ax.pcolormesh(
                np.arange(len(first.values) + 1) - 0.5,
                np.arange(len(second.values) + 1) - 0.5,
                z,
                shading="flat",
            )
            ax.set_xticks(range(len(first.values)), [f"{v:.4g}" for v in first.values])
            ax.set_yticks(range(len(second.values)), [f"{v:.4g}" for v in second.values])
            lo, hi = (
                np.nanmin(z) if np.isfinite(z).any() else 0,
                np.nanmax(z) if np.isfinite(z).any() else 1,
            )
            for j, b in enumerate(second.values):
                for i, a in enumerate(first.values):
                    if np.isfinite(z[j, i]):
                        bright = hi > lo and (z[j, i] - lo) / (hi - lo) > 0.6
                        ax.text(
                            i,
                            j,
                            f"{z[j, i]:.3g}",
                            ha="center",
                            va="center",
                            fontsize=8,
                            color="black" if bright else "white",
                        )
            ax.set_xlabel(first.key)
            ax.set_ylabel(second.key)
            ax.set_title(name)
            fig.colorbar(mesh, ax=ax)
    else:
        fig = _lines(plt, points, varies, names, by_values, x, labels)
    fig.suptitle(f"rftfem sweep of {Path(title).name}", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return True
