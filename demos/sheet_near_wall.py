"""A swimming sheet near a wall: what only the Stokes flow can see.

The sheet of ``demos/sheet_near_wall.toml`` swims by a travelling wave, its
plane parallel to a no-slip wall at distance h.  This script runs it at several
heights and without a wall in Stokes flow, and once with resistive-force drag of
the same viscosity (``model = "rft"``: local drag knows nothing of the wall, so
one run stands for every height).  It prints and writes the speed against h.

    python3 demos/sheet_near_wall.py                    # h = 1.25, 1.5, 2, 3, 5 and free
    python3 demos/sheet_near_wall.py --heights 1.5 2 --jobs 2
    python3 demos/sheet_near_wall.py --reuse            # table and plot again, no rerun

Outputs in ``--out`` (default ``results/sheet_near_wall``): ``table.csv``,
``table.md``, ``speed.png`` (speed against h), ``sheet.png`` and ``sheet.mp4``
(the run at h = 1.5, a camera following the sheet), and one run folder per case.

What to expect (docs/stokes.md, "A sheet near a wall"): the speed grows as the
sheet comes nearer the wall, and far from it tends to the free sheet's speed;
the RFT speed is the same at every height.
"""

from __future__ import annotations

import argparse
import csv
import json
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

# the repository's .venv when this python3 lacks rftfem (scripts/repository_python.py)
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))
import repository_python  # noqa: E402

repository_python.ensure()

#: the lowest height whose closest gap, h − b, is 2.5 blobs of the shipped mesh
GAP_LOWEST = 0.5 + 2.5 * 0.25
HERE = Path(__file__).resolve().parent
SCENE = HERE / "sheet_near_wall.toml"


def scene_changes(height: float | None, model: str = "stokes") -> list[str]:
    """The command-line changes that make the shipped scene's case: the wall at
    ``height`` below the sheet, no wall (None), or local drag of the same viscosity
    (``model = "rft"``, no wall)."""
    if model == "rft":
        return ["--set", "fluid.model=rft", "--unset", "fluid.wall"]
    if height is None:
        return ["--unset", "fluid.wall"]
    return ["--set", f"fluid.wall.point=[0.0, 0.0, {-float(height)!r}]"]


def run(name: str, changes: list[str], out: Path, reuse: bool) -> Path:
    folder = out / name
    if reuse and (folder / "summary.json").exists():
        print(f"{name}: reusing {folder}", flush=True)
        return folder
    out.mkdir(parents=True, exist_ok=True)
    cmd = [
        sys.executable,
        "-m",
        "rftfem",
        "run",
        str(SCENE),
        "--out",
        str(folder),
        "--quiet",
        *changes,
    ]
    print(f"{name}: {' '.join(cmd)}", flush=True)
    with open(out / f"{name}.log", "w") as log:
        status = subprocess.call(cmd, stdout=log, stderr=subprocess.STDOUT)
    if status != 0:
        raise SystemExit(f"{name} failed (exit {status}); see {out / (name + '.log')}")
    return folder


def steady_speed(folder: Path) -> tuple[float, bool, float]:
    """The steady speed of the front corner, whether the run became steady, wall s."""
    summary = json.loads((folder / "summary.json").read_text())
    steady = summary["steady"]
    return (steady["values"]["front_ux_rate"], bool(steady["reached"]), summary["wall_s"]["total"])


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--heights", type=float, nargs="+", default=[1.25, 1.5, 2.0, 3.0, 5.0])
    parser.add_argument("--jobs", type=int, default=1, help="runs at once")
    parser.add_argument("--out", type=Path, default=Path("results/sheet_near_wall"))
    parser.add_argument("--reuse", action="store_true", help="keep finished runs in --out")
    args = parser.parse_args(argv)
    if min(args.heights) < GAP_LOWEST:
        parser.error(
            f"--heights: below h = {GAP_LOWEST} the closest gap between the waving "
            "sheet (amplitude 0.5) and the wall is under 2.5 blobs (0.25 on the "
            "shipped mesh) and the wall leaks; refine the mesh in the scene first"
        )

    cases = [(f"h_{h:g}", scene_changes(h), h) for h in args.heights]
    cases += [("free", scene_changes(None), None), ("rft", scene_changes(None, "rft"), None)]
    with ThreadPoolExecutor(max_workers=max(1, args.jobs)) as pool:
        folders = list(pool.map(lambda c: run(c[0], c[1], args.out, args.reuse), cases))

    free = steady_speed(folders[-2])[0]
    rows = []
    for (name, _, h), folder in zip(cases, folders):
        U, reached, wall_s = steady_speed(folder)
        rows.append(
            {
                "case": name,
                "h": "" if h is None else h,
                "U": U,
                "U_over_free": U / free,
                "steady": reached,
                "wall_s": round(wall_s, 1),
            }
        )
        print(
            f"{name:>8}: U = {U:.5f} mm/s, {U / free:.4f} of the free sheet's"
            + ("" if reached else "  (NOT steady by time.end)")
        )
    with open(args.out / "table.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    with open(args.out / "table.md", "w") as f:
        f.write("| case | h (mm) | U (mm/s) | U / U_free | steady | wall (s) |\n")
        f.write("|---|---:|---:|---:|---|---:|\n")
        for r in rows:
            f.write(
                f"| {r['case']} | {r['h']} | {r['U']:.5f} | {r['U_over_free']:.4f} | "
                f"{r['steady']} | {r['wall_s']} |\n"
            )
    plot(rows, args.out / "speed.png")
    near = dict(zip([c[0] for c in cases], folders)).get("h_1.5")
    if near is not None:
        draw_picture_and_film(near, "sheet", view="follow")
    return 0 if all(r["steady"] for r in rows) else 1


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


def plot(rows, path: Path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    walls = [r for r in rows if r["h"] != ""]
    free = next(r for r in rows if r["case"] == "free")["U"]
    rft = next(r for r in rows if r["case"] == "rft")["U"]
    fig, ax = plt.subplots(figsize=(5, 3.5))
    ax.plot([r["h"] for r in walls], [r["U"] for r in walls], "o-", label="Stokes, wall at h")
    ax.axhline(free, color="k", ls="--", label="Stokes, no wall")
    ax.axhline(rft, color="tab:red", ls=":", label="RFT (any h)")
    ax.set_xlabel("distance to the wall h (mm)")
    ax.set_ylabel("swimming speed (mm/s)")
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    print(f"drew {path}")


if __name__ == "__main__":
    sys.exit(main())
