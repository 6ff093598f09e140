"""Adjoint sensitivities of static scenes (rftfem/studies/sensitivity.py, docs/model.md §7.6):
Taylor tests against the runs themselves, a closed form, the outputs of an ordinary
run, and the keys and objectives it refuses.

A Taylor test of a gradient g at p along a unit step: r₂(h) = |J(p + h) − J(p) − h g|
falls as h² when g is right (as h when it is not), r₁(h) = |J(p + h) − J(p)| as h.
Each key is stepped by h₀, h₀/2, h₀/4 (h₀ = 2 % of its value) and the observed
orders log₂ r(h)/r(h/2) must be 2 ± 0.2 and 1 ± 0.2.  Newton runs to 1e-13 so the
residuals (1e-7 to 1e-3 of J) stay far above the solver's tolerance.  The runs take
two load steps: the converged state is a function of the nodal directors alone, not
of the load path (docs/model.md §4.3), so the adjoint at the last step is the whole
derivative (test_against_central_differences).
"""

from __future__ import annotations

import json
import math

import pytest
from conftest import write_scene

TIGHT = ["-snes_atol", "1e-13", "-snes_stol", "1e-15"]

STRIP = """
title = "a cantilever strip bent and twisted by an end force"
[mesh]
kind = "strip"
length = 10.0
width = 1.0
divisions = [8, 1]
[[mesh.regions]]
name = "root"
x = [0.0, 5.0]
[shell]
thickness = 0.1
E = 1.2e6
nu = 0.3
[[shell.parts]]
region = "root"
E = 2.0e6
[time]
scheme = "static"
end = 1.0
dt = 0.5
[[boundary]]
where = "x=0"
fix = ["clamped"]
[[load]]
kind = "edge-force"
where = "x=L"
value = [0.0, 0.3, 1.0]
[[output.probes]]
name = "tip"
at = [10.0, 1.0, 0.0]
[output]
fields = false
"""
# the tip deflects by 2.05 (a fifth of the length) and turns 0.3 rad

MAGNET = """
title = "a strip with a magnetized half in a field across it, a point force and a pressure"
[mesh]
kind = "strip"
length = 10.0
width = 1.0
divisions = [8, 1]
[[mesh.regions]]
name = "magnet"
x = [5.0, 10.0]
[shell]
thickness = 0.1
E = 1.2e4
nu = 0.0
[time]
scheme = "static"
end = 1.0
dt = 0.5
[[boundary]]
where = "x=0"
fix = ["clamped"]
[magnetic]
[[magnetic.parts]]
region = "magnet"
magnetization = 100.0
direction = [1.0, 0.0, 0.0]
[magnetic.field]
strength = 2.0e-3
ramp_time = 1.0
direction = [0.0, 0.0, 1.0]
[[load]]
kind = "point-force"
at = [10.0, 0.5, 0.0]
value = [0.0, 0.01, 0.0]
[[load]]
kind = "pressure"
value = 0.001
[[output.probes]]
name = "tip"
at = [10.0, 1.0, 0.0]
[output]
fields = false
"""
# the tip deflects by 4.5 (45 % of the length); the magnetic couple and the follower
# pressure make the tangent unsymmetric

#: key: (its value in the scene, the --set that gives it the value v)
STRIP_KEYS = {
    "shell.E": (1.2e6, lambda v: f"shell.E={v!r}"),
    "shell.thickness": (0.1, lambda v: f"shell.thickness={v!r}"),
    "shell.nu": (0.3, lambda v: f"shell.nu={v!r}"),
    "shell.parts.0.E": (2.0e6, lambda v: f"shell.parts.0.E={v!r}"),
    "load.0.value.2": (1.0, lambda v: f"load.0.value=[0.0, 0.3, {v!r}]"),
}
MAGNET_KEYS = {
    "magnetic.field.strength": (2.0e-3, lambda v: f"magnetic.field.strength={v!r}"),
    "magnetic.parts.0.magnetization": (100.0, lambda v: f"magnetic.parts.0.magnetization={v!r}"),
    "load.0.value.1": (0.01, lambda v: f"load.0.value=[0.0, {v!r}, 0.0]"),
    "load.1.value": (0.001, lambda v: f"load.1.value={v!r}"),
    "shell.thickness": (0.1, lambda v: f"shell.thickness={v!r}"),
}


