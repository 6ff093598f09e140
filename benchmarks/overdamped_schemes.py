"""BDF2 against backward Euler on an overdamped scene: what 0.1 % costs.

The rigid magnetic plate of docs/verification.md case G (a 2 × 1 × 0.1 plate in
drag, magnetized along its length) behind a field turning about its normal at
twice the critical rate ω_c = π rad/s, to t = 0.5 s (before its first slip).  The
quantity is the mean turning rate over the run; its exact value comes from
Adler's equation in closed form.  Each scheme runs at dt = 0.05 / 2^k until its
rate is within 0.1 % of the exact one (and at least three steps, so that the
error is seen to fall at the scheme's order: a single coarse run can be lucky);
printed per run: steps, Newton
iterations, wall time (compilation excluded) and the error; then the cheapest
run of each scheme within 0.1 % and the ratio of their wall times.

    .venv/bin/python benchmarks/overdamped_schemes.py            # ~2 minutes
    .venv/bin/python benchmarks/overdamped_schemes.py --target 1e-4

Figures also go to results/benchmarks/overdamped_schemes.csv.
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
import tempfile
from pathlib import Path

# the repository's .venv when this python3 lacks rftfem (scripts/repository_python.py)
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))
import repository_python  # noqa: E402

repository_python.ensure()

from step_cost import write_csv

from rftfem.outputs.quantities import evaluate

DRAG = 1.0e-3  # C₃; C₁ = C₂ = 2 C₃ (N·s/mm³)
L, W, T = 2.0, 1.0, 0.1
MB = 2 * math.pi * DRAG / 0.24  # m B giving ω_c = π rad/s about the normal
ZETA = 2 * DRAG * L * W * (L**2 + W**2) / 12
OMEGA_C = MB * T * L * W / ZETA
OMEGA = 2 * OMEGA_C
END = 0.5

SCENE = f"""
title = "rigid magnetic plate behind a rotating field (Adler's rotor)"
[mesh]
kind = "strip"
length = {L}
width = {W}
divisions = [4, 2]
[[mesh.regions]]
name = "plate"
x = [0.0, {L}]
[shell]
thickness = {T}
E = 1.0e7
nu = 0.3
[fluid]
drag = [{2 * DRAG}, {2 * DRAG}, {DRAG}]
[time]
end = {END}
[magnetic]
[[magnetic.parts]]
region = "plate"
magnetization = {MB / 1.0e-3}
direction = [1.0, 0.0, 0.0]
[magnetic.field]
strength = 1.0e-3
ramp_time = 0.0
direction = [1.0, 0.0, 0.0]
frequency = {OMEGA / (2 * math.pi)}
rotation_axis = [0.0, 0.0, 1.0]
[output]
fields = false
[[output.probes]]
name = "a"
at = [0.0, 0.5, 0.0]
[[output.probes]]
name = "b"
at = [2.0, 0.5, 0.0]
"""
RATE = f"spin(a, b, z, 0, {END})"


def exact_rate() -> float:
    """Adler's rotor, ζ φ' = m B sin(ω t − φ), φ(0) = 0, ω > ω_c, in closed form:
    tan(ψ/2) = (ω_c + Ω tan(Ω t/2 + c))/ω with ψ = ω t − φ, Ω = √(ω² − ω_c²),
    c = atan(−ω_c/Ω); the mean rate φ(END)/END."""
    big = math.sqrt(OMEGA**2 - OMEGA_C**2)
    c = math.atan(-OMEGA_C / big)
    psi = 2 * math.atan((OMEGA_C + big * math.tan(big * END / 2 + c)) / OMEGA)
    return (OMEGA * END - psi) / END


def run(folder: Path, scheme: str, dt: float) -> dict:
    scene = folder / "plate.toml"
    scene.write_text(SCENE, encoding="utf-8")
    out = folder / f"{scheme}-{dt:g}"
    cmd = [
        sys.executable,
        "-m",
        "rftfem",
        "run",
        str(scene),
        "--out",
        str(out),
        "--quiet",
        "--set",
        f'time.scheme="{scheme}"',
        "--set",
        f"time.dt={dt!r}",
    ]
    done = subprocess.run(cmd, capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"{scheme} at dt = {dt:g} failed: {done.stderr.strip()[-500:]}")
    summary = json.loads((out / "summary.json").read_text())
    c, wall = summary["counts"], summary["wall_s"]
    rate = evaluate(RATE, out)
    return {
        "scheme": scheme,
        "dt": dt,
        "steps": c["steps"],
        "newton": c["newton_iterations"],
        "wall_s": wall["total"] - wall["compile"],
        "rate": rate,
        "error": abs(rate / exact_rate() - 1),
    }


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--target", type=float, default=1e-3, help="relative error to reach")
    parser.add_argument("--max-halvings", type=int, default=12)
    args = parser.parse_args(argv)
    rows, cheapest = [], {}
    with tempfile.TemporaryDirectory() as tmp:
        for scheme in ("backward-euler", "bdf2"):
            for k in range(args.max_halvings + 1):
                r = run(Path(tmp), scheme, 0.05 / 2**k)
                rows.append(r)
                print(
                    f"{scheme:15s} dt {r['dt']:.3e}: {r['steps']:5d} steps, {r['newton']:6d} "
                    f"Newton its, {r['wall_s']:7.2f} s, error {100 * r['error']:.4f} %",
                    flush=True,
                )
                if r["error"] > args.target:
                    cheapest.pop(scheme, None)  # the cheapest after which all stay within
                elif scheme not in cheapest:
                    cheapest[scheme] = r
                if scheme in cheapest and k >= 2:
                    break
    print(f"\nexact mean rate {exact_rate():.10f} rad/s; target {100 * args.target:g} %")
    for scheme in ("backward-euler", "bdf2"):
        own = [r for r in rows if r["scheme"] == scheme]
        orders = [math.log2(a["error"] / b["error"]) for a, b in zip(own, own[1:])]
        print(f"{scheme}: observed orders " + ", ".join(f"{p:.2f}" for p in orders))
    for scheme in ("backward-euler", "bdf2"):
        r = cheapest.get(scheme)
        print(
            f"{scheme}: "
            + (f"dt {r['dt']:.3e}, {r['steps']} steps, {r['wall_s']:.2f} s" if r else "not reached")
        )
    if len(cheapest) == 2:
        ratio = cheapest["backward-euler"]["wall_s"] / cheapest["bdf2"]["wall_s"]
        print(f"BDF2 is {ratio:.1f}x cheaper than backward Euler for {100 * args.target:g} %")
    write_csv(Path("results/benchmarks/overdamped_schemes.csv"), rows)


if __name__ == "__main__":
    main()
