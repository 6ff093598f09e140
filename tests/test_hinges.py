"""Hinges: exact fold of a spring hinge, a free hinge turning against RFT drag (its
director jumping across the line), Purcell's three-link swimmer against its
exact rigid-link result (docs/hinges.md), an oblique
gmsh crease, and mpirun against serial with a partition across a hinge."""

from __future__ import annotations

import csv
import math
import subprocess
import sys

import numpy as np
import pytest
import rigid_links
import ufl
from conftest import DEMOS, ROOT, run_scene, write_scene

SCALLOP = DEMOS / "scallop.toml"

# --- a two-link strip: links 5 × 0.5 side by side, hinge along X at y = 0.5 ---------

L, ELL = 5.0, 0.5  # hinge length, link width

TWO_LINKS = """
title = "two links"
[mesh]
kind = "strip"
length = 5.0
width = 1.0
divisions = [4, 4]
[[mesh.regions]]
name = "fixed"
y = [0.0, 0.5]
[shell]
thickness = 0.1
E = {E}
nu = 0.0
[[hinge]]
where = "y=0.5"
stiffness = {k}
[[boundary]]
where = "{clamp}"
fix = ["clamped"]
[[load]]
kind = "edge-moment"
where = "y=W"
value = [{M!r}, 0.0, 0.0]
{extra}
[[output.probes]]
name = "hinge"
at = [2.5, 0.5, 0.0]
[[output.probes]]
name = "mid"
at = [2.5, 0.75, 0.0]
[[output.probes]]
name = "edge"
at = [2.5, 1.0, 0.0]
[[output.probes]]
name = "fixed_mid"
at = [2.5, 0.25, 0.0]
[[output.probes]]
name = "fixed_edge"
at = [2.5, 0.0, 0.0]
"""

PROBES = np.array(
    [[2.5, 0.5, 0.0], [2.5, 0.75, 0.0], [2.5, 1.0, 0.0], [2.5, 0.25, 0.0], [2.5, 0.0, 0.0]]
)


def positions(values):
    return PROBES + np.asarray(values)


def link_angle(p, a, b):
    """Angle about X of the link from probe a to probe b (0 in the reference)."""
    v = p[b] - p[a]
    return math.atan2(v[2], v[1])


def sagitta_curvature(p, a, m, b):
    """Curvature of a link from the distance of its midpoint probe ``m`` to the
    chord ``a``-``b`` (circle through three points: κ = 8 s / chord²)."""
    chord = p[b] - p[a]
    s = np.linalg.norm(np.cross(p[m] - p[a], chord)) / np.linalg.norm(chord)
    return 8 * s / np.dot(chord, chord)


class TieAndFold:
    """Observer: after every step, the root mean square over the hinge lines (assembled
    over dS) of the gap ``|u⁺ − u⁻|`` and of the jump of the director across them.

    The gap is zero by construction, to round-off: the displacement is one
    continuous P2 field across every hinge (hinges.py splits only the rotation
    fields and triads), so the two sides' traces are the same nodal values.  An
    assert on it checks that set-up, not the hinge; the hinge's own kinematics is
    the director's jump, and its mechanics the folds and rates of the tests."""

    def __init__(self):
        self.gap, self.jump = [], []
        self.forms = None

    def __call__(self, sim):
        from dolfinx import fem

        from rftfem import compat
        from rftfem.model import hinges

        m = sim.model
        if self.forms is None:
            dS = hinges.facet_measure(m.mesh, m.hinges)
            u = m.u_n
            d = m.kinematics().d
            length = compat.form(fem.Constant(m.mesh, 1.0) * dS)
            self.length = m.comm.allreduce(fem.assemble_scalar(length))
            self.forms = [
                compat.form(ufl.dot(u("+") - u("-"), u("+") - u("-")) * dS),
                compat.form(ufl.dot(d("+") - d("-"), d("+") - d("-")) * dS),
            ]
        gap, jump = (m.comm.allreduce(fem.assemble_scalar(f)) for f in self.forms)
        self.gap.append(math.sqrt(max(gap, 0.0) / self.length))
        self.jump.append(math.sqrt(max(jump, 0.0) / self.length))


