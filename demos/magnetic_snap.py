"""A bistable magnetic arch snapped through by a field: the static equilibrium path
by arc length, and the dynamic snap in a liquid on either side of its limit.

    python3 demos/magnetic_snap.py [--out results/magnetic_snap] [--film] [--mesh N]

1. ``demos/magnetic_snap_path.toml`` (arc length) gives the crown's height
   against the field along the whole path, and from it the two limit fields:
   the snap-through one (the largest field on the upper branch) and the one that
   snaps the inverted arch back (a reversed field, on the lower branch).
2. ``demos/magnetic_snap.toml`` (in drag) ramps the field to 5 % below and 5 %
   above the snap-through limit and holds it: the arch must stay up below and
   snap through above.
3. ``path.png``: the path (field against the crown's displacement), its limit
   points, and the two dynamic runs' (field, crown) histories on it;
   ``summary.md``: the table below.  With ``--film``, ``snap.mp4`` of the run
   above the limit.

``--mesh N`` rewrites ``demos/magnetic_arch.msh`` (the half arch, N nine-node
cells along it, one across) before running; the shipped mesh has N = 16.

Exit status 1 when the run below the limit snaps or the one above does not.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

# the repository's .venv when this python3 lacks rftfem (scripts/repository_python.py)
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))
import repository_python  # noqa: E402

repository_python.ensure()

import numpy as np  # noqa: E402

HERE = Path(__file__).resolve().parent
PATH_SCENE = HERE / "magnetic_snap_path.toml"
SNAP_SCENE = HERE / "magnetic_snap.toml"
MESH = HERE / "magnetic_arch.msh"
#: the half arch: half span, rise, width (mm)
HALF_SPAN, RISE, WIDTH = 10.0, 1.5, 2.0
#: the path scene's field at λ = 1 (mT)
PATH_FIELD = 20.0
#: the dynamic runs' field: ramped from RAMP_START over RAMP (s), then held
RAMP_START, RAMP = 0.3, 1.0


def arch_mesh(path: Path, cells: int = 16) -> Path:
    """The half arch x ≥ 0: a circular arc from the crown (0, 0, RISE) to the end
    (HALF_SPAN, 0, 0), extruded WIDTH along Y; ``cells`` × 1 nine-node cells;
    curves "crown" (x = 0) and "end" (x = HALF_SPAN)."""
    import gmsh

    radius = (HALF_SPAN**2 + RISE**2) / (2 * RISE)
    gmsh.initialize(readConfigFiles=False)
    gmsh.option.setNumber("General.Terminal", 0)
    try:
        geo = gmsh.model.geo
        centre = geo.addPoint(0, 0, RISE - radius)
        arc = geo.addCircleArc(geo.addPoint(0, 0, RISE), centre, geo.addPoint(HALF_SPAN, 0, 0))
        top, surface, at_end, at_crown = geo.extrude(
            [(1, arc)], 0, WIDTH, 0, numElements=[1], recombine=True
        )
        geo.synchronize()
        gmsh.model.mesh.setTransfiniteCurve(arc, cells + 1)
        for dim, tag, name in (
            (2, surface[1], "arch"),
            (1, abs(at_crown[1]), "crown"),
            (1, abs(at_end[1]), "end"),
        ):
            gmsh.model.setPhysicalName(dim, gmsh.model.addPhysicalGroup(dim, [tag]), name)
        gmsh.model.mesh.generate(2)
        gmsh.model.mesh.setOrder(2)
        gmsh.option.setNumber("Mesh.MshFileVersion", 2.2)
        gmsh.write(str(path))
    finally:
        gmsh.finalize()
    return path


def field_formula(b_mT: float) -> list[str]:
    """The dynamic scene's B: ramped to ``b_mT`` over RAMP from RAMP_START, then held
    (``float``: numpy 2 writes a numpy number as ``np.float64(...)``)."""
    b = float(b_mT) * 1e-6
    return ["0", "0", f"{b!r}*min(max((t - {RAMP_START!r})/{RAMP!r}, 0), 1)"]


def run(scene_file: Path, out: Path, changes=None) -> dict:
    """Run ``scene_file`` with ``changes`` (dotted keys to values) into ``out``; its
    probes.csv as arrays by column."""
    import rftfem

    result = rftfem.run(rftfem.load_scene(scene_file, set=changes), out=out)
    return {name: column.to_numpy() for name, column in result.probes.items()}


def limits(path: dict) -> tuple[int, int]:
    """Rows of the snap-through limit (the first maximum of λ) and of the snap-back
    limit (the minimum of λ after it)."""
    lam = path["load_factor"]
    falls = np.flatnonzero(np.diff(lam) < 0)
    top = int(falls[0])
    bottom = top + int(np.argmin(lam[top:]))
    return top, bottom


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out", type=Path, default=Path("results/magnetic_snap"))
    p.add_argument("--film", action="store_true", help="render snap.mp4 of the snapping run")
    p.add_argument(
        "--mesh",
        type=int,
        default=None,
        metavar="N",
        help="rewrite demos/magnetic_arch.msh with N cells along the half arch",
    )
    args = p.parse_args(argv)
    if args.mesh or not MESH.exists():
        arch_mesh(MESH, args.mesh or 16)
    args.out.mkdir(parents=True, exist_ok=True)

    path = run(PATH_SCENE, args.out / "path")
    top, bottom = limits(path)
    b_path = PATH_FIELD * path["load_factor"]
    w_path = path["crown_uz"]
    b_up, b_back = b_path[top], b_path[bottom]
    print(
        f"path: {len(b_path) - 1} arc steps; snap-through limit {b_up:.4f} mT at crown "
        f"uz = {w_path[top]:+.3f} mm; snap-back limit {b_back:+.4f} mT at {w_path[bottom]:+.3f} mm"
    )

    runs = {}
    for factor in (0.95, 1.05):
        name = f"x{factor:g}"
        changes = {"magnetic.field.B": field_formula(factor * b_up)}
        if args.film and factor > 1:
            changes["output.render"] = "mp4"
        probes = run(SNAP_SCENE, args.out / name, changes)
        t, w = probes["time"], probes["crown_uz"]
        snapped = bool(w[-1] < -RISE)
        speed = np.gradient(w, t)
        fastest = int(np.argmin(speed))
        runs[factor] = dict(
            t=t,
            w=w,
            snapped=snapped,
            time=t[fastest],
            field=factor * b_up * np.clip((t - RAMP_START) / RAMP, 0, 1),
        )
        print(
            f"held at {factor:.2f} × the limit ({factor * b_up:.3f} mT): "
            + (
                f"snapped through, fastest at t = {t[fastest]:.3f} s "
                f"({-speed[fastest]:.1f} mm/s); crown ends at {w[-1]:+.3f} mm"
                if snapped
                else f"stays up, crown at {w[-1]:+.3f} mm"
            )
        )
    if args.film and (args.out / "x1.05" / "render.mp4").exists():
        (args.out / "x1.05" / "render.mp4").replace(args.out / "snap.mp4")

    _plot(b_path, w_path, top, bottom, runs, args.out / "path.png")
    ok = runs[1.05]["snapped"] and not runs[0.95]["snapped"]
    lines = [
        "| | field (mT) | crown uz (mm) |",
        "| --- | --- | --- |",
        f"| snap-through limit (arc length) | {b_up:.3f} | {w_path[top]:+.3f} |",
        f"| snap-back limit (arc length) | {b_back:+.3f} | {w_path[bottom]:+.3f} |",
        f"| in drag, held at 0.95 × | {0.95 * b_up:.3f} | "
        f"{'snapped' if runs[0.95]['snapped'] else 'stays up'} |",
        f"| in drag, held at 1.05 × | {1.05 * b_up:.3f} | "
        f"{'snaps at t = %.3f s' % runs[1.05]['time'] if runs[1.05]['snapped'] else 'stays up'} |",
    ]
    (args.out / "summary.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    print(f"wrote {args.out / 'path.png'} and {args.out / 'summary.md'}")
    return 0 if ok else 1


def _plot(b_path, w_path, top, bottom, runs, png):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    ax.plot(w_path, b_path, color="k", lw=1.4, label="equilibrium path (arc length)")
    ax.plot(
        w_path[[top, bottom]], b_path[[top, bottom]], "o", color="tab:red", label="limit points"
    )
    for (factor, r), style in zip(sorted(runs.items(), reverse=True), ("--", ":")):
        ax.plot(
            r["w"], r["field"], lw=1.4, ls=style, label=f"in drag, held at {factor:.2f} × the limit"
        )
    ax.axhline(0.0, color="grey", lw=0.6)
    ax.set_xlabel("crown displacement uz (mm)")
    ax.set_ylabel("field B_z (mT)")
    ax.set_ylim(min(b_path[bottom] * 1.5, -0.5), b_path[top] * 1.6)
    ax.set_title("Magnetic arch: snap-through and back")
    ax.legend(fontsize=8, loc="upper right")
    fig.tight_layout()
    fig.savefig(png, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    sys.exit(main())