def _objective(scene, objective, folder, overrides=()):
    from rftfem.studies.gradient_runs import run_with_gradient

    status, J, _ = run_with_gradient(scene, list(overrides), folder, [], objective, TIGHT)
    assert status == 0, (folder / "run.log").read_text()
    return J


def _taylor(tmp_path, text, keys, objective, h0=0.02):
    """The gradient of ``objective`` by ``keys``, then each key's Taylor residuals;
    returns ``{key: (orders of r₂, orders of r₁, r₂)}``."""
    from rftfem.studies.gradient_runs import run_with_gradient

    scene = write_scene(tmp_path, text)
    status, J, grad = run_with_gradient(scene, [], tmp_path / "base", list(keys), objective, TIGHT)
    assert status == 0, (tmp_path / "base" / "run.log").read_text()
    out = {}
    for (key, (value, override)), g in zip(keys.items(), grad):
        steps = [h0 * value / 2**i for i in range(3)]
        Js = [
            _objective(scene, objective, tmp_path / f"{key}_{i}", [override(value + h)])
            for i, h in enumerate(steps)
        ]
        r2 = [abs(Jh - J - h * g) for Jh, h in zip(Js, steps)]
        r1 = [abs(Jh - J) for Jh in Js]
        orders = [[math.log2(r[i] / r[i + 1]) for i in range(2)] for r in (r2, r1)]
        print(
            f"{objective}, {key}: dJ/dp = {g:.6e}; r2 {r2[0]:.2e} {r2[1]:.2e} {r2[2]:.2e}, "
            f"orders {orders[0][0]:.3f} {orders[0][1]:.3f}; first-order residual orders "
            f"{orders[1][0]:.3f} {orders[1][1]:.3f}"
        )
        out[key] = (*orders, r2)
    return out


def _assert_orders(results):
    for key, (second, first, _) in results.items():
        assert all(abs(o - 2.0) < 0.2 for o in second), f"{key}: Taylor orders {second}"
        assert all(abs(o - 1.0) < 0.2 for o in first), f"{key}: first-order orders {first}"


def test_taylor_probe_displacement(tmp_path):
    """A probe's displacement (a point evaluation) by the material, a part's modulus and
    a load component: order 2 (measured 1.99-2.02 on both stacks)."""
    _assert_orders(_taylor(tmp_path, STRIP, STRIP_KEYS, "tip_uz@end"))


def test_taylor_stored_energy(tmp_path):
    """The stored energy depends on E and t itself (∂J/∂p) and is stationary on no
    dof, the clamped ones included: the adjoint's right-hand side must be cut there."""
    keys = {k: STRIP_KEYS[k] for k in ("shell.E", "shell.thickness", "load.0.value.2")}
    _assert_orders(_taylor(tmp_path, STRIP, keys, "elastic_energy@end"))


def test_taylor_unsymmetric_tangent(tmp_path):
    """Magnetic couples and a follower pressure: the tangent is unsymmetric, so the
    adjoint needs Kᵀ; the field's strength, the magnetization, a point force's
    component, the pressure and the thickness."""
    _assert_orders(_taylor(tmp_path, MAGNET, MAGNET_KEYS, "tip_ux@end"))