def test_spring_hinge_folds_by_moment_over_stiffness(tmp_path):
    """One link clamped along its outer edge, an edge moment M about the hinge line on
    the other link's free edge, stiffness k per length: the fold is exactly
    φ = M / (k L).  Loaded in 10 static steps to φ = 120°, every step within 5e-7
    (reached: 5.0e-8).  The links are stiff (E t³/12 = 1e5 against k ℓ = 5e-3): each
    stays straight, curvature below 1e-6 of the fold per link width (reached 5e-8),
    and the two sides' nodal directors on the hinge differ by the fold angle."""
    k, phi_max = 0.01, 2 * math.pi / 3
    M = k * L * phi_max
    scene = write_scene(
        tmp_path,
        TWO_LINKS.format(
            E=1.2e9,
            k=k,
            clamp="y=0",
            M=M,
            extra="""
[time]
scheme = "static"
end = 1.0
dt = 0.1""",
        ),
    )
    sim = run_scene(scene)
    assert sim.model.active_effects()[:3] == ["elasticity", "hinge", "hinge-spring"]
    rows = sim.history[1:]
    assert len(rows) == 10
    worst_fold, worst_bend = 0.0, 0.0
    for t, values in rows:
        p = positions(values)
        phi = link_angle(p, 0, 2) - link_angle(p, 4, 0)
        exact = phi_max * t
        worst_fold = max(worst_fold, abs(phi / exact - 1))
        bend = max(sagitta_curvature(p, 0, 1, 2), sagitta_curvature(p, 4, 3, 0))
        worst_bend = max(worst_bend, bend / (phi / ELL))
    print(f"fold error {worst_fold:.2e}, curvature / (fold per width) {worst_bend:.2e}")
    assert worst_fold < 5e-7
    assert worst_bend < 1e-6

    # the two sides' directors on the hinge line differ by the fold angle
    m = sim.model
    X = m.Vu.tabulate_dof_coordinates()
    on_hinge = np.abs(X[:, 1] - 0.5) < 1e-9
    side = [dn.x.array.reshape(-1, 3)[on_hinge] for _, _, dn in m.triads]
    assert len(side) == 2 and on_hinge.sum() == 9  # 4 cells along the line: 9 P2 nodes
    angle = np.arccos(np.clip(np.sum(side[0] * side[1], axis=1), -1, 1))
    print(f"directors across the hinge: angle error {np.abs(angle / phi_max - 1).max():.1e}")
    assert np.abs(angle / phi_max - 1).max() < 2e-13  # reached 8.9e-15, 2.2e-14 (current)


#: the free link of test_free_hinge_turns_against_drag: its normal drag coefficient,
#: its rate (one turn a second) and the ramp time of its moment
FREE_LINK_C3, FREE_LINK_RATE, FREE_LINK_RAMP = 5.67e-9, 2 * math.pi, 0.01


def free_link_scene(tmp_path):
    """Two links, one clamped, the other free on its hinge in RFT drag, turned by a
    constant moment at one turn a second for 1.25 s (backward Euler, dt = 0.01)."""
    C3, tau = FREE_LINK_C3, FREE_LINK_RAMP
    zeta = C3 * L * ELL**3 / 3
    return write_scene(
        tmp_path,
        TWO_LINKS.format(
            E=1.2e6,
            k=0.0,
            clamp="fixed",
            M=FREE_LINK_RATE * zeta,
            extra=f"""
ramp = "table"
table = [[0.0, 0.0], [{tau}, 1.0], [2.0, 1.0]]
[fluid]
drag = [3.0e-9, 3.0e-9, {C3}]
[time]
end = 1.25
dt = 0.01""",
        ),
    )


