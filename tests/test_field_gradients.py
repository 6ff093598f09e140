"""Exact gradients by material fields (rftfem/studies/field_gradients.py, docs/model.md
§7.6): per cell and per profile point, against the runs themselves and a closed form.

The strips are those of tests/test_sensitivity.py (shared compiled forms), with one
load step (``time.dt = time.end``): the adjoint of that step's residual is then the
whole derivative.  A field is perturbed in the Model before the run (the same
Functions the compiled forms read), so a cell's or a direction's change needs no
scene syntax.

- Taylor tests: along a random direction δ over the field's dofs (each value moved by
  up to h₀ = 2 % of itself), r₂(h) = |J(f + hδ) − J(f) − h g·δ| falls as h² (orders
  2 ± 0.2) and r₁ = |J(f + hδ) − J(f)| as h, for the thickness, E and ν of the
  bent and twisted strip, the density of a strip sagging under its weight and the
  magnetization of the magnetized half of the unsymmetric strip;
- central differences of 5 cells drawn at random (seeded), each cell's thickness
  field (DG2, a formula) moved uniformly by ±1e-4 of it: within 1e-6;
- the tapered cantilever's tip deflection by each cell column's thickness against
  ``−3 ∫ P (L − x)² · 12/(E w t⁴) dx`` over the column (small deflection);
- a profile's gradient is the field's carried back through the interpolation
  weights: Σ over the grid equals the per-cell total, and the profile's gradient
  agrees with the formula's cell gradients for a profile equal to the formula.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import write_scene
from material_references import tapered_deflection_gradient
from test_sensitivity import MAGNET, STRIP, TIGHT

ONE_STEP = ["time.dt=1.0"]

SAGGING = STRIP.replace(
    "[[load]]",
    """[[load]]
