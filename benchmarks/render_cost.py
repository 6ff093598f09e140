"""What a frame of a film costs, and where the time goes.

The run is the sheet robot as shipped (demos/sheet_robot.toml: 16 × 2 cells, 825
unknowns, 1537 output rows; about 1.5 minutes) unless ``--results`` names a run
folder. Its film is drawn as ``rftfem render`` draws it (at most 360 frames of
1024 × 768, the magnetization's colours and arrows), then the parts of a frame
are timed on their own over the same frames:

- read: the frame's fields from fields.xdmf/.h5 (VTK's XDMF reader);
- geometry: the curved surface (subdivided cells), edges, outline and arrows;
- draw + encode: the rest (VTK's rendering, reading the image back, ffmpeg).

A still picture is timed too: it keeps 8 samples per pixel of antialiasing,
which a film leaves out (rftfem/outputs/render.py says why).

    .venv/bin/python benchmarks/render_cost.py [--results DIR] [--size 1024x768]

Prints a table; nothing is asserted.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

# the repository's .venv when this python3 lacks rftfem (scripts/repository_python.py)
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))
import repository_python  # noqa: E402

repository_python.ensure()

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--results",
        type=Path,
        default=None,
        help="a run folder with fields (default: run the sheet robot)",
    )
    parser.add_argument("--size", default="1024x768")
    args = parser.parse_args(argv)

    with tempfile.TemporaryDirectory() as tmp:
        results = args.results
        if results is None:
            results = Path(tmp) / "sheet_robot"
            t0 = time.perf_counter()
            subprocess.run(
                [
                    sys.executable,
                    "-m",
                    "rftfem",
                    "run",
                    str(ROOT / "demos" / "sheet_robot.toml"),
                    "--out",
                    str(results),
                    "--quiet",
                ],
                check=True,
            )
            print(f"run: {time.perf_counter() - t0:.1f} s")

        # rendering in this process: pyvista before anything imports dolfinx
        from rftfem.outputs.render import _arrows, render
        from rftfem.outputs.render_body import BodyDrawing
        from rftfem.outputs.render_view import MAX_FILM_FRAMES, RunFields, film_plan

        size = tuple(int(v) for v in args.size.split("x"))
        t0 = time.perf_counter()
        film = render(results, Path(tmp) / "film.mp4", size=size)
        total = time.perf_counter() - t0
        t0 = time.perf_counter()
        render(results, Path(tmp) / "still.png", size=size)
        still = time.perf_counter() - t0

        run = RunFields(results)
        idx, _ = film_plan(len(run.times), None, None, MAX_FILM_FRAMES)
        t0 = time.perf_counter()
        frames = [run.frame(i) for i in idx]
        read = time.perf_counter() - t0
        drawing = BodyDrawing(run.reference)
        t0 = time.perf_counter()
        for frame in frames:
            u = frame["displacement"]
            drawing.surface(u, {"m": frame.get("magnetization", u)[:, 0]})
            drawing.edges(u)
            drawing.outline(u)
            if "magnetization" in frame:
                m = frame["magnetization"]
                _arrows(run.points(frame), m, np.linalg.norm(m, axis=1) > 0, 1.0)
        geometry = time.perf_counter() - t0

    n = film.frames
    dofs = "?"
    try:
        import json

        dofs = json.loads((results / "summary.json").read_text())["dofs"]
    except (OSError, KeyError, ValueError):
        pass
    print(
        f"\nfilm of {n} frames, {size[0]}x{size[1]}, {dofs} unknowns: {total:.1f} s, "
        f"{total / n:.3f} s a frame (the survey pass and set-up included)"
    )
    print("| part | s a frame |\n| --- | ---: |")
    print(f"| read the fields | {read / n:.4f} |")
    print(f"| surface, edges, arrows | {geometry / n:.4f} |")
    print(f"| draw + encode (the rest) | {(total - read - geometry) / n:.4f} |")
    print(f"\nstill picture (8 samples a pixel): {still:.2f} s including reading the run")
    return 0


if __name__ == "__main__":
    sys.exit(main())
