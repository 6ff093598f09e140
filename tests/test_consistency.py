"""The Jacobian is the exact derivative of the residual, director map and drag included."""

import numpy as np
import pytest
import ufl
from conftest import build_model, write_scene

from rftfem import compat
from rftfem.integration.schemes import make_scheme
from rftfem.meshes import build_body
from rftfem.model.shell_model import Model
from rftfem.scene.reading import load_scene

SCENE = """
title = "random state for a Taylor test"
[mesh]
length = 4.0
width = 1.0
divisions = [4, 2]
[shell]
thickness = 0.1
E = 1.0e4
nu = 0.3
density = 1.0e-3
[time]
scheme = "generalized-alpha"
rho_inf = 0.8
dt = 0.01
end = 1.0
[[boundary]]
where = "x=0"
fix = ["clamped"]
[[load]]
kind = "edge-moment"
where = "x=L"
value = [1.0, 2.0, 0.5]
ramp = "constant"
[[load]]
kind = "edge-force"
where = "y=W"
value = [0.3, -0.2, 1.0]
ramp = "constant"
[fluid]
drag = [0.02, 0.05, 0.11]
"""


def _assemble_residual(model):
    """(1 − α_f) F(w) + M a(w) as a numpy array (no boundary conditions)."""
    out = 0
    af = float(model.coef["alpha_f"].value)
    for form, scale in ((model.forces_form, 1 - af), (model.inertia_form, 1.0)):
        if form is None:
            continue
        b = compat.create_vector(form, model.W)
        compat.assemble_vector(b, form)
        b.ghostUpdate(addv=2, mode=1)  # ADD, REVERSE
        out = out + scale * b.getArray().copy()
        b.destroy()
    return out


def _jacobian_action(model, delta):
    A = compat.create_matrix(model.jacobian_form)
    compat.assemble_matrix(A, model.jacobian_form, [])
    A.assemble()
    x = A.createVecRight()
    x.setArray(delta)
    y = A.createVecLeft()
    A.mult(x, y)
    out = y.getArray().copy()
    for obj in (A, x, y):
        obj.destroy()
    return out


@pytest.mark.parametrize("theta_amplitude", [0.0, 0.6])
def test_taylor_remainder_is_second_order(tmp_path, theta_amplitude):
    """|R(w + εδ) − R(w) − ε J δ| falls as ε² (observed order ≥ 1.9), for a random
    rotated triad, random displacement and velocity state (so the RFT drag, with
    its frame and area ratio, is active and anisotropic), and θ = 0 (the start of
    every Newton solve) or θ of 0.6 rad (the closed-form branch of the rotation)."""
    scene = load_scene(write_scene(tmp_path, SCENE))
    model = Model(scene, build_body(model_comm(), scene["mesh"]))
    model.set_coefficients(make_scheme(scene["time"]).coefficients(0.01))
    model.set_time(0.5)
    assert "drag" in model.effects
    rng = np.random.default_rng(1)
    n_local = model.W.dofmap.index_map.size_local * model.W.dofmap.index_map_bs
    th = model.theta_dofs[model.theta_dofs < n_local]
    w0 = _random_state(model, rng, theta_amplitude)
    delta = rng.uniform(-1, 1, len(w0))
    jd = _jacobian_action(model, delta[:n_local])
    assert np.abs(jd[np.isin(np.arange(n_local), th)]).max() > 0, "rotation rows must be coupled"
    orders, remainders, _ = _orders(lambda: _assemble_residual(model), w0, delta, jd, model)
    print(f"theta amplitude {theta_amplitude}: remainders {remainders}, orders {orders}")
    assert orders.min() >= 1.9


