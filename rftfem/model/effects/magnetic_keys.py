"""The scene's ``[magnetic]`` table: the magnetized parts, the applied field and the
permanent magnets (their checks across keys are the component's, magnetic.py)."""

from __future__ import annotations

from typing import Any

from rftfem.model.magnetic_sources import FIELD_KINDS
from rftfem.model.magnets import SOURCE_SCHEMA
from rftfem.scene.bodies import BODY_KEY
from rftfem.scene.schema import (
    NONNEGATIVE,
    Array,
    Bool,
    Formula,
    Formulas,
    Leaf,
    Num,
    Rows,
    Str,
    Table,
    Validator,
    Vec,
    err,
)


class InteractionPoints(Validator):
    """``"auto"`` or ``[q, L]``: Gauss points per cell side (1-4) and through the
    thickness (1-3)."""

    expected = '"auto" or [points per cell side 1-4, points through the thickness 1-3]'

    def __call__(self, value: Any, path: str) -> str | list[int]:
        if value == "auto":
            return value
        if (
            not isinstance(value, list)
            or len(value) != 2
            or any(isinstance(v, bool) or not isinstance(v, int) for v in value)
            or not 1 <= value[0] <= 4
            or not 1 <= value[1] <= 3
        ):
            raise err(path, self.expected, value)
        return list(value)


#: the reference coordinates a part's formulas take
REFERENCE = ("X", "Y", "Z")

