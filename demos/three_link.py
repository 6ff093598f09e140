"""The paper's three-link swimmer (section 4.2, Tables 3-4, Fig. 8), cases I-IV.

    python3 demos/three_link.py [--out results/three_link] [--cases I II III IV]

Three sheets 5 × 0.5 × 0.2 mm hinged along their long edges swim by lifting and
lowering their outer edges (``demos/three_link.toml``: the stroke, the data and
why).  The paper's four cases differ in the links' stiffness:

    case   E_L   E_M   E_R   strokes
    I      400   400   400   w_L and w_R
    II      40    40   400   w_L and w_R
    III     40    40   400   w_L only (the right edge is free)
    IV       4     4   400   w_L and w_R

The paper attributes the net translation to the stiffness contrast between the
links.  Two dimensionless groups decide what can cause it: the inertia number
ρ t ω / C₃ (≈ 5.5 here: inertia is not negligible) and the elasto-viscous number
Sp = ℓ (C₃ ω / D)^¼ of each link (≪ 1 for every case: the drag hardly bends a
link, so the links move as rigid bodies on their hinges whatever E is).  The
script therefore runs every case twice, with the paper's density and with none
(Stokes regime), so the two causes can be told apart.

Case I has an independent answer: its links hardly bend, so it moves as three
rigid plates with distributed mass on free hinges in the same drag
(``tests/rigid_links.py``, with the corners of the stroke as constraint
impulses).  The script prints case I against it after nine cycles (corner Y,
middle-link centre Z, middle-link angle, centroid Y) and exits 1 if any of them
is off by more than 1 %.

Writes to ``--out``: ``table4.csv`` (reference-corner displacement along Y every
0.4 s, for every case and both densities), ``centroid.csv`` (the body's
centroid along Y at the same times), ``reference.md`` (case I against the
rigid-link reference), ``groups.md`` (the groups per case), ``three_link.png``
(the corner's and the centroid's Y displacement against time, Fig. 8 style),
and one run folder per case (probes, summary, fields).
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
from pathlib import Path

# the repository's .venv when this python3 lacks rftfem (scripts/repository_python.py)
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))
import repository_python  # noqa: E402

repository_python.ensure()

import numpy as np

HERE = Path(__file__).resolve().parent
SCENE = HERE / "three_link.toml"

#: Table 3: E of the left, middle, right link (MPa) and which edges are driven
CASES = {
    "I": ((400.0, 400.0, 400.0), ("w_L", "w_R")),
    "II": ((40.0, 40.0, 400.0), ("w_L", "w_R")),
    "III": ((40.0, 40.0, 400.0), ("w_L",)),
    "IV": ((4.0, 4.0, 400.0), ("w_L", "w_R")),
}
#: the paper's Table 4 (case I): corner displacement along Y (mm) at t = 0.4, 0.8, ...
PAPER_TABLE4 = [
    -0.003758,
    -0.003759,
    -0.003650,
    -0.003648,
    -0.003535,
    -0.003537,
    -0.003420,
    -0.003427,
    -0.003305,
]
PERIOD, CYCLES = 0.4, 9
RHO, T, NU, LINK, C3 = 1.0e-8, 0.2, 0.3, 0.5, 5.67e-9
#: how far case I may lie from the rigid-link reference (relative)
REFERENCE_TOLERANCE = 0.01


def groups(E: float) -> dict:
    omega = 2 * math.pi / PERIOD
    D = E * T**3 / (12 * (1 - NU**2))
    return {"inertia": RHO * T * omega / C3, "Sp": LINK * (C3 * omega / D) ** 0.25}


def run_case(name: str, density: float, out: Path):
    """Run one case; return (times, probe rows (n, 4, 3), centroid Y, summary)."""
    import rftfem

    (EL, EM, ER), driven = CASES[name]
    changes = {"shell.density": density}
    if density == 0.0:
        changes["time.scheme"] = "backward-euler"
    scene = rftfem.load_scene(SCENE, set=changes)
    parts = [
        {"region": r, "E": E, "nu": NU, "thickness": T, "density": density}
        for r, E in (("left", EL), ("middle", EM), ("right", ER))
    ]
    changes = {
        "shell.parts": parts,
        "title": f"Three-link swimmer, case {name}" + ("" if density else ", no inertia"),
    }
    if "w_R" not in driven:
        changes["motion"] = [m for m in scene.raw()["motion"] if m["where"] != "y=W"]
    scene.update(changes)
    result = rftfem.run(scene, out=out)
    probes = result.probes  # time, then corner_ux, corner_uy, corner_uz, centre_ux, ...
    t = probes["time"].to_numpy()
    rows = probes.drop(columns="time").to_numpy().reshape(len(t), -1, 3)
    centroid = result.body["centroid_y"].to_numpy()
    return t, rows, centroid - centroid[0], result.summary


def measures(probes) -> dict:
    """Corner Y, middle centre Z and the middle link's angle about X (from +Y towards
    +Z) of one probe row (corner, centre, hinge_left, hinge_right)."""
    left = np.array([2.5, 0.5, 0.0]) + probes[2]
    right = np.array([2.5, 1.0, 0.0]) + probes[3]
    chord = right - left
    return {
        "corner_y": probes[0][1],
        "centre_z": probes[1][2],
        "angle_middle": math.atan2(chord[2], chord[1]),
    }


def rigid_reference(scene_path: Path = SCENE) -> dict | None:
    """Case I's rigid-link answer after nine cycles (tests/rigid_links.py), or None
    where the repository's tests folder is not beside the demos."""
    tests = HERE.parent / "tests"
    if not (tests / "rigid_links.py").exists():
        return None
    sys.path.insert(0, str(tests))
    try:
        import rigid_links
    finally:
        sys.path.pop(0)
    import tomllib

    scene = tomllib.loads(scene_path.read_text(encoding="utf-8"))
    w_left, w_right = (m["values"] for m in scene["motion"])
    result = rigid_links.simulate(
        w_left, w_right, PERIOD * CYCLES, density=RHO, thickness=T, link_width=LINK
    )
    return result.summary()


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=Path("results/three_link"))
    parser.add_argument("--cases", nargs="+", choices=list(CASES), default=list(CASES))
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)

    marks = [PERIOD * k for k in range(1, CYCLES + 1)]
    table, centroids, curves, failed, last = {}, {}, {}, [], {}
    for name in args.cases:
        for density, label in ((RHO, name), (0.0, f"{name} (no inertia)")):
            folder = f"case_{name}" + ("" if density else "_stokes")
            t, probes, centroid, summary = run_case(name, density, args.out / folder)
            if summary["status"] != "ok":
                failed.append(label)
            y = probes[:, 0, 1]
            curves[label] = (t, y, centroid)
            rows = [int(np.argmin(abs(t - m))) for m in marks]
            table[label] = [float(y[i]) for i in rows]
            centroids[label] = [float(centroid[i]) for i in rows]
            last[label] = {**measures(probes[-1]), "centroid_y": float(centroid[-1])}
            print(
                f"case {label:18s} after nine cycles: corner Y {table[label][-1]:+.6f} mm, "
                f"centroid Y {centroids[label][-1]:+.6f} mm "
                f"({summary['counts']['steps']} steps, {summary['wall_s']['total']:.0f} s)"
            )

    with open(args.out / "table4.csv", "w", newline="", encoding="utf-8") as fh:
        writer = csv.writer(fh)
        writer.writerow(["t", *table, "paper case I"])
        for i, m in enumerate(marks):
            writer.writerow([f"{m:.1f}", *(f"{v[i]:.6f}" for v in table.values()), PAPER_TABLE4[i]])
    lines = [
        "| case | E_L, E_M, E_R (MPa) | inertia ρtω/C₃ | Sp of the links |",
        "|---|---|---|---|",
    ]
    for name in args.cases:
        Es = CASES[name][0]
        sp = ", ".join(f"{groups(E)['Sp']:.3f}" for E in Es)
        lines.append(
            f"| {name} | {', '.join(f'{E:g}' for E in Es)} | "
            f"{groups(Es[0])['inertia']:.2f} | {sp} |"
        )
    (args.out / "groups.md").write_text("\n".join(lines) + "\n", encoding="utf-8")
    print("\n".join(lines))
    with open(args.out / "centroid.csv", "w", newline="", encoding="utf-8") as fh:
        writer = csv.writer(fh)
        writer.writerow(["t", *centroids])
        for i, m in enumerate(marks):
            writer.writerow([f"{m:.1f}", *(f"{v[i]:.6f}" for v in centroids.values())])
    if "I" in last:
        reference = rigid_reference()
        if reference is None:
            print("tests/rigid_links.py not found: case I not compared with the rigid links")
        else:
            lines = [
                "| after nine cycles | case I | rigid links | difference |",
                "|---|---|---|---|",
            ]
            for key, what in (
                ("corner_y", "corner Y (mm)"),
                ("centre_z", "centre Z (mm)"),
                ("angle_middle", "middle-link angle (rad)"),
                ("centroid_y", "centroid Y (mm)"),
            ):
                ours, ref = last["I"][key], reference[key]
                rel = ours / ref - 1
                # the centroid hardly moves: it is compared against the corner's scale
                off = (
                    abs(ours - ref) / abs(reference["corner_y"])
                    if key == "centroid_y"
                    else abs(rel)
                )
                lines.append(f"| {what} | {ours:+.6f} | {ref:+.6f} | {100 * rel:+.2f} % |")
                if off > REFERENCE_TOLERANCE:
                    failed.append(
                        f"case I {what} off the rigid-link reference by {100 * off:.2f} %"
                    )
            (args.out / "reference.md").write_text("\n".join(lines) + "\n", encoding="utf-8")
            print("\n".join(lines))
    _plot(curves, args.out / "three_link.png")
    print(
        f"wrote {args.out / 'table4.csv'}, centroid.csv, reference.md, groups.md and three_link.png"
    )
    # a picture and a film of the first case, drawn as `rftfem render` draws them
    draw_picture_and_film(args.out / f"case_{args.cases[0]}", "swimmer", view="follow")
    if failed:
        print("failed: " + "; ".join(failed))
        return 1
    return 0


