"""What one Jacobian assembly costs per cell, and what compiler flags buy.

For each case the demo runs a few steps (so the state is a moving one), then its
Jacobian form is compiled again under each set of C compiler flags, each into a
fresh JIT cache (the compile time is a cold one), and the assemblies are timed
round-robin -- one of each flag set in turn, many rounds -- so that the drift of
a shared machine falls on every variant alike.  Printed per flag set: compile
time, best and median assembly time (ms and µs per cell), and the largest
difference of the assembled matrix from the first flag set's, relative to its
largest entry (0: bitwise the same; ~1e-15: round-off, from reassociated sums
and fused multiply-adds).  Last, the same assembly with a trivial kernel of the
same spaces: the cost of inserting the cell matrices into PETSc's, which no
flag changes -- into the tangent's block matrix (rftfem/petsc_options.py,
MATRIX_TYPE) and, for comparison, into a point-wise AIJ matrix.

    .venv/bin/python benchmarks/form_cost.py               # sheet and strip, ~4 minutes
    .venv/bin/python benchmarks/form_cost.py sheet --rounds 60

Figures go to stdout and results/benchmarks/form_cost.csv.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

# the repository's .venv when this python3 lacks rftfem (scripts/repository_python.py)
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))
import repository_python  # noqa: E402

repository_python.ensure()

import numpy as np
import ufl
from step_cost import CASES, DEMOS, _Enough, cases_asked, stopper, write_csv

import rftfem  # noqa: F401  (sets up the FEniCSx stack)
from rftfem import compat, petsc_options
from rftfem.integration.simulation import Simulation
from rftfem.scene.reading import load_scene

#: flag sets compared: the JIT's own default first, then rftfem's earlier default,
#: then the vectorised ones; the one in use (rftfem/compat/compilation.py) is marked
FLAG_SETS = [
    ["-O2", "-g0"],
    ["-O2", "-g0", "-fno-math-errno"],
    [
        "-O3",
        "-g0",
        "-fno-math-errno",
        "-fno-trapping-math",
        "-fno-signed-zeros",
        "-fassociative-math",
        "-freciprocal-math",
    ],
]
if compat.COMPILE_FLAGS not in map(tuple, FLAG_SETS):
    FLAG_SETS.append(list(compat.COMPILE_FLAGS))


def measure(name: str, rounds: int) -> list[dict]:
    scene_file, overrides, _ = CASES[name]
    scene = load_scene(DEMOS / scene_file, overrides)
    rows = []
    with tempfile.TemporaryDirectory() as out:
        sim = Simulation(scene, out_dir=Path(out), quiet=True, observers=[stopper(scene, 10)])
        try:
            try:
                sim.run()
            except _Enough:
                pass
            model = sim.model
            cells = model.mesh.topology.index_map(2).size_local
            forms, compile_s = [], []
            for flags in FLAG_SETS:
                with tempfile.TemporaryDirectory() as cache:
                    t0 = time.perf_counter()
                    forms.append(
                        compat.form(
                            model.jacobian_ufl,
                            {"cffi_extra_compile_args": flags, "cache_dir": cache, "timeout": 900},
                        )
                    )
                    compile_s.append(time.perf_counter() - t0)
            # a kernel that does next to nothing on the same spaces: what is left is
            # packing and inserting 45 x 45 cell matrices into PETSc's
            trivial = ufl.inner(ufl.TrialFunction(model.W), ufl.TestFunction(model.W))
            forms += [compat.form(trivial * model.dx(metadata={"quadrature_degree": 0}))] * 2
            kinds = [petsc_options.MATRIX_TYPE] * (len(forms) - 1) + ["aij"]
            matrices = [compat.create_matrix(J, kind) for J, kind in zip(forms, kinds)]
            times = [[] for _ in forms]
            for _ in range(rounds):
                for J, A, t in zip(forms, matrices, times):
                    A.zeroEntries()
                    t0 = time.perf_counter()
                    compat.assemble_matrix(A, J, model.bcs)
                    A.assemble()
                    t.append(time.perf_counter() - t0)
            values = [A.convert("aij").getValuesCSR()[2] for A in matrices]
            labels = [" ".join(f) for f in FLAG_SETS] + [
                f"(trivial kernel: insertion only, {petsc_options.MATRIX_TYPE})",
                "(trivial kernel: insertion only, aij)",
            ]
            for label, tc, t, v in zip(labels, compile_s + [0.0, 0.0], times, values):
                same = tc > 0.0  # the trivial kernel's matrix is another one
                rows.append(
                    {
                        "case": name,
                        "cells": cells,
                        "flags": label,
                        "in_use": label == " ".join(compat.COMPILE_FLAGS),
                        "compile_s": tc,
                        "best_ms": 1e3 * min(t),
                        "median_ms": 1e3 * np.median(t),
                        "best_us_per_cell": 1e6 * min(t) / cells,
                        "median_us_per_cell": 1e6 * np.median(t) / cells,
                        "max_difference": float(
                            np.max(np.abs(v - values[0])) / np.max(np.abs(values[0]))
                        )
                        if same
                        else None,
                    }
                )
            for A in matrices:
                A.destroy()
        finally:
            sim.close()
    return rows


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "cases", nargs="*", help="sheet, strip, rollup, three-link (default: sheet and strip)"
    )
    parser.add_argument("--rounds", type=int, default=40, help="timed assemblies per flag set")
    args = parser.parse_args(argv)
    rows = []
    for name in cases_asked(parser, args.cases or ["sheet", "strip"]):
        print(f"\n{name}: Jacobian assembly, {args.rounds} rounds (cold compile, best, median)")
        for row in measure(name, args.rounds):
            rows.append(row)
            mark = "  <- in use" if row["in_use"] else ""
            diff = row["max_difference"]
            print(
                f"  {row['flags']}{mark}\n      compile {row['compile_s']:5.1f} s   "
                f"{row['best_ms']:6.2f} / {row['median_ms']:6.2f} ms   "
                f"{row['best_us_per_cell']:5.0f} / {row['median_us_per_cell']:5.0f} µs per cell"
                + (f"   matrix vs first: {diff:.1e}" if diff is not None else ""),
                flush=True,
            )
    write_csv(Path("results/benchmarks/form_cost.csv"), rows)


if __name__ == "__main__":
    main()
