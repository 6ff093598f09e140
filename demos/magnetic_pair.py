"""Two magnetic strips side by side: what sharing the liquid and the magnets does.

``demos/magnetic_pair.toml`` puts two of the paper's bidirectional strips 1 mm apart
in one Stokes flow, in the rotating field that makes each swim along −Z.  This
script runs three cases and compares them:

* ``alone``: one strip (the same scene without the second body);
* ``pair, flow only``: both strips, ``[magnetic] interactions = false``: they feel
  each other only through the liquid;
* ``pair, flow and magnets``: as shipped: each strip's magnets also pull and turn
  the other's.

Printed and written to ``pair.md`` (in the output folder): each strip's speed along Z
over the last field period and its spacing from the other (the distance between
their centroids in the XY plane) at the start and the end.  With ``--film`` the
interacting pair is drawn into ``pair.mp4``.

    python3 demos/magnetic_pair.py                 # results in results/magnetic_pair_demo/
    python3 demos/magnetic_pair.py --film
    python3 demos/magnetic_pair.py --set time.end=0.6     (shorter: the ramp and 2 periods)

Exit status 1 if a strip does not swim along −Z.
"""

from __future__ import annotations

import argparse
import sys
import tomllib
from pathlib import Path

# the repository's .venv when this python3 lacks rftfem (scripts/repository_python.py)
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))
import repository_python  # noqa: E402

repository_python.ensure()

import rftfem  # noqa: E402

HERE = Path(__file__).resolve().parent
SCENE = HERE / "magnetic_pair.toml"
PERIOD = 0.25  # the field's period at 4 Hz (s)


def cases(changes: dict) -> dict[str, rftfem.Scene]:
    """The three scenes: alone, the pair with the liquid only, the pair as shipped."""
    pair = rftfem.load_scene(SCENE, set=changes)
    flow_only = pair.copy()
    flow_only["magnetic.interactions"] = False
    alone = pair.copy()
    for key in ("magnetic.parts.3", "magnetic.parts.2", "body.1"):
        alone.pop(key)
    alone["magnetic.interactions"] = False
    return {"alone": alone, "pair, flow only": flow_only, "pair, flow and magnets": pair}


def speeds(result: rftfem.Result, names: list[str]) -> dict[str, float]:
    """Each body's mean speed along Z over the last field period (mm/s)."""
    body = result.body
    end = body["time"].iloc[-1]
    last = body[body["time"] >= end - PERIOD - 1e-9]
    span = last["time"].iloc[-1] - last["time"].iloc[0]
    return {
        n: (last[f"{n}_centroid_z"].iloc[-1] - last[f"{n}_centroid_z"].iloc[0]) / span
        for n in names
    }


def spacing(result: rftfem.Result) -> tuple[float, float]:
    """The distance between the two centroids in the XY plane, first and last row."""
    b = result.body
    d = (
        (b["right_centroid_x"] - b["left_centroid_x"]) ** 2
        + (b["right_centroid_y"] - b["left_centroid_y"]) ** 2
    ) ** 0.5
    return float(d.iloc[0]), float(d.iloc[-1])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="results/magnetic_pair_demo")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    parser.add_argument("--film", action="store_true", help="draw the pair into pair.mp4")
    args = parser.parse_args(argv)
    changes = {}
    for text in args.set:
        key, _, value = text.partition("=")
        changes[key] = tomllib.loads(f"v = {value}")["v"]
    out = Path(args.out)
    rows, ok = [], True
    for name, scene in cases(changes).items():
        folder = out / name.replace(", ", "-").replace(" ", "_")
        print(f"{name}: running into {folder}", flush=True)
        result = rftfem.run(scene, folder)
        bodies = ["left"] if name == "alone" else ["left", "right"]
        v = speeds(result, bodies)
        gap = spacing(result) if len(bodies) == 2 else (float("nan"), float("nan"))
        ok &= all(s < 0 for s in v.values())
        rows.append((name, v.get("left"), v.get("right", float("nan")), *gap))
        if args.film and name == "pair, flow and magnets":
            print(f"film: {result.render(out / 'pair.mp4')}")
    lines = [
        "| case | left strip (mm/s) | right strip (mm/s) | spacing, start (mm) | end (mm) |",
        "| --- | ---: | ---: | ---: | ---: |",
    ]
    lines += [f"| {n} | {a:.4f} | {b:.4f} | {s0:.4f} | {s1:.4f} |" for n, a, b, s0, s1 in rows]
    text = "\n".join(lines)
    print(text)
    out.mkdir(parents=True, exist_ok=True)
    (out / "pair.md").write_text(text + "\n", encoding="utf-8")
    if not ok:
        print("a strip did not swim along −Z", file=sys.stderr)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