def draw_picture_and_film(folder: Path, stem: str, **options) -> None:
    """``STEM.png`` (the last frame) and ``STEM.mp4`` (the whole run) in ``folder``, by
    ``rftfem.Result.render`` (``options``: render's, e.g. ``view="follow"``). A failure
    is reported, not raised: the numbers of a demo matter more than its pictures."""
    import rftfem

    for suffix in (".png", ".mp4"):
        out = folder / f"{stem}{suffix}"
        try:
            rftfem.Result(folder).render(out, **options)
            print(f"drew {out}")
        except Exception as exc:  # noqa: BLE001 (whatever stopped the drawing, say it)
            print(f"could not draw {out}: {exc}")


def _plot(curves, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax, bx) = plt.subplots(1, 2, figsize=(11, 4))
    for label, (t, y, centroid) in curves.items():
        style = "-" if "no inertia" not in label else ":"
        ax.plot(t, 1e3 * y, ls=style, label=f"case {label}")
        bx.plot(t, 1e3 * centroid, ls=style, label=f"case {label}")
    ax.plot(
        [PERIOD * k for k in range(1, CYCLES + 1)],
        [1e3 * v for v in PAPER_TABLE4],
        "kx",
        label="paper, case I (Table 4)",
    )
    ax.set_xlabel("t (s)")
    ax.set_ylabel("corner displacement along Y (µm)")
    ax.set_title("the corner (0, 0): the chain folding")
    bx.set_xlabel("t (s)")
    bx.set_ylabel("centroid displacement along Y (µm)")
    bx.set_title("the centroid: what the body swims")
    ax.legend(fontsize=7, ncol=2)
    fig.suptitle("Three-link swimmer, out-and-back stroke, A = 0.1 mm")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    sys.exit(main())