def test_free_hinge_turns_against_drag(tmp_path):
    """One link clamped whole, the other free on its hinge (k = 0) in RFT drag,
    no density: a constant moment M about the hinge line turns the free link at
    ω = M / ζ with ζ = C₃ L ℓ³ / 3 (the normal drag of a plate turning about its
    edge).  Backward Euler balances M(tₙ₊₁) against the drag of the chord
    velocity on the end normal, ζ sin Δθ / Δt, so each step turns the rigid link
    by exactly Δθ = arcsin(ω r(tₙ₊₁) Δt), r the load's ramp (0 → 1 over τ).
    After 1.25 turns (the link passes through the clamped one: no contact) the
    angle is the sum of these steps within 2e-10 (reached 4.4e-12 reference,
    1.6e-11 current stack; a normal drag coefficient 0.5 % too large fails it,
    which the two 1 % checks below passed).  Against the continuous solution the
    angle is within 1 % of ω (t − τ/2) and the rate over the last turn within
    0.7 % of ω (reached 4.68e-3 and 6.59e-4 on both stacks: the ramp taken at
    the end of its step, τ/2 ahead, 4.0e-3, plus the chord error (ω Δt)²/6 =
    6.6e-4 of every step; the angle's 1 % cannot be ten times its figure, the
    sum above is the sharp check).  The hinge line does not move (1e-12 ℓ,
    reached 2e-16)."""
    omega, tau = FREE_LINK_RATE, FREE_LINK_RAMP
    track = TieAndFold()
    sim = run_scene(free_link_scene(tmp_path), observers=[track])
    assert "hinge-spring" not in sim.model.active_effects()
    t = np.array([row[0] for row in sim.history])
    angle = np.unwrap([link_angle(positions(v), 0, 2) for _, v in sim.history])
    hinge = np.array([v[0] for _, v in sim.history])
    final = angle[-1] / (omega * (t[-1] - tau / 2)) - 1
    i1 = int(np.argmin(abs(t - 0.25)))
    rate = (angle[-1] - angle[i1]) / (t[-1] - t[i1]) / omega - 1
    steps = np.arcsin(omega * np.minimum(t[1:] / tau, 1.0) * np.diff(t))
    discrete = angle[-1] / steps.sum() - 1
    print(
        f"angle {angle[-1]:.8f} rad after {t[-1]} s, backward Euler's exact "
        f"{steps.sum():.8f}: error {discrete:.2e}; against ω (t − τ/2) {final:.2e}; "
        f"rate error {rate:.2e}; hinge line moved {np.abs(hinge).max() / ELL:.1e} ℓ"
    )
    assert angle[-1] > 2 * math.pi
    assert abs(discrete) < 2e-10
    assert abs(final) < 1e-2 and abs(rate) < 7e-3
    assert np.abs(hinge).max() < 1e-12 * ELL
    # the gap is zero by construction (u is one continuous field: see TieAndFold), not a
    # check of the hinge; the directors really part across the line
    assert max(track.gap) < 1e-12 * L
    assert max(track.jump) > 1.0


def _corner_rows(sim):
    """(Y, Z of the middle link's centre, middle link's angle about X) per output row."""
    out = []
    ref = np.array([[2.5, 0.75, 0.0], [2.5, 0.5, 0.0], [2.5, 1.0, 0.0]])
    for t, v in sim.history:
        p = ref + np.asarray(v)
        chord = p[2] - p[1]
        out.append((t, p[0][1] - 0.75, p[0][2], math.atan2(chord[2], chord[1])))
    return np.array(out)


#: docs/verification.md case H, computed by the overdamped rigid-link model of
#: tests/rigid_links.py (which test_rigid_links.py checks against the published
#: −1.29213e-3, −4.8837e-3, ...): after 1, 2, 3 square cycles (A = 0.1), the
#: middle link's centre Y and angle
_PURCELL = rigid_links.simulate(
    *rigid_links.loop_tables("square", 0.1, 1.0, 3), 3.0, density=0.0, times=[1.0, 2.0, 3.0]
)
PURCELL_Y, PURCELL_ANGLE = tuple(_PURCELL.centre_y), tuple(_PURCELL.angle_middle)


def reciprocal_loop(amplitude, cycles):
    """(w_L, w_R) tables of the out-and-back loop (0,0) → (A,0) → (A,A) → (A,0) → (0,0)."""
    return _load_demo().loop_tables("reciprocal", amplitude, 1.0, cycles)


