"""The time table's rules that depend on the rest of the scene: which scheme
``time.scheme = "auto"`` resolves to, whether the body has inertia, and the period
of ``time.until = "periodic"`` with its checks.  Reading a scene applies them
(rftfem.scene.keys, rftfem.scene.reading); the time loop and the effects read
their answers (integration/schemes.py, integration/steady.py, effects/inertia.py).
"""

from __future__ import annotations

import math

from rftfem.errors import SceneError
from rftfem.scene.validators import fmt

#: the schemes of static runs, whose outputs carry the load factor
STATIC_SCHEMES = ("static", "arc-length")


def has_density(scene: dict) -> bool:
    """Whether ``shell.density`` or some ``shell.parts`` density is above 0."""
    shell = scene.get("shell") or {}

    def positive(value) -> bool:  # a formula or profile (>= 0, checked): somewhere > 0
        return isinstance(value, (str, dict)) or (value or 0.0) > 0.0

    return positive(shell.get("density")) or any(
        positive(part.get("density")) for part in shell.get("parts") or []
    )


def resolved_scheme(scene: dict) -> str:
    """``time.scheme`` with "auto" resolved: second order with inertia, first
    order with drag only, load stepping otherwise."""
    scheme = (scene.get("time") or {}).get("scheme", "auto")
    inertia = has_density(scene)
    if scheme == "auto":
        if inertia:
            return "generalized-alpha"
        return "backward-euler" if scene.get("fluid") else "static"
    if scheme == "static" and scene.get("fluid"):
        raise SceneError(
            'time.scheme: "static" has no velocity, so the [fluid] drag would '
            'do nothing; use "backward-euler", "generalized-alpha" (with '
            'density) or "auto", or remove [fluid]'
        )
    if scheme == "arc-length" and scene.get("fluid"):
        raise SceneError(
            'time.scheme: "arc-length" follows a static equilibrium path, '
            "and the [fluid] drag is a force of motion; remove [fluid] or use "
            "a scheme in time"
        )
    if scheme in ("generalized-alpha", "hht") and not inertia:
        raise SceneError(
            f'time.scheme: "{scheme}" needs inertia (shell.density > 0 or a '
            "shell.parts density > 0), found shell.density = "
            f"{fmt((scene.get('shell') or {}).get('density', 0.0))}; use "
            '"backward-euler", "static" or "auto"'
        )
    return scheme


def scene_period(scene: dict) -> float:
    """The period of ``time.until = "periodic"``: ``time.period``, else the one the
    travelling-wave motions share, else the rotating field's 1/frequency."""
    time_ = scene["time"]
    if time_.get("period") is not None:
        return float(time_["period"])
    found = {}
    for i, motion in enumerate(scene.get("motion") or []):
        w = motion.get("angular_frequency") or 0.0
        if motion.get("kind", "travelling-wave") == "travelling-wave" and w != 0.0:
            found[f"motion.{i}"] = 2 * math.pi / abs(w)
    field = (scene.get("magnetic") or {}).get("field") or {}
    if field.get("kind", "rotating") == "rotating" and (field.get("frequency") or 0.0) != 0.0:
        found["magnetic.field"] = 1.0 / abs(field["frequency"])
    if not found:
        raise SceneError(
            'time.until = "periodic": no period in the scene (a travelling-wave '
            "motion or a rotating field); give time.period"
        )
    periods = list(found.values())
    if max(periods) > min(periods) * (1 + 1e-9):
        raise SceneError(
            'time.until = "periodic": the drivers have different periods ('
            + ", ".join(f"{k}: {fmt(v)}" for k, v in found.items())
            + "); give time.period"
        )
    return periods[0]


def check_periodic(scene: dict) -> None:
    """``time.until = "periodic"``: the period is found and is a whole number of steps
    and of output rows; ``time.period`` only with it."""
    time_ = scene["time"]
    if time_.get("until", "end") != "periodic":
        for key in ("period",):
            if time_.get(key) is not None:
                raise SceneError(f'time.{key}: only used with time.until = "periodic"')
        return
    if time_.get("tolerance") is not None:
        raise SceneError('time.until = "periodic" takes fixed steps; remove time.tolerance')
    scheme = resolved_scheme(scene)
    if scheme in ("static", "arc-length"):
        raise SceneError(
            f'time.until = "periodic" needs a run in time, found time.scheme = "{scheme}"'
        )
    period = scene_period(scene)
    steps = period / time_["dt"]
    if abs(steps - round(steps)) > 1e-6 * steps or round(steps) < 1:
        raise SceneError(
            f"time.dt: expected a whole fraction of the period {fmt(period)} "
            f'(time.until = "periodic"), found {fmt(time_["dt"])} '
            f"({steps:.6g} steps a period)"
        )
    if round(steps) % time_["output_every"]:
        raise SceneError(
            f"time.output_every: expected a divisor of the {round(steps)} steps "
            f'of a period (time.until = "periodic"), found {time_["output_every"]}'
        )
