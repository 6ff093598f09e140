"""The scales of a scene: the drives' periods, and the dimensionless groups that make
a slip of units show (docs/scenes.md "Scales").

- :func:`drive_periods`: every time scale a scene drives its body with (a field's
  frequency, a travelling wave, a ``sin`` of t in a formula, a table's rows);
- :func:`aliasing_warnings`: the drives that ``time.dt`` is too long to follow, one
  line each, which a run prints at its start and keeps in summary.json;
- :func:`groups`: what ``rftfem check`` prints: steps per drive period, L/t, the
  magneto-elastic number, the fluid's relaxation time against the period (the sperm
  number) and the deflection the loads would give over the length.
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass
from typing import Any

import numpy as np

from rftfem.scene.expressions import parse, periods_in_time
from rftfem.scene.validators import fmt

#: a step longer than this share of a drive's period cannot follow it
STEP_SHARE = 0.25
#: table intervals shorter than this share of time.end are jumps on purpose (a load
#: released right after t = 0), not a drive to resolve
JUMP_SHARE = 1e-9


@dataclass(frozen=True)
class Drive:
    """A time scale of the scene: ``key`` the scene key, ``period`` in time units (for
    a table four times its shortest interval), ``what`` the words for a message."""

    key: str
    period: float
    what: str
    table: bool = False


def _table_drive(key: str, rows, end: float) -> Drive | None:
    """A table's drive: its shortest interval within [0, end] (jumps left out), as a
    quarter period: a step longer than it jumps over a row of the table."""
    t = np.asarray([row[0] for row in rows], dtype=float)
    if len(t) < 2:
        return None
    gaps = np.diff(t)
    inside = (t[1:] > 0.0) & (t[:-1] < end) & (gaps > JUMP_SHARE * end)
    if not inside.any():
        return None
    shortest = float(gaps[inside].min())
    return Drive(key, shortest / STEP_SHARE, f"the table's shortest interval, {shortest:.6g}", True)


def drive_periods(scene: dict) -> list[Drive]:
    """Every drive of the scene whose time scale can be read (see the module's text)."""
    end = scene["time"]["end"]
    found: list[Drive] = []
    for i, motion in enumerate(scene.get("motion") or []):
        key = f"motion.{i}"
        if motion.get("kind", "travelling-wave") == "travelling-wave":
            w = motion.get("angular_frequency") or 0.0
            if w:
                found.append(Drive(key, 2 * math.pi / abs(w), "the travelling wave's period"))
        elif motion.get("values"):
            found.append(_table_drive(f"{key}.values", motion["values"], end))
    for i, load in enumerate(scene.get("load") or []):
        if load.get("ramp") == "table" and load.get("table"):
            found.append(_table_drive(f"load.{i}.table", load["table"], end))
    field = (scene.get("magnetic") or {}).get("field") or {}
    kind = field.get("kind", "rotating")
    if kind == "rotating" and field.get("frequency"):
        found.append(
            Drive(
                "magnetic.field.frequency",
                1.0 / abs(field["frequency"]),
                f"the field's rotation period at {fmt(float(field['frequency']))} Hz",
            )
        )
    elif kind == "expression":
        periods = [
            p
            for i, b in enumerate(field.get("B") or [])
            for p in periods_in_time(parse(b, f"magnetic.field.B.{i}", ("x", "y", "z", "t")))
        ]
        if periods:
            found.append(
                Drive("magnetic.field.B", min(periods), "the period of the field's sin or cos of t")
            )
    elif kind == "table" and field.get("values"):
        found.append(_table_drive("magnetic.field.values", field["values"], end))
    elif kind == "dipole" and field.get("path"):
        found.append(_table_drive("magnetic.field.path", field["path"], end))
    return [d for d in found if d is not None]


def aliasing_warnings(scene: dict) -> list[str]:
    """One line for each drive that fixed steps of ``time.dt`` cannot follow: a step
    longer than a quarter of its period, or than a table's shortest interval."""
    time_ = scene["time"]
    if time_.get("scheme") == "arc-length" or time_.get("tolerance") is not None:
        return []
    dt = time_["dt"]
    lines = []
    for d in drive_periods(scene):
        most = STEP_SHARE * d.period
        if dt > most * (1 + 1e-9):
            scale = d.what if d.table else f"a quarter of {d.what}, {d.period:.6g}"
            lines.append(
                f"time.dt = {fmt(dt)} is longer than {scale} ({d.key}): the "
                f"steps cannot follow it and the answer is aliased; take time.dt "
                f"<= {most:.3g}"
            )
    return lines


def _bending_stiffness(model) -> float:
    """``D = E t³ / (12 (1 − ν²))`` of the shell's own values (not its parts'; a field's
    mean), at least the smallest normal float (a thickness of 1e-290 makes t³ zero; the
    groups that divide by D are then huge, not a division by zero)."""
    E, t, nu = (model.material_value(k, "shell") for k in ("E", "thickness", "nu"))
    return max(E * t**3 / (12 * (1 - nu**2)), sys.float_info.min)


def groups(scene: dict, model: Any) -> list[tuple[str, float, str]]:
    """``(name, value, meaning)`` of the scene's dimensionless groups (serial or
    collective: every rank returns the same)."""
    time_ = scene["time"]
    L = model.body.length
    width = model.area() / L
    t = model.material_value("thickness", "shell")
    D = _bending_stiffness(model)
    out = [("L/t", L / t, _slenderness_note(L / t))]
    drives = drive_periods(scene)
    period = min((d.period for d in drives if not d.table), default=None)
    out += _step_groups(drives, time_)
    out += _magnetic_groups(model, time_, L, t, D)
    out += _fluid_groups(model, period, L, D)
    out += _deflection_groups(model, L, D, width)
    out += _material_groups(model)
    out += _contact_groups(model, time_, L, t)
    return out


def _slenderness_note(ratio: float) -> str:
    """The meaning of L/t, with a warning below 5."""
    slender = "slenderness: length over thickness"
    if ratio < 5:
        slender += (
            "; below 5 the body is no thin shell: the thickness's units may be off (µm for mm?)"
        )
    return slender


def _step_groups(drives: list[Drive], time_: dict) -> list[tuple[str, float, str]]:
    """Steps per period of the fastest drive (none for arc-length or no drive)."""
    if not (drives and time_.get("scheme") != "arc-length"):
        return []
    d = min(drives, key=lambda d: d.period)
    return [
        (
            "steps per drive period",
            d.period / time_["dt"],
            f"{d.key}; fewer than 4 alias the drive",
        )
    ]


def _magnetic_groups(
    model: Any, time_: dict, L: float, t: float, D: float
) -> list[tuple[str, float, str]]:
    """The magneto-elastic number of the field at time.end (none without a field)."""
    magnetic = model.get("magnetic")
    if magnetic is None:
        return []
    end = time_["end"]
    B = (
        magnetic.source.scale(end)
        if magnetic.uniform
        else magnetic.source.scale(model.Vu.tabulate_dof_coordinates(), end, model.comm)
    )
    m = max(magnetic._largest_magnetization(i) for i in range(len(magnetic.parts)))
    return [
        (
            "magneto-elastic number",
            t * m * B * L**2 / D,
            "t m B L² / D: the field's couple against bending over the length "
            "(about 1 bends the body by a radian)",
        )
    ]


def _fluid_groups(
    model: Any, period: float | None, L: float, D: float
) -> list[tuple[str, float, str]]:
    """The fluid's relaxation time (over the drive period) and the sperm number."""
    fluid = model.fluid
    if fluid is None:
        return []
    C = max(fluid.C)  # (Stokes flow: the slender-body drag of its viscosity)
    tau = C * L**4 / D
    out = [
        (
            "relaxation time / drive period" if period else "relaxation time",
            tau / period if period else tau,
            "C L⁴ / D, the time the fluid lets a bend of the body's length relax"
            + (_units_note(tau / period) if period else " (time units; no periodic drive)"),
        )
    ]
    if period:
        sperm = (2 * math.pi * tau / period) ** 0.25
        out.append(
            (
                "sperm number",
                sperm,
                "L (C ω / D)^¼: below 1 the body moves rigidly, above 3 the "
                "fluid confines the bending near the driven end" + _units_note(sperm),
            )
        )
    return out


def _deflection_groups(
    model: Any, L: float, D: float, width: float
) -> list[tuple[str, float, str]]:
    """The cantilever deflection of the loads' largest force over the length."""
    force = max(
        (f for comp in model.components for f in comp.force_scales() if comp.is_load), default=0.0
    )
    if not force > 0.0:
        return []
    deflection = force * L**2 / (3 * D * width)
    note = "P L² / (3 D W) of the loads' largest force P: a cantilever's tip"
    if deflection < 1e-5:
        note += "; so small that the units of E or of the loads may be off"
    elif deflection > 1e3:
        note += "; so large that the units of E or of the loads may be off"
    return [("deflection / length", deflection, note)]


def _material_groups(model: Any) -> list[tuple[str, float, str]]:
    """The spread of each material value that varies over the body."""
    out = []
    for key, (lo, hi, mean) in getattr(model, "material_ranges", {}).items():
        if hi > lo:  # a field, or parts that differ
            out.append(
                (
                    f"shell.{key} max/min",
                    hi / lo if lo > 0 else math.inf,
                    f"over the body: {lo:.4g} … {hi:.4g}, mean over its nodes {mean:.4g}",
                )
            )
    return out


def _contact_groups(model: Any, time_: dict, L: float, t: float) -> list[tuple[str, float, str]]:
    """Each contact plane's reach over the thickness and creep over the length."""
    out = []
    contact = model.get("contact")
    for i, plane in enumerate(contact.planes if contact is not None else []):
        out.append(
            (
                f"contact.{i} reach / t",
                plane.reach / t,
                "the barrier's reach δ over the thickness: no point of the lower face "
                "goes deeper than δ below the plane",
            )
        )
        out.append(
            (
                f"contact.{i} slip velocity × end / L",
                plane.slip_velocity * time_["end"] / L,
                "ε_v time.end / L: how far a sticking body may creep in the run, over its length",
            )
        )
    return out


#: a fluid group outside this range is flagged: no swimmer of a shell's proportions has
#: it, and a viscosity in Pa·s instead of N·s/mm² (1e6 times too large) lands there
FLUID_RANGE = (1e-4, 1e4)


def _units_note(value: float) -> str:
    lo, hi = FLUID_RANGE
    if lo <= value <= hi:
        return ""
    return (
        (
            f"; outside {lo:.0e} … {hi:.0e}: units? (the viscosity or drag, or E; "
            "1 mPa·s = 1e-9 N·s/mm²)"
        )
        .replace("e-0", "e-")
        .replace("e+0", "e")
    )


def format_groups(rows: list[tuple[str, float, str]]) -> list[str]:
    """The groups as aligned lines for ``rftfem check``."""
    width = max((len(name) for name, _, _ in rows), default=0)
    return [f"  {name:<{width}}  {value:<10.3g}  {meaning}" for name, value, meaning in rows]