def test_purcell_square_loop_matches_rigid_links():
    """The shipped scene: rigid links, square loop, 3 cycles, 40 steps per leg.
    The middle link's centre moves along Y within 0.5 % and the middle link turns
    within 2 % of the exact rigid-link figures after every cycle (reached: 4e-4
    and 5e-3).
    The directors jump across both hinges; the displacement's gap there stays
    below 1e-12 of the body size, which holds by construction (one continuous
    field, see TieAndFold) and is no check of the hinges."""
    track = TieAndFold()
    sim = run_scene(SCALLOP, observers=[track])
    rows = _corner_rows(sim)
    for n in (1, 2, 3):
        _, y, _, angle = rows[int(np.argmin(abs(rows[:, 0] - n)))]
        print(
            f"cycle {n}: Y {y:.6e} ({y / PURCELL_Y[n - 1] - 1:+.2e}), "
            f"angle {angle:.6e} ({angle / PURCELL_ANGLE[n - 1] - 1:+.2e})"
        )
        assert y == pytest.approx(PURCELL_Y[n - 1], rel=0.005)
        assert angle == pytest.approx(PURCELL_ANGLE[n - 1], rel=0.02)
    assert max(track.gap) < 1e-12 * L  # by construction (TieAndFold): not a check of the hinges
    assert max(track.jump) > 1e-2


def test_reciprocal_loop_goes_nowhere():
    """Scallop theorem: the out-and-back loop at the same amplitude moves the rigid
    swimmer less than 1e-3 of the square loop's displacement per cycle; asserted
    tighter, 5e-4 (reached: 1.4e-4, the time-stepping error).  A velocity with
    memory, v = Δu/dt + v_n/2, gives 8e-4 and fails here."""
    wl, wr = reciprocal_loop(0.1, 3)
    sim = run_scene(SCALLOP, f"motion.0.values={wl}", f"motion.1.values={wr}")
    rows = _corner_rows(sim)
    per_cycle = abs(rows[-1, 1]) / 3
    print(f"reciprocal: {per_cycle:.3e} mm per cycle; square: {abs(PURCELL_Y[0]):.3e}")
    assert per_cycle < 5e-4 * abs(PURCELL_Y[0])


def _load_demo():
    from importlib import util

    spec = util.spec_from_file_location("scallop", DEMOS / "scallop.py")
    demo = util.module_from_spec(spec)
    spec.loader.exec_module(demo)
    return demo


@pytest.mark.long
def test_soft_arms_break_the_scallop_theorem():
    """Stokes regime, out-and-back loop of amplitude A = 0.2 (0.4 link widths):
    with soft outer links at Sp = 2 the swimmer moves, per cycle (the last of 3),

    - at least 1e-4 of a link width (reached: 4.5e-4),
    - the same within 5 % when dt is halved (reached: 0.03 %),
    - at least 100 times what rigid links do.  For rigid links the loop's
      displacement is the time-stepping error alone: it halves with dt (checked,
      ratio within 2 ± 0.3), and its limit dt → 0 by Richardson extrapolation,
      2 r(dt/2) − r(dt), is what the soft arms are compared with (reached: over
      1e3 times; against the raw rigid figure at 120 steps per leg: 47 times).
    """
    demo = _load_demo()
    soft = demo.arm_modulus(2.0, 1.0)
    per_cycle = {}
    for spl in (30, 60):
        ends, summary = demo.swim(
            "reciprocal", soft, 3, amplitude=0.2, divisions=(1, 4), steps_per_leg=spl
        )
        assert summary["status"] == "ok"
        per_cycle[spl] = ends[-1] - ends[-2]
    rigid = {}
    for spl in (60, 120):
        ends, _ = demo.swim(
            "reciprocal", demo.RIGID_E, 2, amplitude=0.2, divisions=(1, 4), steps_per_leg=spl
        )
        rigid[spl] = ends[-1] - ends[-2]
    limit = 2 * rigid[120] - rigid[60]
    width = demo.LINK_WIDTH
    print(
        f"soft arms: {per_cycle[30]:.4e}, {per_cycle[60]:.4e} mm per cycle "
        f"({abs(per_cycle[60]) / width:.2e} link widths); rigid: {rigid[60]:.3e}, "
        f"{rigid[120]:.3e}, dt → 0: {limit:.2e}"
    )
    assert abs(per_cycle[60]) > 1e-4 * width
    assert per_cycle[30] == pytest.approx(per_cycle[60], rel=0.05)
    assert rigid[60] / rigid[120] == pytest.approx(2.0, abs=0.3)
    assert abs(per_cycle[60]) > 100 * abs(limit)