EVERY_EFFECT = """
title = "every effect with a state-dependent term, for a Taylor test"
[mesh]
length = 4.0
width = 1.0
divisions = [4, 2]
[[mesh.regions]]
name = "end"
x = [3.0, 4.0]
[shell]
thickness = 0.1
E = 1.0e4
nu = 0.3
density = 1.0e-3
[time]
scheme = "generalized-alpha"
rho_inf = 0.8
dt = 0.01
end = 1.0
[[hinge]]
where = "x=2"
stiffness = 0.7
[[boundary]]
where = "x=0"
fix = ["clamped"]
[[load]]
kind = "pressure"
value = 0.05
ramp = "constant"
[[load]]
kind = "gravity"
value = [0.0, 0.0, -9810.0]
ramp = "constant"
[[load]]
kind = "edge-moment"
where = "x=L"
value = [1.0, 2.0, 0.5]
ramp = "constant"
[fluid]
drag = [0.02, 0.05, 0.11]
[magnetic]
[[magnetic.parts]]
region = "end"
magnetization = 3.0
direction = [0.6, 0.3, 0.74]
[magnetic.field]
strength = 0.4
direction = [0.2, 0.9, -0.4]
"""


def _random_state(model, rng, theta_amplitude):
    """A far-from-reference triad (two random finite rotations of every node), random
    u, v, a and iterate; returns the iterate."""
    for _ in range(2):
        model.w.x.array[:] = 0.0
        model.w.x.array[model.theta_dofs] = rng.uniform(-1.5, 1.5, len(model.theta_dofs))
        model.update_triad()
    for f in (model.u_n, model.v_n, model.a_n):
        f.x.array[:] = rng.uniform(-0.1, 0.1, len(f.x.array))
    model.w.x.array[:] = rng.uniform(-0.1, 0.1, len(model.w.x.array))
    model.w.x.array[model.theta_dofs] = rng.uniform(
        -theta_amplitude, theta_amplitude, len(model.theta_dofs)
    )
    return model.w.x.array.copy()


def _orders(residual, w0, delta, jd, model, eps=(1e-2, 5e-3, 2.5e-3, 1.25e-3), field=None):
    """Observed orders of the Taylor remainder |R(w₀ + εδ) − R(w₀) − ε J δ|, and the
    remainders; ``field``: the Function perturbed (default ``model.w``)."""
    field = model.w if field is None else field
    r0 = residual()
    remainders = []
    for e in eps:
        field.x.array[:] = w0 + e * delta
        remainders.append(np.linalg.norm(residual() - r0 - e * jd))
    field.x.array[:] = w0
    rem = np.array(remainders)
    with np.errstate(divide="ignore", invalid="ignore"):  # a dead load's zeros
        return np.log(rem[:-1] / rem[1:]) / np.log(2), rem, r0


@pytest.mark.long
@pytest.mark.both_stacks
def test_every_effect_taylor_remainder(tmp_path):
    """Every effect with a state-dependent term in one scene (elasticity, a hinge
    spring with its two-coloured rotations, inertia, drag, a magnetic part with an
    out-of-plane magnetization, a follower pressure, gravity, an edge moment on the
    director), on a random rotated state: the model's own Jacobian form (α_f-weighted,
    mixed-point corrections included, as the solver assembles it) against its residual
    falls as ε² (orders ≥ 1.9; reached 2.000), and so does each effect's term alone
    against its
    ``ufl.derivative``.  Gravity, a dead load per reference area, has no derivative:
    its remainder is round-off."""
    model = build_model(EVERY_EFFECT, tmp_path, compile_forms=True)
    assert set(model.effects) >= {
        "elasticity",
        "hinge-spring",
        "drag",
        "magnetic",
        "pressure",
        "gravity",
        "edge-loads",
    }, set(model.effects)
    assert model.n_colours == 2 and model.inertia is not None
    model.set_coefficients(make_scheme(model.scene["time"]).coefficients(0.01))
    model.set_time(0.5)
    rng = np.random.default_rng(3)
    w0 = _random_state(model, rng, 0.4)
    n_local = model.W.dofmap.index_map.size_local * model.W.dofmap.index_map_bs
    delta = rng.uniform(-1, 1, len(w0))
    orders, rem, _ = _orders(
        lambda: _assemble_residual(model),
        w0,
        delta,
        _jacobian_action(model, delta[:n_local]),
        model,
    )
    print(f"whole model: remainders {rem}, orders {orders}")
    assert orders.min() >= 1.9
    for name, term in model.effects.items():
        orders, rem, r0, jd = term_taylor(model, term, w0, delta)
        print(
            f"{name}: |R| {np.linalg.norm(r0):.3e}, |J δ| {np.linalg.norm(jd):.3e}, "
            f"remainders {rem}, orders {orders}"
        )
        assert np.linalg.norm(r0) > 0, name
        if name == "gravity":
            assert np.linalg.norm(jd) == 0.0 and rem.max() <= 1e-13 * np.linalg.norm(r0), name
        else:
            # the largest ε is not yet asymptotic for the spring (1.91 there)
            assert np.linalg.norm(jd) > 0 and orders[1:].min() >= 1.9, name


