"""Reactions of named ``[[boundary]]`` entries (rftfem/model/reactions.py): the force and
moment each carries, against the loads they hold up.

The forces and the moments balance to the solver's residual on the free rows: a
rigid virtual rotation through the rotation dofs turns every nodal director by
it, and the interpolated director with them (docs/model.md §4.2), so the elastic
forces carry no net moment of their own.  (With the interpolated rotation vectors
of the earlier versions they did, falling with the mesh: 2e-8 of the load's
moment on the cantilever, 2.3e-4 on a coarse, strongly bent magnetic strip,
2.7e-3 on a coarse cylinder panel.)  The tolerances below are about 10x what the
runs reach.
"""

import numpy as np
import pytest
import ufl
from conftest import run_scene, write_scene
from test_curved_shells import quarter_cylinder

CANTILEVER = """
title = "cantilever under an oblique tip force"
[mesh]
length = 10.0
width = 1.0
divisions = [16, 2]
[shell]
thickness = 0.1
E = 1.2e6
nu = 0.0
{density}
[time]
end = {end}
dt = {dt}
{scheme}
[[boundary]]
name = "clamp"
where = "x=0"
fix = ["clamped"]
[[load]]
kind = "point-force"
at = [10.0, 0.3, 0.0]
value = [0.3, 0.2, -1.0]
{ramp}
[[output.probes]]
name = "p"
at = [10.0, 0.3, 0.0]
[output]
fields = false
"""
FORCE = np.array([0.3, 0.2, -1.0])


def body_rows(sim, name):
    """The reaction columns (n, 6) of ``name`` in body.csv, and the times."""
    from rftfem.outputs.quantities import read_csv

    header, rows = read_csv(sim.out_dir / "body.csv")
    cols = [header.index(f"{name}_{c}") for c in ("Fx", "Fy", "Fz", "Mx", "My", "Mz")]
    return rows[:, 0], rows[:, cols]


def test_cantilever_reaction_holds_the_tip_force(tmp_path):
    """Large deflection (the tip drops 28 % of the length): the clamp carries −P and −x_p × P,
    x_p the load point where it has moved to.  Reached: force 1e-11, moment 5.4e-13."""
    scene = write_scene(
        tmp_path, CANTILEVER.format(density="", end=1.0, dt=0.25, scheme="", ramp="")
    )
    sim = run_scene(scene, out_dir=tmp_path / "out")
    times, r = body_rows(sim, "clamp")
    force_err = moment_err = 0.0
    for (t, probe), row in zip(sim.history[1:], r[1:]):
        load = t * FORCE
        x = np.array([10.0, 0.3, 0.0]) + probe[0]
        moment = np.cross(x, load)
        force_err = max(force_err, np.abs(row[:3] + load).max() / np.linalg.norm(load))
        moment_err = max(moment_err, np.abs(row[3:] + moment).max() / np.linalg.norm(moment))
    tip = sim.history[-1][1][0]
    print(f"tip displacement {tip}; force error {force_err:.1e}, moment error {moment_err:.1e}")
    assert tip[2] < -2.5  # large deflection
    assert force_err < 1e-10 and moment_err < 1e-11


CYLINDER = """
title = "a quarter cylinder panel under pressure, clamped all round"
[mesh]
kind = "gmsh"
file = "cylinder.msh"
[shell]
thickness = 0.05
E = 1.0e4
nu = 0.3
[time]
end = 1.0
dt = 0.5
[[boundary]]
name = "a"
where = "sym_x"
fix = ["clamped"]
[[boundary]]
name = "b"
where = "sym_z"
fix = ["clamped"]
[[boundary]]
name = "c"
where = "bottom"
fix = ["clamped"]
[[boundary]]
name = "d"
where = "top"
fix = ["clamped"]
[[load]]
kind = "pressure"
value = {p}
[output]
fields = false
"""


