"""The scene's ``[[contact]]`` entries: their keys, defaults and the friction
coefficient's validator (the checks across keys and against the body are the
component's, contact.py)."""

from __future__ import annotations

import math
from typing import Any

from rftfem.scene.schema import Array, Leaf, Str, Table, Validator, Vec, err, fmt
from rftfem.scene.validators import POSITIVE


class Coefficient(Validator):
    """A friction coefficient ≥ 0: one number, or ``[forward, backward, sideways]``."""

    expected = "a number >= 0 or [forward, backward, sideways], numbers >= 0"

    def __call__(self, value: Any, path: str) -> float | list[float]:
        if isinstance(value, list):
            if len(value) != 3:
                raise err(path, self.expected, value)
            out = []
            for i, v in enumerate(value):
                if (
                    isinstance(v, bool)
                    or not isinstance(v, (int, float))
                    or not math.isfinite(float(v))
                    or v < 0
                ):
                    raise err(path, self.expected, value, f" (entry {i}: {fmt(v)})")
                out.append(float(v))
            return out
        if (
            isinstance(value, bool)
            or not isinstance(value, (int, float))
            or not math.isfinite(float(value))
            or value < 0
        ):
            raise err(path, self.expected, value)
        return float(value)


def triple(mu: float | list[float]) -> list[float]:
    """A coefficient as [forward, backward, sideways]."""
    return list(mu) if isinstance(mu, list) else [float(mu)] * 3


SCHEMA = Array(
    Table(
        {
            "kind": Leaf(
                Str(("plane",)),
                required=True,
                doc='What the body touches: "plane", an infinite plane.',
            ),
            "body": Leaf(
                Str(name=True),
                None,
                default_doc="every body",
                doc="The [[body]] the plane acts on; without it the plane acts on every body.",
            ),
            "point": Leaf(Vec(), required=True, unit="length", doc="A point of the plane."),
            "normal": Leaf(
                Vec(nonzero=True),
                required=True,
                doc="The plane's normal, pointing to the side the body stays on "
                "(any length; normalised).",
            ),
            "friction": Leaf(
                Coefficient(),
                0.0,
                doc="The kinetic Coulomb coefficient μ_k: one number, or [forward, "
                "backward, sideways] for slip along +shell.axis, along −shell.axis "
                "and across it (the axis as the body carries it, projected on "
                "the plane). 0: frictionless.",
            ),
            "static_friction": Leaf(
                Coefficient(),
                None,
                default_doc="equal to `friction`",
                doc="The static coefficient μ_s (same shapes as `friction`): "
                "the friction force reaches μ_s times the pressure at slip "
                "speed `slip_velocity`, and falls to μ_k beyond it "
                "(docs/contact.md §2).",
            ),
            "distance": Leaf(
                POSITIVE,
                None,
                unit="length",
                default_doc="0.1 × the thinnest shell thickness",
                doc="The barrier's reach δ: it pushes on the lower face within δ "
                "of the plane, on either side; a face pressed with the reference "
                "pressure rests on the plane, a lighter one floats less than δ "
                "above it, and none goes deeper than δ below it (while the "
                "pressure stays under ~850 times the reference).",
            ),
            "stiffness": Leaf(
                POSITIVE,
                None,
                unit="force/length³",
                default_doc="the reference pressure / ((2 ln 2 + 1) δ)",
                doc="The barrier's stiffness κ in the pressure −κ b′(g + δ). The "
                "default makes the reference pressure (the body's weight along the "
                "plane's normal over the area of its lower face within reach at the "
                "start; without gravity the bending pressure D t / L⁴) rest the face "
                "on the plane (docs/contact.md §1).",
            ),
            "slip_velocity": Leaf(
                POSITIVE,
                None,
                unit="length/time",
                default_doc="1e-3 × the body's diagonal / the shortest drive "
                "period (time.end without a periodic drive)",
                doc="The velocity scale ε_v of the smoothed stick–slip law: below "
                "it the friction force grows from 0 to μ_s times the pressure "
                "(a sticking body creeps slower than ε_v); above it it falls "
                "to μ_k within a few ε_v.",
            ),
        }
    ),
    doc="Planes the body touches with its lower face (the mid-surface less half the "
    "thickness along the director): a barrier keeps it from crossing them, Coulomb "
    "friction resists its slip (docs/contact.md).",
)