SCHEMA = Table(
    {
        "parts": Array(
            Table(
                {
                    "region": Leaf(
                        Str(name=True),
                        required=True,
                        doc='The magnetized region, or "all" (the whole body); a cell '
                        "takes "
                        "one magnetization.",
                    ),
                    "body": BODY_KEY,
                    "magnetization": Leaf(
                        Formula(REFERENCE, NONNEGATIVE),
                        None,
                        unit="current/length",
                        default_doc="required unless `profile` is given",
                        doc="The size of the remanent magnetization: a number "
                        "(0 switches the part off) or a formula of the "
                        "reference coordinates X, Y, Z (a negative value "
                        "reverses the direction there).",
                    ),
                    "direction": Leaf(
                        Formulas(REFERENCE, nonzero=True),
                        None,
                        default_doc="required unless `profile` is given",
                        doc="The magnetization's direction in the reference state "
                        "(normalised), each entry a number or a formula of X, Y, "
                        "Z; it turns with the material fibre.",
                    ),
                    "profile": Leaf(
                        Str(),
                        None,
                        default_doc="none",
                        doc="Instead of `magnetization` and `direction`: a CSV file "
                        "(path relative to the scene file) of rows X,Y,Z,mx,my,mz, "
                        "the remanent magnetization vector at points of a grid "
                        "covering the part, interpolated (multilinear) to the "
                        "part's nodes.",
                    ),
                }
            ),
            min_items=1,
            doc="The magnetized regions of the body.",
        ),
        "interactions": Leaf(
            Bool(),
            False,
            doc="Whether the magnetized parts act on each other: the magnetized volume "
            "is summed as point dipoles of its current moment (`interaction_points`), "
            "and dipoles of different parts or bodies attract, repel and turn each "
            "other (docs/bodies.md). A part does not act on itself.",
        ),
        "interaction_points": Leaf(
            InteractionPoints(),
            "auto",
            doc="The dipoles a magnetized cell is summed as: [q, L], q × q Gauss points "
            "over the cell (1 to 4) and L through the thickness (1 to 3); [1, 1] is one "
            'dipole per cell at its mid-surface. "auto" picks them at the start from how '
            "close the parts are to each other for their cells' size and thickness, "
            "for about 0.1 % (docs/bodies.md).",
        ),
        "interaction_sums": Leaf(
            Str(("auto", "direct", "fmm")),
            "auto",
            doc='How the pairs of dipoles are summed: "direct", compiled sums over every '
            'pair (exact tangent); "fmm", fast multipoles (fmm3dpy), the tangent by a '
            'central difference of the forces. "auto": direct below 100 000 dipoles, '
            "where it is the faster (docs/bodies.md).",
        ),
        "field": Table(
            {
                "kind": Leaf(
                    Str(choices=tuple(FIELD_KINDS)),
                    "rotating",
                    doc='Uniform fields: "rotating" (ramps up along `direction`, '
                    'then turns about `rotation_axis`), "expression" '
                    '(`B`, formulas of t), "table" (`values`). Nonuniform '
                    'fields, whose gradient also pulls the body: "expression" '
                    "with formulas of x, y, z (the current position) and t, "
                    '"dipole" (a point dipole `moment` at `position` or '
                    "moving along `path`).",
                ),
                "strength": Leaf(
                    NONNEGATIVE,
                    None,
                    unit="force/(current·length)",
                    default_doc='0 (kind "rotating")',
                    doc="The size of the applied flux density once ramped up "
                    "(tesla in SI units; 1 mT is 1e-6 N/(A·mm)).",
                ),
                "ramp_time": Leaf(
                    NONNEGATIVE,
                    None,
                    unit="time",
                    default_doc="0",
                    doc="The time the field takes to grow linearly from 0 to "
                    "`strength` along `direction`; 0 starts at full "
                    "strength.",
                ),
                "direction": Leaf(
                    Vec(nonzero=True),
                    None,
                    default_doc="[1, 0, 0]",
                    doc="The field's direction during the ramp and when it starts "
                    "to turn (normalised).",
                ),
                "frequency": Leaf(
                    Num(),
                    None,
                    unit="1/time",
                    default_doc="0",
                    doc="Turns per unit time after `ramp_time` (Hz with "
                    "seconds), right-handed about `rotation_axis`; negative "
                    "turns the other way, 0 keeps the field still.",
                ),
                "rotation_axis": Leaf(
                    Vec(nonzero=True),
                    None,
                    default_doc="[0, 0, 1]",
                    doc="The axis the field turns about (normalised); not "
                    "parallel to `direction` when the frequency is not "
                    "0.",
                ),
                "B": Leaf(
                    Formulas(("x", "y", "z", "t")),
                    None,
                    unit="force/(current·length)",
                    default_doc='required with kind "expression"',
                    doc="The field's three components: numbers or formulas of t "
                    "(uniform), or of x, y, z and t (nonuniform: x is the current "
                    "position of the mid-surface).",
                ),
                "values": Leaf(
                    Rows(("t", "Bx", "By", "Bz")),
                    None,
                    default_doc='required with kind "table"',
                    doc="Rows [t, Bx, By, Bz] with increasing t; the field is held at "
                    "the first and last rows outside them.",
                ),
                "interpolation": Leaf(
                    Str(choices=("linear", "cubic")),
                    None,
                    default_doc='"linear" (kind "table")',
                    doc='Between rows: "linear", or "cubic" (a not-a-knot '
                    "spline, four rows at least).",
                ),
                "moment": Leaf(
                    Vec(nonzero=True),
                    None,
                    unit="current·length²",
                    default_doc='required with kind "dipole"',
                    doc="The source dipole's moment (A·mm² with mm); its flux density "
                    "is μ₀/(4π) (3 r (m·r)/|r|⁵ − m/|r|³), μ₀/(4π) = 1e-7 N/A².",
                ),
                "position": Leaf(
                    Vec(),
                    None,
                    unit="length",
                    default_doc='one of `position`, `path` with kind "dipole"',
                    doc="Where the dipole stays.",
                ),
                "path": Leaf(
                    Rows(("t", "x", "y", "z")),
                    None,
                    unit="time, length",
                    default_doc='one of `position`, `path` with kind "dipole"',
                    doc="Rows [t, x, y, z]: the dipole moves along them (linear in "
                    "between, held at the ends).",
                ),
            },
            doc="The applied field: uniform (it turns the magnetized parts) or "
            "nonuniform (it "
            "also pulls them along its gradient).",
        ),
        "source": SOURCE_SCHEMA,
    },
    optional=True,
    doc="Couples of an applied magnetic field on magnetized (hard-magnetic) regions.",
)
