"""Static path-following by arc length (rftfem/integration/arclength.py) against an exact
equilibrium path with two load limit points and a snap-back.

The structure is one bar of a shallow two-bar (von Mises) truss, modelled as a
flat shell strip of reference length L₀ from a pinned support at the origin
to the apex at (a, 0, h), which slides along Z (ux = 0 there, rotation free).
With ν = 0 and a straight bar, the strain is uniform and purely axial, the
Green strain ε = (L² − L₀²) / (2 L₀²) of the current length L, and the strip
reproduces the bar exactly (P2 holds the linear displacement field).  A
vertical force F on the apex and the support moved along X by s:

    F = −E t b ε v / L₀,    v = h − w,   L² = (a − s)² + v²,

(w the apex's descent), a closed form for F given w and s.  Under the force
alone (s = 0) F(w) rises to E t b h³ / (3√3 L₀³) at v = h/√3, falls through
zero where the bar lies flat, and reaches its minimum at v = −h/√3: two load
limit points.  With the support pulled outwards as the load grows (s = λ s₀,
F = λ F₀), the descent turns back as well: w(λ) has a snap-back.  The strip is
thick enough (t = 1.2 > 0.78 h) that the compressed bar does not buckle first.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from conftest import run_scene, write_scene

A, H, WIDTH, T, E = 10.0, 1.0, 1.0, 1.2, 1000.0
L0 = math.hypot(A, H)
EA = E * T * WIDTH


def truss_bar(path: Path, n: int = 4) -> Path:
    """The bar as an inclined rectangle, n × 1 nine-node quadrilaterals; curves
    "support" (x = 0) and "apex" (x = a)."""
    from test_curved_shells import _gmsh, _name_mesh_write

    gmsh = _gmsh()
    try:
        geo = gmsh.model.geo
        p = [geo.addPoint(*xyz) for xyz in ((0, 0, 0), (A, 0, H), (A, WIDTH, H), (0, WIDTH, 0))]
        lines = [geo.addLine(p[i], p[(i + 1) % 4]) for i in range(4)]
        surface = geo.addPlaneSurface([geo.addCurveLoop(lines)])
        geo.synchronize()
        for line, cells in zip(lines, (n, 1, n, 1)):
            gmsh.model.mesh.setTransfiniteCurve(line, cells + 1)
        gmsh.model.mesh.setTransfiniteSurface(surface)
        gmsh.model.mesh.setRecombine(2, surface)
        _name_mesh_write(
            gmsh, ((2, surface, "bar"), (1, lines[3], "support"), (1, lines[1], "apex")), path
        )
    finally:
        gmsh.finalize()
    return path


SCENE = """
title = "one bar of a von Mises truss, by arc length"
[mesh]
kind = "gmsh"
file = "bar.msh"
[shell]
thickness = {T}
E = {E}
nu = 0.0
[time]
scheme = "arc-length"
end = {end}
dt = {dt}
max_steps = {max_steps}
[[boundary]]
name = "support"
where = "support"
fix = [{support_fix}]
[[boundary]]
where = "apex"
fix = ["ux"]
[[load]]
kind = "edge-force"
where = "apex"
value = [0.0, 0.0, {force}]
{motion}
[[output.probes]]
name = "apex"
at = [{A}, 0.5, {H}]
[output]
fields = false
"""


def apex_force(w, s=0.0):
    """The vertical force (downwards positive) that holds the apex at descent ``w``
    with the support moved by ``s`` along X."""
    v = H - w
    strain = ((A - s) ** 2 + v**2 - L0**2) / (2 * L0**2)
    return -EA * strain * v / L0


F_LIMIT = EA * H**3 / (3 * math.sqrt(3) * L0**3)


def truss_scene(tmp_path, **keys) -> Path:
    """The bar's mesh and scene in ``tmp_path``; ``keys`` replace SCENE's defaults."""
    truss_bar(tmp_path / "bar.msh")
    values = dict(
        T=T,
        E=E,
        A=A,
        H=H,
        end=1.0,
        dt=0.1,
        max_steps=200,
        support_fix='"ux", "uy", "uz"',
        force=-1.0,
        motion="",
    )
    values.update(keys)
    return write_scene(tmp_path, SCENE.format(**values))


def soft_support(F0):
    """The [[motion]] of the support that sinks as a spring of half the bar's steepest
    unloading stiffness under the force λ F₀, and that sink per unit λ."""
    k = 0.5 * EA * H**2 / (2 * L0**3)
    sink = F0 / k
    return (
        '[[motion]]\nname = "spring"\nwhere = "support"\ncomponent = "uz"\n'
        f'kind = "table"\nvalues = [[-10.0, {10 * sink}], [10.0, {-10 * sink}]]'
    ), sink


def run_truss(tmp_path, **keys):
    sim = run_scene(truss_scene(tmp_path, **keys), out_dir=tmp_path / "out")
    from rftfem.outputs.quantities import read_csv

    header, rows = read_csv(tmp_path / "out" / "probes.csv")
    return sim, rows[:, header.index("load_factor")], -rows[:, header.index("apex_uz")]


def test_truss_through_both_load_limit_points(tmp_path):
    """F = λ F₀ with F₀ = 1.5 F_max beyond the first limit point: the path climbs to
    F_max, falls through zero (the bar flat, w = h) to −F_max, and climbs again to
    λ = 1 on the far side (w > 2h).  Every converged state against the exact
    F(w): the largest error of the force (reached 9e-12 of F_max)."""
    F0 = 1.5 * F_LIMIT
    sim, lam, w = run_truss(tmp_path, force=-F0, dt=0.05)
    error = np.abs(lam * F0 - apex_force(w)).max() / F_LIMIT
    print(
        f"{len(w)} rows, w up to {w.max():.3f} (2h = {2 * H}), λ from {lam.min():.3f} to "
        f"{lam.max():.3f}; error {error:.1e} of F_max; {sim.counts}"
    )
    assert sim.load_factor == pytest.approx(1.0, abs=1e-12)
    assert w.max() > 2 * H  # through the flat state, the second limit and beyond
    assert lam.min() < -0.6 / 1.5 and lam.max() > 0.6  # both limits, ±F_max / F₀ = ±0.67
    assert error < 1e-10


def test_truss_on_a_soft_support_through_its_snap_backs(tmp_path):
    """The truss on a spring support of stiffness k, softer than the bar's steepest
    unloading (|dF/dw| = E t b h² / (2 L₀³) where the bar lies flat): the support
    sinks by F/k, here prescribed as the motion λ F₀/k of the support, so the apex
    sinks by w = w_bar + F/k in all.  Where the bar unloads faster than the spring
    does, w turns back while λ goes on falling: a snap-back, one on each side of
    the flat state.  Against the exact path: the force F(w − λ F₀/k) the computed
    state needs (reached 1.5e-7 of F_max, where arcs of 1e-3 of the first converge
    in one update).  The path turns sharply there: steps whose increment turned more
    than PATH_TURN from the last were rejected and retried with half the arc (16)."""
    F0 = 1.5 * F_LIMIT
    motion, sink = soft_support(F0)  # the support's descent per unit λ
    sim, lam, w = run_truss(tmp_path, force=-F0, dt=0.05, motion=motion, support_fix='"ux", "uy"')
    error = np.abs(lam * F0 - apex_force(w - lam * sink)).max() / F_LIMIT
    dw = np.diff(w)
    back = np.flatnonzero(dw[1:] * dw[:-1] < 0)
    print(
        f"{len(w)} rows; λ from {lam.min():.3f} to {lam.max():.3f}; w turns at rows "
        f"{back + 1} (w = {w[back + 1]}); error {error:.1e}; {sim.counts}"
    )
    assert sim.load_factor == pytest.approx(1.0, abs=1e-12)
    assert len(back) >= 2  # w turns back and forward again: the snap-backs
    assert lam.min() < -0.6 / 1.5  # and the load limit points on the way
    # steps that crossed a sharp turn of the path were rejected and retried shorter
    assert sim.counts["rejected_steps"] >= 5
    assert error < 1.5e-6


class ArcSteps:
    """Observer: for each accepted arc step, the arc it was asked to take (the one
    the last step set, before any cut), its displacement increment ‖Δu‖, its Δλ, and
    whether it was cut, rejected or landed on time.end (those take another length)."""

    def __init__(self):
        self.rows, self._cuts = [], 0
        self._lam, self._t = 0.0, 0.0

    def __call__(self, sim):  # called before the step sets the next arc
        cuts = sim.counts["dt_cuts"] + sim.counts["rejected_steps"]
        self.rows.append(
            (
                sim.arc,
                sim.t - self._t,
                sim.load_factor - self._lam,
                cuts != self._cuts or sim.load_factor == sim.scene["time"]["end"],
            )
        )
        self._cuts, self._lam, self._t = cuts, sim.load_factor, sim.t


def test_each_step_keeps_its_arc_and_the_path_turns_back_at_the_limits(tmp_path):
    """The truss through both limit points, observed step by step: every arc step that
    was neither cut nor landed has ‖Δu‖ equal to its arc (the constraint; reached
    1.1e-13), no arc exceeds MAX_GROWTH times the first, and λ rises up to the first
    limit point (v = h/√3), falls between the two (through the flat bar), and rises
    past the second (v = −h/√3), as the exact F(w) does."""
    from rftfem.integration.arclength import MAX_GROWTH

    F0 = 1.5 * F_LIMIT
    steps = ArcSteps()
    scene = truss_scene(tmp_path, force=-F0, dt=0.05)
    sim = run_scene(scene, out_dir=tmp_path / "out", observers=[steps])
    from rftfem.outputs.quantities import read_csv

    header, rows = read_csv(tmp_path / "out" / "probes.csv")
    lam, w = rows[:, header.index("load_factor")], -rows[:, header.index("apex_uz")]
    kept = [(arc, du) for arc, du, _, odd in steps.rows[1:] if not odd]
    worst = max(abs(du / arc - 1) for arc, du in kept)
    print(
        f"{len(kept)} of {len(steps.rows)} steps at their own arc: ‖Δu‖/arc − 1 up to "
        f"{worst:.1e}; first arc {sim.first_arc:.4g}"
    )
    assert len(kept) > 0.6 * len(steps.rows) and worst < 1e-12
    assert max(arc for arc, *_ in steps.rows[1:]) <= MAX_GROWTH * sim.first_arc * (1 + 1e-12)
    v, dlam = H - w, np.diff(lam)
    mid = 0.5 * (v[1:] + v[:-1])
    rising = (mid > H / math.sqrt(3)) | (mid < -H / math.sqrt(3))
    falling = np.abs(mid) < H / math.sqrt(3)
    away = np.minimum(np.abs(v[1:] - H / math.sqrt(3)), np.abs(v[:-1] - H / math.sqrt(3)))
    away = np.minimum(
        away, np.minimum(np.abs(v[1:] + H / math.sqrt(3)), np.abs(v[:-1] + H / math.sqrt(3)))
    )
    clear = away > 0.02 * H  # steps that straddle a limit point may go either way
    assert (dlam[rising & clear] > 0).all() and (dlam[falling & clear] < 0).all()
    assert falling.sum() >= 5 and (rising & (mid < 0)).sum() >= 2


def test_support_reaction_is_the_bar_force(tmp_path):
    """The named support's reaction along the path (body.csv) against the bar's exact
    force: a two-force member, so the support holds −(E t b ε / L₀)(a, 0, v), ε the
    Green strain, and its moment about the origin is that force at the edge's middle
    (0, b/2, 0) (reached 9e-13 of F_max)."""
    F0 = 1.5 * F_LIMIT
    sim, lam, w = run_truss(tmp_path, force=-F0, dt=0.05)
    from rftfem.outputs.quantities import read_csv

    header, body = read_csv(tmp_path / "out" / "body.csv")
    r = np.stack(
        [body[:, header.index(f"support_{c}")] for c in ("Fx", "Fy", "Fz", "Mx", "My", "Mz")],
        axis=1,
    )
    v = H - w
    strain = (A**2 + v**2 - L0**2) / (2 * L0**2)
    force = -(EA * strain / L0)[:, None] * np.stack([np.full_like(v, A), 0 * v, v], axis=1)
    moment = np.cross([0.0, WIDTH / 2, 0.0], force)
    err = np.abs(np.hstack([r[:, :3] - force, r[:, 3:] - moment])).max() / F_LIMIT
    print(f"support reaction against the bar force: {err:.1e} of F_max over {len(v)} rows")
    assert np.abs(force[:, 2]).max() > 0.9 * F_LIMIT
    assert err < 1e-11


def test_arc_length_branches_that_end_a_run(tmp_path):
    """max_steps reached: a warning (kept in summary.json), a last row at the state
    reached, λ below time.end; loads that do not move the body: a one-line failure;
    steps that never converge (snes_max_it = 1): the arc halved time.max_cuts times,
    then a failure that says so."""
    from rftfem.errors import RunFailed

    F0 = 1.5 * F_LIMIT
    scene = truss_scene(tmp_path, force=-F0, dt=0.05, max_steps=6)
    sim = run_scene(scene, out_dir=tmp_path / "short")
    assert sim.completed == 6 and sim.load_factor < 1.0
    assert sim.history[-1][0] == sim.t
    assert any("time.max_steps = 6 steps reached" in w for w in sim.summary["warnings"])
    with pytest.raises(RunFailed, match="do not move the body"):
        run_scene(truss_scene(tmp_path, force=0.0))
    with pytest.raises(RunFailed, match=r"after 3 halvings of the arc \(time.max_cuts\)"):
        run_scene(
            truss_scene(tmp_path, force=-F0, dt=0.05),
            "time.max_cuts=3",
            "solver.snes_max_it=1",
            "solver.snes_stol=0",
        )


def _table(path):
    from rftfem.outputs.quantities import read_csv

    return read_csv(path)


@pytest.mark.mpi
@pytest.mark.long
@pytest.mark.both_stacks
def test_restart_in_the_middle_and_two_processes_equal_the_serial_run(tmp_path, cli_run):
    """The snap-back path of the truss on a soft support: stopped after 20 steps by
    time.max_steps (a checkpoint every 5), where the load falls, restarted with a larger one,
    and on two
    processes, against the uninterrupted serial run: probes.csv and body.csv (the
    reactions), to 3e-6 of each column.  The first step after the restart differs
    from the serial run's in the last digit, and two processes' partitioned solves
    by their round-off; both grow where this path turns sharply (arcs of 1e-3 of
    the first, converged in one update) to 3.4e-7 and 2.4e-7."""
    F0 = 1.5 * F_LIMIT
    scene = truss_scene(
        tmp_path, dt=0.05, support_fix='"ux", "uy"', force=-F0, motion=soft_support(F0)[0]
    )
    serial = cli_run(scene, tmp_path / "serial")
    cli_run(scene, tmp_path / "cut", ["time.max_steps=20", "output.checkpoint_every=5"])
    half = _table(tmp_path / "cut" / "probes.csv")[1]
    assert 0.0 < half[-1, -1] < half[-2, -1] < 1.0  # stopped on the way down
    import sys

    from conftest import run_command

    done = run_command(
        [
            sys.executable,
            "-m",
            "rftfem",
            "run",
            str(scene),
            "--restart",
            str(tmp_path / "cut"),
            "--quiet",
            "--set",
            "time.max_steps=200",
        ],
        timeout=600,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    two = cli_run(scene, tmp_path / "two", np=2)
    for name in ("probes.csv", "body.csv"):
        header, ref = _table(serial / name)
        for other in (tmp_path / "cut", two):
            h, rows = _table(other / name)
            assert h == header and rows.shape == ref.shape, (other, name)
            # each column against its own size (a column of round-off against the table's)
            scale = np.maximum(np.abs(ref).max(axis=0), 1e-9 * np.abs(ref).max())
            err = (np.abs(rows - ref) / scale).max()
            print(f"{other.name}/{name}: {len(rows)} rows, largest difference {err:.1e}")
            assert err < 3e-6


@pytest.mark.parametrize(
    "sets, message",
    [
        (
            ["fluid.drag=[1.0, 1.0, 2.0]"],
            'time.scheme: "arc-length" follows a static equilibrium path, and the [fluid] drag is '
            "a force of motion; remove [fluid] or use a scheme in time",
        ),
        (["time.dt=-0.1"], "time.dt: expected a number > 0, found -0.1"),
        (["time.max_steps=0"], "time.max_steps: expected an integer >= 1, found 0"),
        (
            ["time.tolerance=1e-3"],
            "time.tolerance: the scheme is static (load steps have no time "
            "error to control); remove time.tolerance or use a scheme in time",
        ),
    ],
)
def test_bad_arc_length_settings_are_refused(tmp_path, sets, message):
    from rftfem.errors import SceneError
    from rftfem.scene.reading import load_scene

    scene = truss_scene(tmp_path, dt=0.05)
    with pytest.raises(SceneError) as err:
        load_scene(scene, sets)
    assert str(err.value) == message


def test_bad_setting_exits_2_in_one_line(tmp_path):
    import sys

    from conftest import run_command

    scene = truss_scene(tmp_path, dt=0.05)
    done = run_command(
        [sys.executable, "-m", "rftfem", "run", str(scene), "--set", "fluid.drag=[1.0, 1.0, 2.0]"],
        timeout=300,
    )
    print(done.stderr)
    assert done.returncode == 2 and len(done.stderr.strip().splitlines()) == 1
    assert "arc-length" in done.stderr
