"""Sze, Liu & Lo (2004) problem 3.5: the pull-out of an open-ended cylinder, as an
octant with three planes of symmetry.

The cylinder (length L = 10.35, radius R = 4.953, thickness t = 0.094, E = 10.5e6,
ν = 0.3125, both ends free) is pulled by two opposite radial point forces P at
mid-length, up to Pmax = 40 000. The octant modelled here has its axis along Y:

- x² + z² = R², x ≥ 0, z ≥ 0, 0 ≤ y ≤ L/2; the mid-length circle y = 0 and the two
  generatrices in the planes x = 0 and z = 0 are planes of symmetry, the arc
  y = L/2 is the free edge;
- A = (0, 0, R): the load point, on two of the planes, so it carries P/4 along +Z;
- B = (R, 0, 0): at mid-length, 90° from A; C = (R, L/2, 0): on the free edge,
  90° from A. The radial displacement there is u_x, and both move inward.

Used as a script it writes the mesh and the scene into a folder:

    python tests/pullout.py OUT_DIR [--n-circ N] [--n-axial M] [--dt DT] ...
    rftfem run OUT_DIR/pullout.toml --out RESULTS

and ``python tests/pullout.py --compare RESULTS`` prints the probes against the
table.
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

from test_curved_shells import _gmsh, _name_mesh_write

#: the benchmark's data
LENGTH, RADIUS, THICKNESS = 10.35, 4.953, 0.094
E, NU, P_MAX = 10.5e6, 0.3125, 40000.0

#: the probes' reference coordinates in the octant (see the module's docstring);
#: "D" is the free edge's point above A, not in the table
POINTS = {
    "A": (0.0, 0.0, RADIUS),
    "B": (RADIUS, 0.0, 0.0),
    "C": (RADIUS, LENGTH / 2, 0.0),
    "D": (0.0, LENGTH / 2, RADIUS),
}

SZE_PULLOUT = {
    0.025: (0.819, 0.864, 0.872),
    0.05: (1.260, 1.471, 1.493),
    0.075: (1.527, 1.901, 1.946),
    0.10: (1.707, 2.217, 2.293),
    0.15: (1.936, 2.641, 2.792),
    0.20: (2.079, 2.904, 3.106),
    0.25: (2.180, 3.087, 3.310),
    0.30: (2.257, 3.227, 3.452),
    0.35: (2.321, 3.342, 3.556),
    0.40: (2.376, 3.443, 3.632),
    0.45: (2.425, 3.539, 3.688),
    0.50: (2.473, 3.653, 3.718),
    0.525: (2.543, 4.061, 3.580),
    0.55: (2.577, 4.171, 3.518),
    0.60: (2.618, 4.274, 3.452),
    0.65: (2.648, 4.338, 3.410),
    0.70: (2.672, 4.385, 3.378),
    0.75: (2.692, 4.423, 3.353),
    0.80: (2.710, 4.455, 3.332),
    0.85: (2.726, 4.483, 3.313),
    0.90: (2.741, 4.508, 3.297),
    0.95: (2.755, 4.530, 3.283),
    1.00: (2.768, 4.551, 3.269),
}
"""Sze, Liu & Lo, "Popular benchmark problems for geometric nonlinear analysis of
shells", Finite Elements in Analysis and Design 40 (2004) 1551–1569, problem 3.5
(ABAQUS S4R, 24 × 36 elements on the octant): P/Pmax -> (W_A, −U_B, −U_C), the
outward radial displacement at the load point A and the inward radial
displacements at B and C. Taken from the table as MBDyn's test suite quotes it,
repository zanoni-mbdyn/MBDyn, tests/plates/sze2004/sze35/sze35_ref.dat (columns
"P/Pmax wA -uB -uC"); the point names follow that suite's model
(tests/plates/sze2004/sze35/sze35.awk): B at mid-length and C on the free edge,
both 90° round from A. The snap-through lies between 0.50 and 0.525, where −U_B
jumps by 0.41 and −U_C turns back."""


def octant_cylinder(path: Path, n_circ: int, n_axial: int) -> Path:
    """The octant x² + z² = R², x, z ≥ 0, 0 ≤ y ≤ L/2 with n_circ × n_axial 9-node
    quadrilaterals (n_circ round the quarter circle, n_axial along the half
    length); curves "sym_x" (the generatrix in the plane x = 0, through A), "sym_z"
    (in z = 0, through B and C), "mid" (the arc y = 0), "free" (the arc y = L/2),
    and the point "A" (0, 0, R), the load point."""
    gmsh = _gmsh()
    try:
        geo = gmsh.model.geo
        centre = geo.addPoint(0, 0, 0)
        a = geo.addPoint(0, 0, RADIUS)
        arc = geo.addCircleArc(geo.addPoint(RADIUS, 0, 0), centre, a)
        out = geo.extrude([(1, arc)], 0, LENGTH / 2, 0, numElements=[n_axial], recombine=True)
        geo.synchronize()
        gmsh.model.mesh.setTransfiniteCurve(arc, n_circ + 1)
        groups = (
            (2, out[1][1], "shell"),
            (1, abs(out[2][1]), "sym_x"),
            (1, abs(out[3][1]), "sym_z"),
            (1, arc, "mid"),
            (1, out[0][1], "free"),
            (0, a, "A"),
        )
        _name_mesh_write(gmsh, groups, path)
    finally:
        gmsh.finalize()
    return path


def scene_text(
    mesh_file: str = "pullout.msh",
    dt: float = 0.05,
    end: float = 1.0,
    solver: dict | None = None,
    title: str | None = None,
) -> str:
    """The TOML scene of the octant under load control: the force at A ramps
    linearly to P/4 · end / 1 at t = end (so t is P/Pmax), in static steps of dt;
    ``solver`` adds a [solver] table (PETSc options, e.g. {"snes_max_it": 200})."""
    solver_table = ""
    if solver:
        lines = [
            f"{k} = {v!r}" if not isinstance(v, str) else f'{k} = "{v}"' for k, v in solver.items()
        ]
        solver_table = "[solver]\n" + "\n".join(lines) + "\n"
    probes = "".join(
        f'[[output.probes]]\nname = "{name}"\nat = [{x!r}, {y!r}, {z!r}]\n'
        for name, (x, y, z) in POINTS.items()
    )
    return f"""title = "{title or "pull-out of an open-ended cylinder (Sze 3.5), an octant"}"