kind = "gravity"
value = [0.0, 0.0, -9.81]
ramp = "constant"
[[load]]""",
).replace("nu = 0.3", "nu = 0.3\ndensity = 0.01")
# the weight alone would sag the tip by about 1.2; the end force adds its bend and twist

TAPERED = """
title = "a tapered cantilever with a small end force"
[mesh]
length = 10.0
width = 1.0
divisions = [20, 1]
[shell]
thickness = "0.15 - 0.01*X"
E = 1.2e6
nu = 0.0
[time]
scheme = "static"
end = 1.0
dt = 1.0
[[boundary]]
where = "x=0"
fix = ["clamped"]
[[load]]
kind = "edge-force"
where = "x=L"
value = [0.0, 0.0, 1.0e-5]
ramp = "constant"
[[output.probes]]
name = "tip"
at = [10.0, 0.5, 0.0]
[output]
fields = false
"""


def _field(model, key):
    if key.startswith("magnetic."):
        return model["magnetic"].remanence
    from rftfem.model.materials import FORM_NAMES

    return model.material[FORM_NAMES[key.split(".")[-1]]]


def _solve(scene_file, overrides, objective, keys=(), change=None):
    """Run in this process (the field changed by ``change(f)`` first); J and, with
    ``keys``, their field gradients."""
    from rftfem.integration.simulation import Simulation
    from rftfem.scene.reading import load_scene
    from rftfem.studies.sensitivity import check_request, gradient, keep_last_step

    scene = load_scene(str(scene_file), list(overrides))
    sim = Simulation(scene, quiet=True, petsc_args=TIGHT)
    try:
        if change is not None:
            change(sim.model)
        last = keep_last_step(sim.model)
        sim.run()
        _, target = check_request(scene, [], objective)
        got = gradient(sim, last, [], target, fields=list(keys))
        return got[0], (got[2] if keys else None)
    finally:
        sim.close()


def _direction(f, key, rng):
    """A random direction over the field's dofs, each of at most its own value (the
    magnetization: along q₀ on each magnetized cell)."""
    if key.startswith("magnetic."):
        M = f.x.array.reshape(-1, 3)
        return (M * rng.uniform(-1.0, 1.0, size=(len(M), 1))).ravel()
    return f.x.array * rng.uniform(-1.0, 1.0, size=len(f.x.array))


@pytest.mark.parametrize(
    "text, key, objective",
    [
        (STRIP, "shell.thickness", "tip_uz@end"),
        (STRIP, "shell.E", "tip_uz@end"),
        (STRIP, "shell.nu", "tip_uy@end"),
        (SAGGING, "shell.density", "tip_uz@end"),
        (MAGNET, "magnetic.parts.0.magnetization", "tip_ux@end"),
    ],
    ids=["thickness", "E", "nu", "density", "magnetization"],
)
def test_taylor_per_field(tmp_path, text, key, objective):
    """Order 2 along a random direction of the whole field (measured 1.986–2.001)."""
    scene = write_scene(tmp_path, text)
    J, (g,) = _solve(scene, ONE_STEP, objective, [key])
    rng = np.random.default_rng(5)
    box = {}

    def take(model):
        f = _field(model, key)
        box["delta"] = _direction(f, key, rng)
        box["f0"] = f.x.array.copy()

    _solve(scene, ONE_STEP, objective, change=take)
    delta = box["delta"]
    slope = float(g.nodal @ delta)
    h0 = 0.02
    r2, r1 = [], []
    for i in range(3):
        h = h0 / 2**i

        def step(model, h=h):
            f = _field(model, key)
            f.x.array[:] = box["f0"] + h * delta

        Jh, _ = _solve(scene, ONE_STEP, objective, change=step)
        r2.append(abs(Jh - J - h * slope))
        r1.append(abs(Jh - J))
    orders2 = [math.log2(r2[i] / r2[i + 1]) for i in range(2)]
    orders1 = [math.log2(r1[i] / r1[i + 1]) for i in range(2)]
    print(f"{key}: g·δ = {slope:.6e}, r2 {r2}, orders {orders2}, first-order {orders1}")
    assert all(abs(o - 2.0) < 0.2 for o in orders2), orders2
    assert all(abs(o - 1.0) < 0.2 for o in orders1), orders1


def test_random_cells_against_central_differences(tmp_path):
    """Five cells of the thickness field (DG2, a formula), each moved uniformly by
    ±1e-4 of its value: the per-cell gradient within 1e-6 (reached 3e-8, the
    differences' own error)."""
    from rftfem import compat

    scene = write_scene(tmp_path, STRIP)
    sets = [*ONE_STEP, 'shell.thickness="0.12 - 0.004*X"']
    J, (g,) = _solve(scene, sets, "tip_uz@end", ["shell.thickness"])
    n_cells = len(g.cells.x.array)
    cells = np.random.default_rng(11).choice(n_cells, size=5, replace=False)
    for c in cells:

        def moved(sign, c=c):
            def change(model):
                f = model.material["t"]
                dofs = compat.cell_dofs(f.function_space)[c]
                f.x.array[dofs] += sign * 1e-4 * f.x.array[dofs].mean()
                box[sign] = 1e-4 * f.x.array[dofs].mean() / (1 + sign * 1e-4)

            return change

        box = {}
        up, _ = _solve(scene, sets, "tip_uz@end", change=moved(+1))
        down, _ = _solve(scene, sets, "tip_uz@end", change=moved(-1))
        fd = (up - down) / (2 * box[+1])
        cell_dof = compat.cell_dofs(g.cells.function_space)[c, 0]
        got = g.cells.x.array[cell_dof]
        print(
            f"cell {c}: adjoint {got:.10e}, central difference {fd:.10e}, {abs(got / fd - 1):.2e}"
        )
        assert abs(got / fd - 1) < 1e-6


def test_tapered_cantilever_closed_form(tmp_path):
    """dw_tip/dt per column of cells (10 × 0.5 of the 20 × 1 strip's columns summed
    over the width) against the closed form: within 1 % (reached 0.25 %, the tip's
    column, where the discretisation errs most; the root's 7e-6)."""
    scene = write_scene(tmp_path, TAPERED)
    J, (g,) = _solve(scene, [], "tip_uz@end", ["shell.thickness"])
    V0 = g.cells.function_space
    x = V0.tabulate_dof_coordinates()[:, 0]
    L, n = 10.0, 20
    column = np.minimum((x / (L / n)).astype(int), n - 1)
    ours = np.bincount(column, weights=g.cells.x.array[: len(x)], minlength=n)
    exact = tapered_deflection_gradient(
        1e-5, L, 1.0, 1.2e6, lambda X: 0.15 - 0.01 * X, np.linspace(0.0, L, n + 1)
    )
    error = np.abs(ours / exact - 1)
    print(
        f"per column: largest error {error.max():.2e} (column {error.argmax()}), "
        f"root {error[0]:.2e}"
    )
    assert error.max() < 1e-2


def test_profile_gradient_carries_the_cells(tmp_path):
    """The same taper as a profile (11 points along X, linear: equal to the formula at
    every node): the cells' gradients agree with the formula's to 2e-9, the
    profile's values sum to the cells' total (the weights at each node sum to 1), and
    two grid values moved by ±1e-4 of themselves in the file give the profile's
    gradient within 1e-6 (reached 1.7e-8).

    The two fields agree at the nodes to 1e-16, but each gradient passes through two
    solves (the state and its adjoint) whose round-off depends on the BLAS kernels:
    the largest relative difference of a cell was 5.5e-11 to 1.7e-10 across CPUs and
    ``OPENBLAS_CORETYPE`` (Cooperlake, SkylakeX, Haswell, Sandybridge; both stacks),
    about the same scaled by the largest gradient, so it is not the small gradients
    near the free end.  The bound is about 10 times the largest."""
    scene = write_scene(tmp_path, TAPERED)
    X = np.linspace(0, 10, 11)

    def write(name, values):
        (tmp_path / name).write_text(
            "X,Y,Z,t\n" + "".join(f"{float(x)!r},0,0,{float(v)!r}\n" for x, v in zip(X, values)),
            encoding="utf-8",
        )

    t = 0.15 - 0.01 * X
    write("t.csv", t)
    _, (formula,) = _solve(scene, [], "tip_uz@end", ["shell.thickness"])
    _, (profile,) = _solve(scene, ['shell.thickness="t.csv"'], "tip_uz@end", ["shell.thickness"])
    a, b = formula.cells.x.array, profile.cells.x.array
    print(
        f"cells' gradients, formula against profile: {np.abs(a / b - 1).max():.2e}; "
        f"scaled by the largest {np.abs(a - b).max() / np.abs(b).max():.2e}"
    )
    assert np.allclose(a, b, rtol=2e-9, atol=0), np.abs(a / b - 1).max()
    points, values = profile.profile
    assert points.shape == (11, 3)
    assert abs(values.sum() / b.sum() - 1) < 1e-12
    assert np.all(values < 0)  # thicker anywhere: a smaller deflection
    for k in (3, 8):
        h = 1e-4 * t[k]
        J = []
        for sign in (1, -1):
            moved = t.copy()
            moved[k] += sign * h
            write(f"t{k}{sign}.csv", moved)
            J.append(_solve(scene, [f'shell.thickness="t{k}{sign}.csv"'], "tip_uz@end")[0])
        fd = (J[0] - J[1]) / (2 * h)
        print(
            f"grid point X = {X[k]}: adjoint {values[k]:.10e}, central difference "
            f"{fd:.10e}, {abs(values[k] / fd - 1):.2e}"
        )
        assert abs(values[k] / fd - 1) < 1e-6


_READ_CELLS = """
import json, sys
import numpy as np
import pyvista as pv
grid = [b for b in pv.read(sys.argv[1]) if "gradient" in b.cell_data][0]
values = np.asarray(grid.cell_data["gradient"])
print(json.dumps({"dtype": str(values.dtype), "x": grid.cell_centers().points[:, 0].tolist(),
                  "values": values.tolist()}))
"""


def test_outputs_of_a_field_gradient(tmp_path):
    """gradient.json (the value, the mass and volume, the files), gradient-KEY.csv (the
    profile's gradient, X,Y,Z,dJ/dvalue) and gradient-KEY.xdmf, read back by VTK's
    XDMF reader (as ParaView does, in a child process) as doubles equal to the cells'
    gradients."""
    import json
    import subprocess
    import sys

    from conftest import ROOT

    from rftfem.studies.gradient_runs import run_with_field_gradients

    scene = write_scene(tmp_path, TAPERED)
    X = np.linspace(0, 10, 11)
    (tmp_path / "t.csv").write_text(
        "X,Y,Z,t\n" + "".join(f"{float(x)!r},0,0,{0.15 - 0.01 * float(x)!r}\n" for x in X),
        encoding="utf-8",
    )
    out = tmp_path / "run"
    status, J, fields = run_with_field_gradients(
        scene, ['shell.thickness="t.csv"'], out, ["shell.thickness"], "tip_uz@end"
    )
    assert status == 0
    g = fields["shell.thickness"]
    data = json.loads((out / "gradient.json").read_text())
    entry = data["fields"]["shell.thickness"]
    assert data["value"] == J and entry["volume"] == pytest.approx(1.0, rel=1e-12)
    assert entry["uniform"] == pytest.approx(g.cells.x.array.sum(), rel=1e-12)
    rows = np.loadtxt(out / entry["profile"], delimiter=",", skiprows=1)
    np.testing.assert_allclose(rows[:, 0], X)
    np.testing.assert_allclose(rows[:, 3], g.profile[1], rtol=1e-15)
    done = subprocess.run(
        [sys.executable, "-c", _READ_CELLS, str(out / entry["cells"])],
        capture_output=True,
        text=True,
        timeout=600,
        cwd=ROOT,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    back = json.loads(done.stdout.strip().splitlines()[-1])
    assert back["dtype"] == "float64"
    x = g.cells.function_space.tabulate_dof_coordinates()[:, 0]
    ours = g.cells.x.array[np.argsort(x)]
    theirs = np.asarray(back["values"])[np.argsort(back["x"])]
    np.testing.assert_allclose(theirs, ours, rtol=1e-14, atol=0)


def test_magnetization_profile_against_central_differences(tmp_path):
    """The magnetized half of the unsymmetric strip given as a profile (6 points along
    X, each a vector): the gradient by two grid vectors' components against central
    differences of the file's values at ±1e-4 of the magnetization, within 2e-9
    (reached 2.0e-10 and 1.2e-10 on the two stacks, ≤ 2.5e-10 under the other OpenBLAS
    kernels), and written as X,Y,Z,dJ/dmx,dJ/dmy,dJ/dmz.  Broke: the differences taken at
    ±1e-3 (a truncation error 100 times as large) → 2.4e-9, which the earlier bound,
    1e-6, let pass."""
    from rftfem.studies.gradient_runs import run_with_field_gradients

    text = MAGNET.replace(
        """magnetization = 100.0
direction = [1.0, 0.0, 0.0]""",
        'profile = "m.csv"',
    )
    scene = write_scene(tmp_path, text)
    X = np.linspace(5.0, 10.0, 6)
    M = np.column_stack([100.0 + 10.0 * (X - 5.0), np.zeros(6), 20.0 * np.sin(X)])

    def write(name, values):
        (tmp_path / name).write_text(
            "X,Y,Z,mx,my,mz\n"
            + "".join(
                f"{float(x)!r},0,0,{float(a)!r},{float(b)!r},{float(c)!r}\n"
                for x, (a, b, c) in zip(X, values)
            ),
            encoding="utf-8",
        )

    write("m.csv", M)
    key = "magnetic.parts.0.magnetization"
    status, J, fields = run_with_field_gradients(
        scene, ONE_STEP, tmp_path / "base", [key], "tip_ux@end", TIGHT
    )
    assert status == 0, (tmp_path / "base" / "run.log").read_text()
    points, grad = fields[key].profile
    rows = np.loadtxt(tmp_path / "base" / f"gradient-{key}.csv", delimiter=",", skiprows=1)
    np.testing.assert_allclose(rows[:, 3:], grad, rtol=1e-15)
    for k, c in ((2, 0), (4, 2)):
        h = 1e-4 * 100.0
        Js = []
        for sign in (1, -1):
            moved = M.copy()
            moved[k, c] += sign * h
            write(f"m{sign}.csv", moved)
            over = [*ONE_STEP, f'magnetic.parts.0.profile="m{sign}.csv"']
            status, Jh, _ = run_with_field_gradients(
                scene, over, tmp_path / f"r{k}{sign}", [key], "tip_ux@end", TIGHT
            )
            assert status == 0
            Js.append(Jh)
        fd = (Js[0] - Js[1]) / (2 * h)
        print(
            f"grid point {k}, component {c}: adjoint {grad[k, c]:.10e}, central "
            f"difference {fd:.10e}, {abs(grad[k, c] / fd - 1):.2e}"
        )
        assert abs(grad[k, c] / fd - 1) < 2e-9


def test_public_gradient_takes_a_scene_and_raises(tmp_path):
    """`rftfem.gradient` takes a Scene made in Python (no file: it was `(2, None, None)`
    with the reason only in run.log), returns the value, the scalar keys' derivatives
    as a Series and a field's per cell as a DataFrame, equal to the file route's within
    the round-off of its two solves (reached 3.8e-11; the bound is the one of
    test_profile_gradient_carries_the_cells); a bad key raises SceneError in one
    line."""
    import rftfem

    scene_file = write_scene(tmp_path, TAPERED)
    _, (cells,) = _solve(scene_file, [], "tip_uz@end", ["shell.thickness"])
    scene = rftfem.scene_from_toml(TAPERED, folder=tmp_path)
    got = rftfem.gradient(
        scene, "tip_uz@end", keys=["shell.E"], fields=["shell.thickness"], out=tmp_path / "api"
    )
    table = got.fields["shell.thickness"]
    assert list(table.columns) == ["x", "y", "z", "d/dshell.thickness"]
    np.testing.assert_allclose(
        table["d/dshell.thickness"].to_numpy(), cells.cells.x.array, rtol=2e-9, atol=0
    )
    # J ∝ 1/E: E dJ/dE = −J
    assert got.keys["shell.E"] * 1.2e6 == pytest.approx(-got.value, rel=1e-6)
    assert not list(tmp_path.glob(".rftfem-gradient-*"))
    with pytest.raises(rftfem.SceneError) as info:
        rftfem.gradient(scene, "tip_uz@end", keys=["shell.EE"], out=tmp_path / "bad")
    assert "\n" not in str(info.value) and "shell.EE" in str(info.value)
    from rftfem.studies.gradient_runs import run_with_field_gradients

    with pytest.raises(rftfem.SceneError, match="for a rftfem.Scene use rftfem.gradient"):
        run_with_field_gradients(scene, [], tmp_path / "old", ["shell.thickness"], "tip_uz@end")