# --- gmsh meshes: a straight oblique crease, a crease that stops inside ---------------


def write_creased_plate(path, dangling=False):
    """The plate [0, 2] × [0, 1] at Z = 0 in triangles, cut by the straight crease from
    (0.8, 0) to (1.2, 1) into the surfaces "a" (left) and "b"; curves "crease" and
    "free" (x = 2).  With ``dangling`` the crease stops at (1.0, 0.5) inside one
    surface (embedded), so it does not cut the plate."""
    import gmsh

    gmsh.initialize(readConfigFiles=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("creased")
        geo = gmsh.model.geo
        p = {
            xy: geo.addPoint(*xy, 0.0, 0.1)
            for xy in ((0, 0), (0.8, 0), (2, 0), (2, 1), (1.2, 1), (0, 1))
        }
        line = lambda a, b: geo.addLine(p[a], p[b])  # noqa: E731
        free = line((2, 0), (2, 1))
        if dangling:
            outline = [line((0, 0), (2, 0)), free, line((2, 1), (0, 1)), line((0, 1), (0, 0))]
            plate = geo.addPlaneSurface([geo.addCurveLoop(outline)])
            tip = geo.addPoint(1.0, 0.5, 0.0, 0.1)
            mid = geo.addPoint(0.9, 0.25, 0.0, 0.1)
            crease = [geo.addLine(mid, tip)]
            surfaces = {"a": [plate]}
        else:
            crease = [line((0.8, 0), (1.2, 1))]
            a = geo.addPlaneSurface(
                [
                    geo.addCurveLoop(
                        [
                            line((0, 0), (0.8, 0)),
                            crease[0],
                            line((1.2, 1), (0, 1)),
                            line((0, 1), (0, 0)),
                        ]
                    )
                ]
            )
            b = geo.addPlaneSurface(
                [
                    geo.addCurveLoop(
                        [line((0.8, 0), (2, 0)), free, line((2, 1), (1.2, 1)), -crease[0]]
                    )
                ]
            )
            surfaces = {"a": [a], "b": [b]}
        geo.synchronize()
        if dangling:
            gmsh.model.mesh.embed(1, crease, 2, surfaces["a"][0])
        for tag, (name, s) in enumerate(surfaces.items(), start=1):
            gmsh.model.addPhysicalGroup(2, s, tag)
            gmsh.model.setPhysicalName(2, tag, name)
        for tag, (name, c) in enumerate((("crease", crease), ("free", [free])), start=11):
            gmsh.model.addPhysicalGroup(1, c, tag)
            gmsh.model.setPhysicalName(1, tag, name)
        gmsh.model.mesh.generate(2)
        gmsh.write(str(path))
    finally:
        gmsh.finalize()
    return path


CREASED = """
title = "creased plate"
[mesh]
kind = "gmsh"
file = "{file}"
[shell]
thickness = 0.1
E = 1.2e8
nu = 0.0
[[hinge]]
where = "crease"
stiffness = {k}
[[boundary]]
where = "a"
fix = ["clamped"]
[[load]]
kind = "edge-moment"
where = "free"
value = {M}
[time]
scheme = "static"
end = 1.0
dt = 0.25
[[output.probes]]
name = "free"
at = [2.0, 0.5, 0.0]
"""


def test_oblique_crease_on_a_gmsh_mesh_folds_exactly(tmp_path):
    """A gmsh physical curve as hinge, oblique to the axes, triangles: one side
    clamped, a moment along the crease on the other side's free edge folds it by
    φ = M / (k · crease length) (6e-6, reached 6e-7) about the crease line.  The
    fold is signed: M along +a (the crease from (0.8, 0) to (1.2, 1)) turns the
    free side about +a by the right-hand rule, its arm r from the crease towards
    a × r (here −Z), so the angle from r towards a × r is +φ t, not −φ t."""
    msh = write_creased_plate(tmp_path / "creased.msh")
    c, tip = np.array([0.8, 0.0, 0.0]), np.array([1.2, 1.0, 0.0])
    length = float(np.linalg.norm(tip - c))
    axis = (tip - c) / length
    k, phi = 0.01, math.pi / 2
    M = (k * length * phi) * axis
    scene = write_scene(tmp_path, CREASED.format(file=msh.name, k=k, M=[float(v) for v in M]))
    sim = run_scene(scene)
    assert sim.model.n_colours == 2
    p0 = np.array([2.0, 0.5, 0.0])
    r = (p0 - c) - np.dot(p0 - c, axis) * axis  # in-plane arm, ⟂ to the crease
    for t, values in sim.history[1:]:
        p = p0 + values[0]
        turned = math.atan2(
            np.dot(p - c, np.cross(axis, r / np.linalg.norm(r))),
            np.dot(p - c, r / np.linalg.norm(r)),
        )
        print(f"t = {t}: fold {turned:.6f}, exact {phi * t:.6f}")
        assert turned == pytest.approx(phi * t, rel=6e-6)


def test_hinge_selectors_that_are_not_hinge_lines(tmp_path, mpirun):
    """`rftfem check` exits 2 with one line naming the hinge's key: a gmsh name that is
    no curve, a crease that stops inside the body, an x=c line no cell edge lies on."""
    exe, env = mpirun
    dangling = write_creased_plate(tmp_path / "dangling.msh", dangling=True)
    plate = write_creased_plate(tmp_path / "creased.msh")
    cases = [
        (
            CREASED.format(file=plate.name, k=0.0, M=[0.0, 0.01, 0.0]).replace(
                'where = "crease"', 'where = "fold"'
            ),
            "hinge.0.where",
            "unknown selector 'fold'",
        ),
        (
            CREASED.format(file=dangling.name, k=0.0, M=[0.0, 0.01, 0.0]).replace(
                'where = "a"\n', 'where = "free"\n'
            ),
            "hinge.0.where",
            "does not cut",
        ),
        (
            CREASED.format(file=plate.name, k=0.0, M=[0.0, 0.01, 0.0]).replace(
                'where = "crease"', 'where = "x=1.33"'
            ),
            "hinge.0.where",
            "not a line of the mesh",
        ),
    ]
    for i, (text, key, words) in enumerate(cases):
        scene = write_scene(tmp_path, text, name=f"bad{i}.toml")
        done = subprocess.run(
            [sys.executable, "-m", "rftfem", "check", str(scene)],
            env=env,
            cwd=ROOT,
            capture_output=True,
            text=True,
            timeout=600,
        )
        lines = done.stderr.strip().splitlines()
        assert done.returncode == 2, done.stdout + done.stderr
        assert len(lines) == 1 and key in lines[0] and words in lines[0], lines


# --- parallel ----------------------------------------------------------------------

PARTITION = """
import sys
from mpi4py import MPI
import rftfem
from rftfem.scene.reading import load_scene
from rftfem.scene.selectors import cells_of
from rftfem.integration.model_setup import build_model
model = build_model(load_scene(sys.argv[1], sys.argv[2:]), MPI.COMM_WORLD)
n = model.mesh.topology.index_map(1).size_local
owners = [MPI.COMM_WORLD.allgather(int((h.facets < n).sum()) > 0) for h in model.hinges]
colours = {r: set().union(*MPI.COMM_WORLD.allgather(set(model.colours[cells_of(model.body, [r])])))
           for r in ("left", "middle", "right")}
one_each = all(len(c) == 1 for c in colours.values())
if MPI.COMM_WORLD.rank == 0:
    print("CUT" if any(sum(o) > 1 for o in owners) else "UNCUT",
          "PANELS" if one_each and colours["left"] != colours["middle"] != colours["right"]
          else f"MIXED {colours}")
"""


@pytest.mark.mpi
def test_three_link_mpirun_matches_serial(tmp_path, cli_run, mpirun):
    """One square cycle of the Purcell swimmer on 2 processes whose partition cuts a
    hinge line (checked) gives the serial probe rows to 1e-8 mm, and each link is
    one panel of one colour across the processes, neighbours differing (checked
    directly: nothing varies along X here, so a link wrongly split in two at the
    partition would not show in the probes)."""
    exe, env = mpirun
    sets = ["time.end=1.0", "time.dt=0.0125", "mesh.divisions=[8, 1]", "output.fields=false"]
    done = subprocess.run(
        [exe, "-n", "2", sys.executable, "-c", PARTITION, str(SCALLOP), *sets],
        env=env,
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    assert done.stdout.split()[-2:] == ["CUT", "PANELS"], done.stdout[-500:]
    rows = {}
    for n in (1, 2):
        out = cli_run(SCALLOP, tmp_path / f"np{n}", sets, np=n)
        with open(out / "probes.csv", encoding="utf-8") as fh:
            rows[n] = np.array([[float(v) for v in r.values()] for r in csv.DictReader(fh)])
    moved = np.abs(rows[1][:, 1:]).max()
    print(
        f"largest probe displacement {moved:.3e} mm; serial vs np 2: "
        f"{np.abs(rows[2] - rows[1]).max():.2e} mm"
    )
    assert moved > 0.01
    assert np.abs(rows[2] - rows[1]).max() < 1e-8


# --- the demos as shipped ------------------------------------------------------------


@pytest.mark.slow
def test_three_link_demo(tmp_path):
    """The paper's cases I-IV, each with and without inertia, run to completion and
    write their Table 4 analogue, groups and plot; without inertia the rigid-link
    case I obeys the scallop theorem (corner moves < 1e-4 mm in 9 cycles)."""
    done = subprocess.run(
        [sys.executable, str(DEMOS / "three_link.py"), "--out", str(tmp_path)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=3 * 3600,
    )
    print(done.stdout[-3000:])
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    for name in ("table4.csv", "groups.md", "three_link.png"):
        assert (tmp_path / name).stat().st_size > 0
    with open(tmp_path / "table4.csv", encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 9
    assert max(abs(float(r["I (no inertia)"])) for r in rows) < 1e-4


@pytest.mark.slow
def test_scallop_demo(tmp_path):
    """The scallop study as shipped: it checks the rigid square loop against the exact
    result (2 %) and the rigid out-and-back loop (1e-3 of it) itself (exit status)."""
    done = subprocess.run(
        [sys.executable, str(DEMOS / "scallop.py"), "--out", str(tmp_path)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=2 * 3600,
    )
    print(done.stdout[-3000:])
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    assert (tmp_path / "scallop.png").stat().st_size > 0


def test_local_panel_components():
    """hinges._local_components against plain label spreading, on random cell-facet
    layouts (some facets shared by two cells, some closed by a hinge): the same
    panels, each named by its smallest cell."""
    from rftfem.model.hinges import _local_components

    rng = np.random.default_rng(7)
    for _ in range(20):
        n_cells, n_facets = int(rng.integers(1, 60)), int(rng.integers(1, 80))
        facets = rng.integers(0, n_facets, size=(n_cells, 4))
        open_ = rng.random((n_cells, 4)) < 0.7
        root = _local_components(n_cells, facets, open_)
        label = np.arange(n_cells)
        while True:  # spread the smallest label across open shared facets
            new = label.copy()
            for c in range(n_cells):
                for d in range(n_cells):
                    if set(facets[c][open_[c]]) & set(facets[d][open_[d]]):
                        new[c] = min(new[c], label[d])
            if (new == label).all():
                break
            label = new
        np.testing.assert_array_equal(root, label)