def test_pressurised_curved_panel(tmp_path):
    """A follower pressure p on a quarter cylinder panel clamped on its four edges:
    its resultant is p ∫ n da and its moment p ∫ x × n da, and both depend on the
    boundary curve alone (Stokes), which the clamps hold where it was: the sum of
    the four reactions is −p ∫ N dA₀ and −p ∫ X × N dA₀ on the reference surface,
    here assembled from the mesh's own geometry.  Reached: force 1.0e-14, moment
    1.4e-14 on this coarse curved mesh (4 cells a quarter turn, the director turning
    22° from node to node; the interpolated rotation vectors of earlier versions
    left the elastic forces a net moment of 2.7e-3 here)."""
    from dolfinx import fem

    from rftfem.forms import kinematics

    quarter_cylinder(tmp_path / "cylinder.msh", 2.0, 3.0, 4)
    p = 1.0
    sim = run_scene(write_scene(tmp_path, CYLINDER.format(p=p)), out_dir=tmp_path / "out")
    mesh = sim.model.mesh
    G1, G2 = kinematics.covariant_basis(mesh)
    jac = ufl.cross(G1, G2)
    N = jac / ufl.sqrt(ufl.dot(jac, jac))
    X = ufl.SpatialCoordinate(mesh)
    dx = ufl.Measure("dx", domain=mesh, metadata={"quadrature_degree": 8})
    area = np.array([fem.assemble_scalar(fem.form(N[i] * dx)) for i in range(3)])
    first = np.array([fem.assemble_scalar(fem.form(ufl.cross(X, N)[i] * dx)) for i in range(3)])
    total = sum(body_rows(sim, name)[1][-1] for name in "abcd")
    bulge = np.abs(sim.model.u_n.x.array).max()
    force_err = np.abs(total[:3] + p * area).max() / (p * np.linalg.norm(area))
    moment_err = np.abs(total[3:] + p * first).max() / (p * np.linalg.norm(first))
    print(
        f"bulge {bulge:.3f}; force {total[:3]} against {-p * area}: {force_err:.1e}; "
        f"moment error {moment_err:.1e}"
    )
    assert bulge > 5e-3
    assert force_err < 5e-12 and moment_err < 2e-13


MAGNETIC = """
title = "a clamped magnetic strip bent by a field across it"
[mesh]
length = 4.0
width = 1.0
divisions = [8, 1]
[shell]
thickness = 0.1
E = 50.0
nu = 0.3
[time]
end = 1.0
dt = 0.25
[[boundary]]
name = "clamp"
where = "x=0"
fix = ["clamped"]
[[magnetic.parts]]
region = "all"
magnetization = 1.0
direction = [1.0, 0.0, 0.0]
[magnetic.field]
kind = "expression"
B = ["0", "0.01*t", "0.04*t"]
[output]
fields = false
"""


def test_magnetic_strip_reaction_is_the_field_couple(tmp_path):
    """A uniform field exerts no force and the couple Q × B on the body (Q its net
    magnetic moment, body.csv's moment columns): the clamp carries 0 and −Q × B.
    The field's own forces balance Q × B exactly, and the elastic forces of this
    coarse (8 cells), strongly bent soft strip carry no moment of their own (3.8e-4
    of it with the interpolated rotation vectors of earlier versions).
    Reached: force 1e-15 (5.7e-13 on the current stack), moment 6.2e-12."""
    from rftfem.outputs.quantities import read_csv

    sim = run_scene(write_scene(tmp_path, MAGNETIC), out_dir=tmp_path / "out")
    header, rows = read_csv(sim.out_dir / "body.csv")
    B = rows[-1, [header.index(f"field_{c}") for c in "xyz"]]
    Q = rows[-1, [header.index(f"moment_{c}") for c in "xyz"]]
    r = body_rows(sim, "clamp")[1][-1]
    couple = np.cross(Q, B)
    tip = sim.history[-1][1]
    print(f"Q × B = {couple}, clamp moment {r[3:]}, force {r[:3]}, tip {tip}")
    assert np.abs(couple).max() > 1e-3
    assert np.abs(r[:3]).max() < 5e-12 * np.abs(couple).max()
    assert np.abs(r[3:] + couple).max() < 6e-11 * np.abs(couple).max()


