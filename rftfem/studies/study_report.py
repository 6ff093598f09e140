"""The tables of a refinement study (``rftfem study``, study.py): the observed
order and the Richardson error estimate of each level, and study.csv, study.md
and study.png (docs/accuracy.md, "What accuracy costs").
"""

from __future__ import annotations

import csv
import math
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from collections.abc import Sequence

    from rftfem.outputs.formulas import Objective
    from rftfem.studies.study import Level

#: nominal orders of the time schemes (refinement of dt)
SCHEME_ORDER = {"backward-euler": 1, "bdf2": 2, "generalized-alpha": 2, "hht": 2}
#: nominal order assumed for mesh refinement (9-node / 6-node elements) when the
#: levels are too few to observe one
MESH_ORDER = 2
#: the same in Stokes flow (docs/stokes.md): the blobs at the nodes are first order in
#: the spacing; the integrated layer about 1.5 (its error is the free edges' corners)
STOKES_MESH_ORDER = {"blobs": 1.0, "layer": 1.5}


def nominal_order(kind: str, scheme: str, stokes: str | None = None) -> float:
    """The order a refinement of ``kind`` should show; ``stokes`` the Stokes method
    ("layer", "blobs") or None."""
    if kind == "dt":
        return SCHEME_ORDER.get(scheme, 2)
    return STOKES_MESH_ORDER.get(stokes, 1.0) if stokes else MESH_ORDER


def analyse(values: list[float | None], nominal: int, ratio: float = 2.0) -> list[dict]:
    """Per level: change from the level before, observed order, the order used and
    the Richardson error estimate (None where they cannot be had); ``ratio`` is the
    refinement factor from one level to the next."""
    rows = []
    for k, q in enumerate(values):
        row = {
            "change": None,
            "order": None,
            "order_used": None,
            "error_estimate": None,
            "extrapolated": None,
        }
        prev = values[k - 1] if k >= 1 else None
        if q is not None and prev is not None:
            row["change"] = q - prev
            older = values[k - 2] if k >= 2 else None
            if older is not None and q != prev and prev != older:
                row["order"] = math.log(abs(prev - older) / abs(q - prev)) / math.log(ratio)
            # an observed order above the nominal one means the levels are not yet in
            # the asymptotic range (the change fell faster than the scheme can make it
            # fall): taken as it is, it would understate the error
            p = (
                min(row["order"], nominal)
                if row["order"] is not None and row["order"] > 0.1
                else nominal
            )
            row["order_used"] = p
            row["error_estimate"] = abs(q - prev) / (ratio**p - 1)
            row["extrapolated"] = q + (q - prev) / (ratio**p - 1)
        rows.append(row)
    return rows


# --- writing -------------------------------------------------------------------------


def _fmt(x, spec=".6g") -> str:
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return ""
    return format(x, spec)


def table_rows(
    plans: dict[str, list[Level]],
    quantities: Sequence[tuple[str, Objective]],
    scheme: str,
    ratio: float = 2.0,
    stokes: str | None = None,
) -> list[dict]:
    rows = []
    for kind, series in plans.items():
        for name, _ in quantities:
            stats = analyse(
                [lv.values.get(name) for lv in series], nominal_order(kind, scheme, stokes), ratio
            )
            for lv, st in zip(series, stats):
                rows.append(
                    {
                        "kind": kind,
                        "level": lv.k,
                        "quantity": name,
                        "folder": str(lv.folder),
                        "status": lv.status,
                        "failure": lv.failure,
                        "dt": lv.dt,
                        "divisions": ("x".join(map(str, lv.divisions)) if lv.divisions else "")
                        + (
                            f", fluid.refine {lv.fluid_refine}"
                            if lv.fluid_refine is not None
                            else ""
                        ),
                        "dofs": lv.dofs,
                        "steps": lv.steps,
                        "newton_iterations": lv.newton,
                        "dt_cuts": lv.cuts,
                        "wall_s": lv.wall,
                        "compile_s": lv.compile,
                        "value": lv.values.get(name),
                        **st,
                    }
                )
    return rows


def write_csv(rows: list[dict], path: Path) -> None:
    with open(path, "w", newline="", encoding="utf-8") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        for row in rows:
            writer.writerow(
                {
                    k: ("" if v is None else repr(v) if isinstance(v, float) else v)
                    for k, v in row.items()
                }
            )


def markdown(rows: list[dict], command: str) -> str:
    lines = ["# Refinement study", "", f"    {command}", ""]
    for kind in dict.fromkeys(r["kind"] for r in rows):
        for name in dict.fromkeys(r["quantity"] for r in rows):
            sel = [r for r in rows if r["kind"] == kind and r["quantity"] == name]
            lines += [
                f"## {name}, refining {kind}",
                "",
                "| level | dt | divisions | unknowns | steps | Newton its | dt cuts | "
                "wall (s) | value | change | observed order | error estimate (order) |",
                "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |",
            ]
            for r in sel:
                if r["status"] != "ok":
                    lines.append(
                        f"| {r['level']} | {_fmt(r['dt'], '.4g')} | {r['divisions']} | "
                        f"{_fmt(r['dofs'], 'd')} | | | | | failed: {r['failure']} "
                        "| | | |"
                    )
                    continue
                est = (
                    f"{_fmt(r['error_estimate'], '.3g')} ({_fmt(r['order_used'], '.2f')})"
                    if r["error_estimate"] is not None
                    else ""
                )
                lines.append(
                    f"| {r['level']} | {_fmt(r['dt'], '.4g')} | {r['divisions']} | "
                    f"{_fmt(r['dofs'], 'd')} | {_fmt(r['steps'], 'd')} | "
                    f"{_fmt(r['newton_iterations'], 'd')} | {_fmt(r['dt_cuts'], 'd')} | "
                    f"{_fmt(r['wall_s'], '.1f')} | {_fmt(r['value'], '.8g')} | "
                    f"{_fmt(r['change'], '.3g')} | {_fmt(r['order'], '.2f')} | {est} |"
                )
            lines.append("")
    return "\n".join(lines)


def plot(rows: list[dict], path: Path) -> bool:
    """Estimated error against wall time (log-log); False if matplotlib is missing
    or there is nothing to draw."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return False
    names = list(dict.fromkeys(r["quantity"] for r in rows))
    fig, axes = plt.subplots(1, len(names), figsize=(5.5 * len(names), 4.2), squeeze=False)
    drawn = False
    for ax, name in zip(axes[0], names):
        for kind in dict.fromkeys(r["kind"] for r in rows):
            pts = [
                (r["wall_s"], r["error_estimate"])
                for r in rows
                if r["quantity"] == name
                and r["kind"] == kind
                and r["status"] == "ok"
                and r["error_estimate"]
                and r["wall_s"]
            ]
            if pts:
                ax.loglog(*zip(*pts), "o-", label=f"refine {kind}")
                drawn = True
        ax.set_xlabel("wall time per run, compilation excluded (s)")
        ax.set_ylabel(f"estimated error of {name}")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend()
    fig.tight_layout()
    if drawn:
        fig.savefig(path, dpi=120)
    plt.close(fig)
    return drawn


# --- command line -----------------------------------------------------------------
