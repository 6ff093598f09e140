"""The bidirectional magnetic strip of the paper's section 4.3 (docs/verification.md case I).

A strip with oppositely magnetized ends sits in a field that first ramps along
+X (phase 1): the anti-aligned end flips over and the strip takes a chiral
shape.  Then the field rotates about Z (phase 2) and the strip swims along Z.
Ramping along −X instead flips the other end, gives the shape of opposite hand,
and the strip swims the other way.  ``demos/bidirectional_strip.toml`` explains
the parameters; this script runs both protocols and shows the three behaviours:

* ``shape_phase1.png``: the strip at the end of phase 1, both protocols;
* ``trajectory.png`` and ``trajectory.csv``: the centroid along the rotation axis
  at each output time (body.csv);
* ``groups.md``: the magneto-elastic number, the sperm number, and the
  rigid-rotor step-out estimate of the phase-1 shape, ``f_c = |Q⊥| B / (2π ζ)``,
  with Q the total magnetic moment and ζ the RFT drag of a rigid rotation about
  the axis (both computed on the deformed shape);
* with ``--sweep DIR``: the speed-against-frequency plot of the runs that
  ``demos/strip_sweep.sh`` made in DIR, with the speed peak and the stepped-out
  runs (the moment loses turns against the field) marked (``sweep.png``).

    python3 demos/bidirectional_strip.py                     # both protocols
    python3 demos/bidirectional_strip.py --set mesh.divisions=[10,2]
    mpirun -n 2 python3 demos/bidirectional_strip.py
    demos/strip_sweep.sh                                     # then it calls --sweep

Exit status 1 when the two protocols do not swim in opposite senses with net
displacements over the last two field periods within 5 % of each other.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import sys
import tomllib
from pathlib import Path

# the repository's .venv when this python3 lacks rftfem (scripts/repository_python.py)
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))
import repository_python  # noqa: E402

repository_python.ensure()

import numpy as np

HERE = Path(__file__).resolve().parent
SCENE = HERE / "bidirectional_strip.toml"
PROTOCOLS = {"+X": [1.0, 0.0, 0.0], "-X": [-1.0, 0.0, 0.0]}
#: seconds after the ramp before a sweep run's speed is measured (strip_sweep.sh)
SETTLE = 0.1
#: slip (turns lost per field turn) above which a run counts as stepped out
STEPPED_OUT_SLIP = 0.05


# --- the dimensionless groups ------------------------------------------------------


def groups(scene: dict) -> dict:
    """Magneto-elastic number ``Mn = m B t A_end L / (D W)`` (one end's couple
    against the strip's bending stiffness, per length) and sperm number
    ``Sp = L (C₃ ω / D)^¼`` at the scene's frequency; D = E t³ / (12 (1 − ν²))."""
    shell, mesh, field = scene["shell"], scene["mesh"], scene["magnetic"]["field"]
    t, L, W = shell["thickness"], mesh["length"], mesh["width"]
    D = shell["E"] * t**3 / (12 * (1 - shell["nu"] ** 2))
    part = scene["magnetic"]["parts"][0]
    region = next(r for r in mesh["regions"] if r["name"] == part["region"])
    end_area = (region["x"][1] - region["x"][0]) * W
    couple = part["magnetization"] * field["strength"] * t * end_area
    omega = 2 * math.pi * field.get("frequency", 0.0)
    return {
        "magneto_elastic_number": couple * L / (D * W),
        "sperm_number": L * (scene["fluid"]["drag"][2] * omega / D) ** 0.25,
        "end_couple_Nmm": couple,
    }


def parse_set(text: str) -> tuple[str, object]:
    """``KEY=VALUE`` of ``--set`` as ``rftfem run`` reads it: VALUE is TOML, else a bare word."""
    key, _, value = text.partition("=")
    try:
        return key.strip(), tomllib.loads(f"v = {value}")["v"]
    except tomllib.TOMLDecodeError:
        return key.strip(), value.strip()


def run_protocol(name: str, overrides: list[str], out: Path, comm):
    """One protocol in-process (on every rank of ``comm``); returns its rftfem.Result
    and scene."""
    import rftfem

    changes = {"title": f"Bidirectional magnetic strip (paper section 4.3), field along {name}"}
    changes.update(parse_set(text) for text in overrides)
    changes["magnetic.field.direction"] = PROTOCOLS[name]
    scene = rftfem.load_scene(SCENE, set=changes)
    return rftfem.run(scene, out=out / f"protocol{name}", comm=comm), scene


def unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def rotational_drag(mesh, C, material_axis, axis, centre) -> float:
    """The RFT drag coefficient ζ of a rigid rotation of a written shape about
    ``axis`` through ``centre``: ``ζ = ∫ (C̃ v)·v dA`` over the deformed mid-surface
    with ``v = a × (x − centre)`` and ``C̃ = Σ Cᵢ eᵢ⊗eᵢ`` in the drag's frame (e₁ the
    material axis carried by the deformation, e₃ the normal; docs/model.md §5.4).
    ``mesh`` is ``Result.fields``' (nine-node quadrilaterals: the solution's degree),
    integrated with the run's own rule (3 × 3 Gauss points a cell), so ζ is what the
    run's drag gives, to round-off; NaN for a mesh of other cells."""
    if set(mesh.celltypes.tolist()) != {28}:  # VTK_BIQUADRATIC_QUAD
        return math.nan
    cells = mesh.cells.reshape(-1, 10)[:, 1:]
    X = np.asarray(mesh.points)[cells]
    x = X + np.asarray(mesh.point_data["displacement"])[cells]
    # VTK's node order (corners, edge midpoints, centre) on the grid (0, 1/2, 1)²
    ij = np.array([(0, 0), (2, 0), (2, 2), (0, 2), (1, 0), (2, 1), (1, 2), (0, 1), (1, 1)])

    def lagrange(s):  # the quadratic shape functions at 0, 1/2, 1 and their derivatives
        return (
            np.array([2 * (s - 0.5) * (s - 1), -4 * s * (s - 1), 2 * s * (s - 0.5)]),
            np.array([4 * s - 3, 4 - 8 * s, 4 * s - 1]),
        )

    points, weights = np.polynomial.legendre.leggauss(3)
    a, zeta = unit(axis), 0.0
    for p, wp in zip((points + 1) / 2, weights / 2):
        for q, wq in zip((points + 1) / 2, weights / 2):
            (lp, dp), (lq, dq) = lagrange(p), lagrange(q)
            N, Np, Nq = (f[ij[:, 0]] * g[ij[:, 1]] for f, g in ((lp, lq), (dp, lq), (lp, dq)))
            G = np.stack([Np @ X, Nq @ X], axis=-1)  # reference tangents, (cells, 3, 2)
            g = np.stack([Np @ x, Nq @ x], axis=-1)  # current tangents
            normal = np.cross(g[..., 0], g[..., 1])
            area = np.linalg.norm(normal, axis=-1)
            along = np.linalg.pinv(G) @ np.asarray(material_axis, dtype=float)
            e1 = unit(np.einsum("cij,cj->ci", g, along))  # F E₁ (E₁ made tangent)
            e3 = normal / area[:, None]
            v = np.cross(a, N @ x - centre)
            power = sum(
                c * np.einsum("ck,ck->c", v, e) ** 2 for c, e in zip(C, (e1, np.cross(e3, e1), e3))
            )
            zeta += wp * wq * float(power @ area)
    return zeta


def phase1(result, scene) -> tuple[np.ndarray, float]:
    """At the end of phase 1 (the written time nearest the ramp's end): the shape (the
    points of the deformed mid-surface) and the rigid-rotor step-out estimate
    ``f_c = |Q⊥| B / (2π ζ)`` of that shape, Q from body.csv."""
    field = scene["magnetic.field"]
    axis = unit(field["rotation_axis"])
    mesh = result.fields(field["ramp_time"])
    body = result.body
    row = body.iloc[int(np.argmin(abs(body["time"].to_numpy() - mesh.field_data["time"][0])))]
    Q = row[["moment_x", "moment_y", "moment_z"]].to_numpy(dtype=float)
    centre = row[["centroid_x", "centroid_y", "centroid_z"]].to_numpy(dtype=float)
    zeta = rotational_drag(mesh, result.summary["fluid"]["drag"], scene["shell.axis"], axis, centre)
    q_perp = np.linalg.norm(Q - (Q @ axis) * axis)
    shape = np.asarray(mesh.points) + np.asarray(mesh.point_data["displacement"])
    return shape, q_perp * field["strength"] / zeta / (2 * math.pi)


def centroid_path(result) -> tuple[np.ndarray, np.ndarray]:
    """The centroid at each output time (body.csv): times (n,) and positions (n, 3)."""
    body = result.body
    return (body["time"].to_numpy(), body[["centroid_x", "centroid_y", "centroid_z"]].to_numpy())


def net_displacement(t, c, axis, t0: float, t1: float) -> float:
    """Centroid displacement along ``axis`` between the rows nearest t0 and t1."""
    i0, i1 = int(np.argmin(abs(t - t0))), int(np.argmin(abs(t - t1)))
    return float((c[i1] - c[i0]) @ axis)


# --- plots -------------------------------------------------------------------------


def plot_shapes(shapes: dict, path: Path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig = plt.figure(figsize=(9, 4.5))
    for k, (name, x) in enumerate(shapes.items()):
        ax = fig.add_subplot(1, 2, k + 1, projection="3d")
        ax.scatter(x[:, 0], x[:, 1], x[:, 2], c=x[:, 2], cmap="coolwarm", s=6)
        c, half = x.mean(axis=0), 0.6 * np.ptp(x, axis=0).max()
        ax.set_xlim(c[0] - half, c[0] + half)
        ax.set_ylim(c[1] - half, c[1] + half)
        ax.set_zlim(c[2] - half, c[2] + half)
        ax.set_title(f"field along {name}: end of phase 1")
        ax.set_xlabel("x (mm)")
        ax.set_ylabel("y (mm)")
        ax.set_zlabel("z (mm)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def plot_trajectories(curves: dict, ramp: float, path: Path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4))
    for name, (t, z) in curves.items():
        ax.plot(t, z, label=f"field ramped along {name}")
    ax.axvline(ramp, color="grey", ls=":", lw=1)
    ax.text(ramp, ax.get_ylim()[1], " rotation starts", va="top", fontsize=8, color="grey")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("centroid along the rotation axis (mm)")
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)


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


# --- the frequency sweep -----------------------------------------------------------


def sweep_row(folder: Path, settle: float = SETTLE) -> dict:
    """The speed along the axis, the mean slip of the moment behind the field (turns
    per field turn) from ``settle`` seconds after the ramp to the end of the run,
    and the run's status (a failed run is measured up to where it stopped, and
    marked).  The speed of a run that became steady (``time.until = "periodic"``)
    is its steady centroid rate along the axis (summary.json); otherwise the mean
    over that window, which the strip's curling after the ramp still biases: it
    moves the centroid along the axis by millimetres in the first periods (at
    4 Hz the window 0.2-2.1 s reads −3.6 mm/s where the steady speed is −1.57)."""
    summary = json.loads((folder / "summary.json").read_text())
    scene = summary["scene"]
    field = scene["magnetic"]["field"]
    axis = np.asarray(field["rotation_axis"], dtype=float)
    axis /= np.linalg.norm(axis)
    with open(folder / "body.csv", encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    t = np.array([float(r["time"]) for r in rows])
    c = np.array([[float(r[f"centroid_{k}"]) for k in "xyz"] for r in rows])
    b = np.array([[float(r[f"field_{k}"]) for k in "xyz"] for r in rows])
    q = np.array([[float(r[f"moment_{k}"]) for k in "xyz"] for r in rows])
    window = t >= field["ramp_time"] + settle - 1e-12
    if window.sum() < 2:
        raise ValueError(f"{folder}: the run ends before {settle} s after the ramp")
    t0, t1 = t[window][0], t[-1]
    speed = float((c[window][-1] - c[window][0]) @ axis / (t1 - t0))
    # angle of field and moment about the axis, unwrapped: the moment loses turns
    # against the field only above step-out
    e1 = np.cross(axis, [1.0, 0, 0]) if abs(axis[0]) < 0.9 else np.cross(axis, [0, 1.0, 0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    angle = [np.unwrap(np.arctan2(v[window] @ e2, v[window] @ e1)) for v in (b, q)]
    turns = (angle[0][-1] - angle[0][0]) / (2 * math.pi)
    lost = ((angle[0][-1] - angle[1][-1]) - (angle[0][0] - angle[1][0])) / (2 * math.pi)
    steady = summary.get("steady") or {}
    if steady.get("reached"):
        values = steady["values"]
        speed = float(axis @ [values[f"centroid_{k}_rate"] for k in "xyz"])
    return {
        "frequency": field["frequency"],
        "speed": speed,
        "slip": lost / max(turns, 1e-300),
        "status": summary["status"],
        "end": float(t1),
        "steady": bool(steady.get("reached")) if steady else None,
    }


def sweep(folder: Path, estimate: float | None, settle: float = SETTLE) -> int:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = []
    for run in sorted(
        p for p in folder.iterdir() if (p / "body.csv").exists() and (p / "summary.json").exists()
    ):
        try:
            rows.append(sweep_row(run, settle))
        except ValueError as error:  # a run that failed early: say so, plot the others
            print(f"bidirectional_strip: left out of the sweep: {error}", file=sys.stderr)
    if not rows:
        print(
            f"bidirectional_strip: no usable runs (body.csv and summary.json) in {folder}",
            file=sys.stderr,
        )
        return 2
    rows.sort(key=lambda r: r["frequency"])
    f = np.array([r["frequency"] for r in rows])
    v = np.array([r["speed"] for r in rows])
    # step-out: the moment loses turns against the field.  The speed may peak well
    # below it, when the strip no longer holds its chiral shape at a high sperm
    # number while its magnetized ends still follow the field.
    slipping = np.array([r["slip"] > STEPPED_OUT_SLIP for r in rows])
    peak = int(np.argmax(np.abs(v)))
    with open(folder / "sweep.csv", "w", encoding="utf-8") as out:
        out.write("frequency_hz,mean_speed_mm_s,slip_turns_per_field_turn,status,t_end_s,steady\n")
        for r in rows:
            out.write(
                f"{r['frequency']},{r['speed']:.6g},{r['slip']:.4f},{r['status']},"
                f"{r['end']:.6g},{'' if r['steady'] is None else str(r['steady']).lower()}"
                "\n"
            )
    fig, ax = plt.subplots(figsize=(6, 4))
    # signed: the direction along the axis may change with f
    ax.axhline(0.0, color="grey", lw=0.6)
    ax.plot(f, v, "o-", color="C0", label="mean speed along the rotation axis")
    ax.plot(f[peak], v[peak], "*", color="C1", ms=12, label="fastest")
    if slipping.any():
        ax.plot(
            f[slipping],
            v[slipping],
            "x",
            color="C3",
            ms=10,
            label="stepped out: the moment slips behind the field",
        )
    failed = np.array([r["status"] != "ok" for r in rows])
    if failed.any():
        ax.plot(
            f[failed],
            v[failed],
            "s",
            mfc="none",
            color="k",
            ms=10,
            label="run failed: measured up to where it stopped",
        )
    if estimate:
        ax.axvline(estimate, color="grey", ls="--", label=f"rigid-rotor estimate {estimate:.0f} Hz")
    if f.min() > 0 and f.max() / f.min() > 8:
        ax.set_xscale("log", base=2)
    ax.set_xlabel("field frequency f (Hz)")
    ax.set_ylabel("swimming speed along the axis (mm/s)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(folder / "sweep.png", dpi=110)
    for r in rows:
        failed = "" if r["status"] == "ok" else f"  (run FAILED at t = {r['end']:.4g} s)"
        how = {True: "steady", False: "NOT steady by its end", None: "window mean"}[r["steady"]]
        print(
            f"f = {r['frequency']:6.2f} Hz: speed {r['speed']:+9.4f} mm/s ({how}), "
            f"slip {r['slip']:.3f} turn per field turn{failed}"
        )
    print(f"wrote {folder / 'sweep.csv'} and {folder / 'sweep.png'}")
    return 0


# --- main --------------------------------------------------------------------------


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=Path("results/bidirectional_strip"))
    parser.add_argument(
        "--set",
        dest="overrides",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="scene override, as for rftfem run",
    )
    parser.add_argument(
        "--sweep",
        type=Path,
        metavar="DIR",
        help="only plot the sweep made by demos/strip_sweep.sh in DIR",
    )
    parser.add_argument("--estimate", type=float, help="step-out estimate to mark (Hz)")
    parser.add_argument(
        "--settle",
        type=float,
        default=SETTLE,
        help=f"seconds after the ramp left out of the sweep's speeds (default {SETTLE})",
    )
    args = parser.parse_args(argv)
    if args.sweep:
        return sweep(args.sweep, args.estimate, args.settle)

    from mpi4py import MPI

    import rftfem  # noqa: F401  (before mpi4py: sets up the FEniCSx stack)

    comm = MPI.COMM_WORLD
    runs = {name: run_protocol(name, args.overrides, args.out, comm) for name in PROTOCOLS}
    if comm.rank != 0:  # rank 0 wrote the outputs; it reads them
        return 0
    scene = runs["+X"][1]
    field = scene["magnetic.field"]
    axis = unit(field["rotation_axis"])
    end, period = scene["time.end"], 1.0 / field["frequency"]
    paths = {name: centroid_path(result) for name, (result, _) in runs.items()}
    net = {
        name: net_displacement(*path, axis, end - 2 * period, end) for name, path in paths.items()
    }
    g = groups(scene.to_dict())
    phases = {name: phase1(result, protocol) for name, (result, protocol) in runs.items()}
    f_c = phases["+X"][1]
    args.out.mkdir(parents=True, exist_ok=True)
    lines = [
        "| quantity | value |",
        "|---|---|",
        f"| magneto-elastic number m B t A_end L / (D W) | {g['magneto_elastic_number']:.3g} |",
        f"| sperm number L (C₃ ω / D)^¼ at f = {field['frequency']:g} Hz "
        f"| {g['sperm_number']:.3g} |",
        f"| rigid-rotor step-out estimate of the phase-1 shape | {f_c:.3g} Hz |",
    ] + [
        f"| net displacement along the axis, last two periods, field along {n} | {d:+.4f} mm |"
        for n, d in net.items()
    ]
    (args.out / "groups.md").write_text("\n".join(lines) + "\n", encoding="utf-8")
    print("\n".join(lines))
    with open(args.out / "trajectory.csv", "w", encoding="utf-8") as f:
        f.write("time," + ",".join(f"centroid_along_axis_{n}" for n in PROTOCOLS) + "\n")
        t = paths["+X"][0]
        along = [c @ axis for _, c in paths.values()]
        for i, ti in enumerate(t):
            f.write(f"{float(ti)!r}," + ",".join(f"{float(z[i])!r}" for z in along) + "\n")
    plot_shapes({n: shape for n, (shape, _) in phases.items()}, args.out / "shape_phase1.png")
    curves = {n: (t, c @ axis) for n, (t, c) in paths.items()}
    plot_trajectories(curves, field["ramp_time"], args.out / "trajectory.png")
    print(f"wrote groups.md, trajectory.csv, shape_phase1.png, trajectory.png in {args.out}")
    # a picture and a film of each protocol, drawn as `rftfem render` draws them
    for name, (result, _) in runs.items():
        draw_picture_and_film(result.folder, "strip", view="follow")
    a, b = net["+X"], net["-X"]
    if not (a * b < 0 and abs(abs(a) / abs(b) - 1) <= 0.05):
        print(
            f"bidirectional_strip: FAILED: the protocols should swim in opposite senses "
            f"with equal magnitudes (5 %); got {a:+.4f} and {b:+.4f} mm",
            file=sys.stderr,
        )
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