def test_dynamic_reaction_balances_load_inertia_and_drag(tmp_path):
    """Generalized-α (ρ∞ = 0.5) with drag: each step solves the blend
    (1 − α_f) F_{n+1} + α_f F_n + M a_{n+1−α_m} = 0, so the clamp's force is the blend
    of the load and the drag, plus the inertia force ∫ ρ t a_{n+1−α_m} dA₀, summed
    here from the model's own drag and inertia forms over the whole body.
    Reached: 2.4e-12 of the load."""
    from petsc4py import PETSc

    from rftfem import compat
    from rftfem.integration.schemes import Coefficients

    scene = write_scene(
        tmp_path,
        CANTILEVER.format(
            density="density = 1.0",
            end=0.2,
            dt=0.02,
            scheme='scheme = "generalized-alpha"\nrho_inf = 0.5\n[fluid]\ndrag = [0.5, 1.0, 2.0]',
            ramp="",
        ),
    )
    # the run starts at rest, unloaded and undeformed
    errors, forms = [], []
    previous = {"drag": np.zeros(3), "accel": np.zeros(3), "load": np.zeros(3)}

    def totals(model, form):
        """Σ over the whole body of an assembled 1-form's displacement rows, per axis."""
        vec = compat.create_vector(form, model.W)
        with vec.localForm() as local:
            local.set(0.0)
        compat.assemble_vector(vec, form)
        vec.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        n = model.W.dofmap.index_map.size_local * model.W.dofmap.index_map_bs
        values = np.zeros(3)
        for c in range(3):
            dofs = model.u_dofs[c::3]
            values[c] = vec.array[dofs[dofs < n]].sum()
        vec.destroy()
        return model.comm.allreduce(values)

    def check(sim):
        m = sim.model
        if not forms:
            # the forms on z, assembled as the solver does into w (rftfem/model/directors.py)
            forms.extend([m.mapped(m.effects["drag"]), m.mapped(m.inertia)])
        step = m.coefficients
        # after the step v_n, a_n hold its end values: the drag form at cv_v = 1
        # (v = v_n), the inertia form at ca_a = 1 (a = a_n)
        m.set_coefficients(Coefficients(cv_v=1.0, ca_a=1.0))
        drag, accel = totals(m, forms[0]), totals(m, forms[1])
        m.set_coefficients(step)
        load = sim.t / 0.2 * FORCE
        af, am = step.alpha_f, step.alpha_m
        blend = (
            (1 - af) * (drag - load)
            + af * (previous["drag"] - previous["load"])
            + (1 - am) * accel
            + am * previous["accel"]
        )
        errors.append(np.abs(sim.reactions.last[0, :3] - blend).max() / np.linalg.norm(FORCE))
        previous.update(drag=drag, accel=accel, load=load)

    run_scene(scene, out_dir=tmp_path / "out", observers=[check])
    print(f"{len(errors)} steps: largest error {max(errors):.1e} of the load")
    assert len(errors) >= 9 and max(errors) < 1e-10


@pytest.mark.parametrize(
    "bad, message",
    [
        (
            'name = "clamp"',
            "motion.0.name: expected a unique reaction name, found 'clamp' "
            "a second time (also boundary.0.name)",
        ),
    ],
)
def test_a_name_given_twice_is_refused(tmp_path, bad, message):
    from rftfem.errors import SceneError
    from rftfem.scene.reading import load_scene

    text = CANTILEVER.format(density="", end=1.0, dt=0.25, scheme="", ramp="") + (
        f'[[motion]]\n{bad}\nwhere = "x=L"\ncomponent = "uy"\nkind = "table"\n'
        "values = [[0, 0], [1, 0.1]]\n"
    )
    with pytest.raises(SceneError) as err:
        load_scene(write_scene(tmp_path, text))
    assert str(err.value) == message