def vector_of(model, F, V=None):
    """A function assembling the compiled 1-form ``F`` (on ``V``, default ``model.W``)
    of the current state into a numpy array (no boundary conditions, no ghost update)."""

    def residual():
        b = compat.create_vector(F, model.W if V is None else V)
        compat.assemble_vector(b, F)
        out = b.getArray().copy()
        b.destroy()
        return out

    return residual


def term_taylor(model, term, w0, delta):
    """The Taylor test of one term (a 1-form on the forms' unknowns ``model.z``) against
    its ``ufl.derivative`` at ``z₀ = Φ(w₀)`` (the nodal directors of ``w₀``) along
    ``delta`` (resized to z): (orders, remainders, R(z₀), J δ)."""
    F = compat.form(term)
    J = compat.form(ufl.derivative(term, model.z, ufl.TrialFunction(model.Z)))
    residual = vector_of(model, F, model.Z)
    z0 = model.directors.map(w0, out=np.zeros(len(model.z.x.array)))
    model.z.x.array[:] = z0
    delta = np.resize(delta, len(z0))

    n_local = model.Z.dofmap.index_map.size_local * model.Z.dofmap.index_map_bs
    A = compat.create_matrix(J)
    compat.assemble_matrix(A, J, [])
    A.assemble()
    x, y = A.createVecRight(), A.createVecLeft()
    x.setArray(delta[:n_local])
    A.mult(x, y)
    jd = y.getArray().copy()
    for obj in (A, x, y):
        obj.destroy()
    orders, rem, r0 = _orders(residual, z0, delta, jd, model, field=model.z)
    return orders, rem, r0, jd


def model_comm():
    from mpi4py import MPI

    return MPI.COMM_SELF


def test_drag_alone_taylor_remainder(tmp_path):
    """The drag term alone (frame, area ratio and velocity all depend on the state):
    its ``ufl.derivative`` Jacobian passes the same Taylor test, and the term is
    not symmetric (RFT is non-conservative)."""
    model = build_model(SCENE, tmp_path)
    model.set_coefficients(make_scheme(model.scene["time"]).coefficients(0.01))
    rng = np.random.default_rng(7)
    for f in (model.u_n, model.v_n, model.a_n):
        f.x.array[:] = rng.uniform(-0.1, 0.1, len(f.x.array))
    model.w.x.array[:] = rng.uniform(-0.3, 0.3, len(model.w.x.array))
    model.directors.sync()  # z = Φ(w): the forms' unknowns, perturbed below
    drag = model.effects["drag"]
    F = compat.form(drag)
    J = compat.form(ufl.derivative(drag, model.z, ufl.TrialFunction(model.Z)))
    residual = vector_of(model, F, model.Z)

    A = compat.create_matrix(J)
    compat.assemble_matrix(A, J, [])
    A.assemble()
    dense = A.convert("dense").getDenseArray().copy()  # a view into A
    A.destroy()
    assert np.abs(dense - dense.T).max() > 1e-3 * np.abs(dense).max(), "drag tangent is symmetric?"
    w0 = model.z.x.array.copy()
    delta = rng.uniform(-1, 1, len(w0))
    r0, jd = residual(), dense @ delta
    remainders = []
    for e in (1e-2, 5e-3, 2.5e-3):
        model.z.x.array[:] = w0 + e * delta
        remainders.append(np.linalg.norm(residual() - r0 - e * jd))
    orders = np.log(np.array(remainders[:-1]) / remainders[1:]) / np.log(2)
    print(f"drag alone: |R| = {np.linalg.norm(r0):.3e}, remainders {remainders}, orders {orders}")
    assert np.linalg.norm(r0) > 0 and orders.min() >= 1.9