@pytest.mark.parametrize("dt, tolerance", [(1.0, 1e-7), (0.5, 1e-7)])
def test_against_central_differences(tmp_path, dt, tolerance):
    """Central differences at 1e-4 of each value (their own error 1e-8 of the gradient
    or less).  The adjoint of the last step's residual is the whole derivative, after
    one load step or two: the state the steps reach depends on the nodal directors
    alone, not on the triads the path left (docs/model.md §4.3).  Agreement within
    1e-7 for both (reached 1.6e-8; on the state after the last triad update, not the
    one the step converged to, ν is 1e-4 off; two steps were 6.5e-5 off, ν, with the
    interpolated rotation vectors of earlier versions)."""
    from rftfem.studies.gradient_runs import run_with_gradient

    scene = write_scene(tmp_path, STRIP)
    step = [f"time.dt={dt}"]
    status, _, grad = run_with_gradient(
        scene, step, tmp_path / "base", list(STRIP_KEYS), "tip_uz@end", TIGHT
    )
    assert status == 0
    errors = {}
    for (key, (value, override)), g in zip(STRIP_KEYS.items(), grad):
        h = 1e-4 * value
        J = [
            _objective(scene, "tip_uz@end", tmp_path / f"{key}{s}", step + [override(value + s)])
            for s in (h, -h)
        ]
        errors[key] = (J[0] - J[1]) / (2 * h) / g - 1
    print(
        f"{1 / dt:g} load step(s): adjoint against central differences: "
        + ", ".join(f"{k} {e:.1e}" for k, e in errors.items())
    )
    assert all(abs(e) < tolerance for e in errors.values()), errors


def test_linear_cantilever_closed_form(tmp_path):
    """A tip force P deflecting the tip by 1e-4 L: w = P L³/(3 E I) + P L/(k G A)
    (Timoshenko, I = b t³/12, k = 5/6, ν = 0), so dw/dE = −w/E, dw/dP = w/P and
    dw/dt = −(3 w_b + w_s)/t.  On 16×1 cells w is 2.2e-5 below it; the gradient must
    meet the closed form within 2e-4, and the discrete model's own scaling (w ∝ 1/E and
    ∝ P in the linear range) within 1e-6."""
    from rftfem.studies.gradient_runs import run_with_gradient

    L, b, t, E = 10.0, 1.0, 0.1, 1.2e6
    I, G, k = b * t**3 / 12, E / 2, 5.0 / 6.0
    P = 1e-4 * 3 * E * I / L**2
    scene = write_scene(
        tmp_path, STRIP.replace('[[shell.parts]]\nregion = "root"\nE = 2.0e6\n', "")
    )
    status, J, (dE, dt, dP) = run_with_gradient(
        scene,
        [
            "mesh.divisions=[16, 1]",
            "shell.nu=0.0",
            f"load.0.value=[0.0, 0.0, {P!r}]",
            "load.0.ramp=constant",
            "time.dt=1.0",
        ],
        tmp_path / "out",
        ["shell.E", "shell.thickness", "load.0.value.2"],
        "tip_uz@end",
        TIGHT,
    )
    assert status == 0
    w_b, w_s = P * L**3 / (3 * E * I), P * L / (k * G * b * t)
    w = w_b + w_s
    errors = {
        "w": J / w - 1,
        "dw/dE": dE / (-w / E) - 1,
        "dw/dP": dP / (w / P) - 1,
        "dw/dt": dt / (-(3 * w_b + w_s) / t) - 1,
    }
    print(
        "relative errors against the closed form: "
        + ", ".join(f"{name} {e:.2e}" for name, e in errors.items())
    )
    assert all(abs(e) < 2e-4 for e in errors.values()), errors
    assert dE == pytest.approx(-J / E, rel=1e-6) and dP == pytest.approx(J / P, rel=1e-6)