[mesh]
kind = "gmsh"
file = "{mesh_file}"
[shell]
thickness = {THICKNESS!r}
E = {E!r}
nu = {NU!r}
axis = [0.0, 1.0, 0.0]
{solver_table}[time]
scheme = "static"
end = {end!r}
dt = {dt!r}
[[boundary]]
where = "sym_x"
symmetry = [1.0, 0.0, 0.0]
[[boundary]]
where = "sym_z"
symmetry = [0.0, 0.0, 1.0]
[[boundary]]
where = "mid"
symmetry = [0.0, 1.0, 0.0]
[[load]]
kind = "point-force"
at = [0.0, 0.0, {RADIUS!r}]
value = [0.0, 0.0, {P_MAX / 4 * end!r}]
{probes}"""


def radial(rows: dict) -> tuple:
    """(W_A, −U_B, −U_C) from a probes.csv row (a dict of its columns)."""
    return (float(rows["A_uz"]), -float(rows["B_ux"]), -float(rows["C_ux"]))


def compare(results: Path, times=None) -> list[tuple]:
    """Rows (P/Pmax, computed (W_A, −U_B, −U_C), reference, relative errors) for the
    table's load levels that the run in ``results`` wrote."""
    with open(Path(results) / "probes.csv") as f:
        rows = {round(float(r["time"]), 9): r for r in csv.DictReader(f)}
    out = []
    for p, ref in SZE_PULLOUT.items():
        if times is not None and p not in times:
            continue
        row = rows.get(round(p, 9))
        if row is None:
            continue
        got = radial(row)
        out.append((p, got, ref, tuple(g / r - 1 for g, r in zip(got, ref))))
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "out",
        type=Path,
        help="folder for pullout.msh and pullout.toml (or, with --compare, a results folder)",
    )
    parser.add_argument("--n-circ", type=int, default=8)
    parser.add_argument("--n-axial", type=int, default=8)
    parser.add_argument("--dt", type=float, default=0.05)
    parser.add_argument("--snes-max-it", type=int, default=None)
    parser.add_argument(
        "--compare",
        action="store_true",
        help="print the probes of the results folder OUT against the table",
    )
    args = parser.parse_args(argv)
    if args.compare:
        print("P/Pmax   W_A (ref)           -U_B (ref)          -U_C (ref)")
        for p, got, ref, err in compare(args.out):
            print(
                f"{p:6.3f}  "
                + "  ".join(f"{g:.4f} ({r:.3f} {100 * e:+.2f}%)" for g, r, e in zip(got, ref, err))
            )
        return 0
    args.out.mkdir(parents=True, exist_ok=True)
    octant_cylinder(args.out / "pullout.msh", args.n_circ, args.n_axial)
    solver = {"snes_max_it": args.snes_max_it} if args.snes_max_it else None
    (args.out / "pullout.toml").write_text(scene_text(dt=args.dt, solver=solver))
    print(args.out / "pullout.toml")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