def test_outputs_and_statuses_as_run_here(tmp_path):
    """The run writes what batch.run_here writes (probes and body rows to the bit), and
    gradient.json; a failed run and a bad scene give run_here's statuses and no value."""
    from rftfem.studies.batch import run_here
    from rftfem.studies.gradient_runs import run_with_gradient

    scene = write_scene(tmp_path, STRIP)
    assert run_here(scene, [], tmp_path / "plain") == 0
    status, J, grad = run_with_gradient(
        scene, [], tmp_path / "adjoint", ["shell.E", "load.0.value.2"], "tip_uz@end"
    )
    assert status == 0 and len(grad) == 2
    for name in ("probes.csv", "body.csv"):
        assert (tmp_path / "plain" / name).read_text() == (
            tmp_path / "adjoint" / name
        ).read_text(), name
    last = (tmp_path / "plain" / "probes.csv").read_text().splitlines()[-1].split(",")
    assert J == float(last[3])  # tip_uz of the last row: the same state
    saved = json.loads((tmp_path / "adjoint" / "gradient.json").read_text())
    assert saved == {
        "objective": "tip_uz@end",
        "value": J,
        "gradient": {"shell.E": grad[0], "load.0.value.2": grad[1]},
    }
    # Newton allowed one update and no cut: the run fails numerically
    failed = ["time.max_cuts=0", "load.0.value=[0.0, 0.0, 40.0]"]
    assert run_here(scene, failed, tmp_path / "f1", ["-snes_max_it", "1"]) == 3
    assert run_with_gradient(
        scene, failed, tmp_path / "f2", ["shell.E"], "tip_uz@end", ["-snes_max_it", "1"]
    ) == (3, None, None)
    assert "run failed" in (tmp_path / "f2" / "run.log").read_text()
    assert run_with_gradient(scene, ["shell.E=-1"], tmp_path / "f3", ["shell.E"], "tip_uz@end") == (
        2,
        None,
        None,
    )


@pytest.mark.parametrize(
    "key, objective, said",
    [
        ("shell.axis", "tip_uz@end", "gradient key 'shell.axis': expected one of shell.E"),
        ("load.0.value", "tip_uz@end", "give its component"),
        ("load.3.value.0", "tip_uz@end", "index 3 out of range"),
        ("shell.parts.1.E", "tip_uz@end", "index 1 out of range"),
        ("magnetic.field.strength", "tip_uz@end", "the scene has no [magnetic]"),
        ("shell.E", "tip_uz@0.5", "objective 'tip_uz@0.5': expected one of PROBE_ux@end"),
        ("shell.E", "max(tip_uz)", "expected one of PROBE_ux@end"),
        ("shell.E", "nose_uz@end", "(probes: tip)"),
        ("shell.E", "drag_power@end", "elastic_energy@end"),
    ],
)
def test_refused_keys_and_objectives(tmp_path, key, objective, said):
    """What cannot be differentiated is a SceneError of one line naming what can, before
    any run; so is a scene that is not static."""
    from rftfem.errors import SceneError
    from rftfem.studies.gradient_runs import run_with_gradient

    scene = write_scene(tmp_path, STRIP)
    with pytest.raises(SceneError) as err:
        run_with_gradient(scene, [], tmp_path / "out", [key], objective)
    assert said in str(err.value) and "\n" not in str(err.value)
    assert not (tmp_path / "out" / "probes.csv").exists()
    assert said in (tmp_path / "out" / "run.log").read_text()


def test_refused_scheme_and_supports(tmp_path):
    """A scene in time is refused; ``supports`` (what rftfem optimize asks first) says
    the same as the checks, from the keys' syntax alone or with the scene."""
    from rftfem.errors import SceneError
    from rftfem.scene.reading import load_scene
    from rftfem.studies.sensitivity import check_request, supports

    path = write_scene(tmp_path, STRIP)
    scene = load_scene(path, ["time.scheme=backward-euler"])
    with pytest.raises(SceneError, match="static runs"):
        check_request(scene, ["shell.E"], "tip_uz@end")
    assert not supports(["shell.E"], "tip_uz@end", scene)
    static = load_scene(path)
    assert supports(["shell.E", "load.0.value.2"], "tip_uz@end")
    assert supports(["shell.parts.0.thickness"], "elastic_energy@end", static)
    assert not supports(["shell.axis"], "tip_uz@end")
    assert not supports(["shell.E"], "mean(tip_uz)")
    assert supports(["shell.E"], "nose_uz@end") and not supports(["shell.E"], "nose_uz@end", static)
