"""The PyElastica side of the peer race (benchmarks/peer_race.py): one run, one JSON line.

Run by the python of .venv-elastica (pyelastica 1.0.0 and numba), never by the
repository's .venv: benchmarks/peer_race.py starts it as a subprocess, so the
FEniCSx stack and elastica never share a process.  Three problems, the same
physics as the rftfem scenes peer_race.py writes (units mm, s, N):

swim       a 10 x 2 x 0.1 strip (E = 5 MPa, nu = 0, 1600 kg/m^3) as a Cosserat rod
           of rectangular section (bending, twist, shear, axial stiffness and
           mass moments of the 2 x 0.1 rectangle); resistive-force drag per unit
           length w (C1 t t + C2 b b + C3 n n) v with the strip's coefficients
           [C1, C2, C3] = [1e-8, 1e-8, 1.89e-8] N s/mm^3 in the rod's director
           frame (lumped at the nodes, Voronoi lengths); the first millimetre is
           magnetized along the axis, 62.9 A/mm, and carries the couple m x B
           (taken to the material frame) of the uniform field
           B = 1e-5 (1, 0, sin 2 pi f t) N/(A mm), f = 4 Hz.  Position Verlet.
           Output: the centroid's mean x speed over periods [window, periods].
elastica   cantilever 10 x 1 x 0.1, E = 1.2e6, nu = 0 (EI = 100), dead tip load
           P = 2 N (P L^2 / EI = 2), relaxed to rest with a uniform analytical
           damper; output: tip deflection w / L.
frequency  the same cantilever, rho = 1e-9, set moving in its first Euler-Bernoulli
           mode (tip amplitude 1e-3 L); output: the period from the tip's zero
           crossings over three periods.

    .venv-elastica/bin/python benchmarks/peer_race_elastica/run.py swim --elements 20
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time as _time

T0 = _time.perf_counter()


def parse(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("problem", choices=["swim", "elastica", "frequency"])
    p.add_argument("--elements", type=int, default=20, help="rod elements")
    p.add_argument(
        "--dt",
        type=float,
        default=0.0,
        help="time step; 0: --cfl times the explicit stability estimate",
    )
    p.add_argument(
        "--cfl",
        type=float,
        default=0.75,
        help="fraction of the stability estimate taken when --dt is 0",
    )
    p.add_argument(
        "--rotary-inertia",
        choices=["section", "match-axial"],
        default="section",
        help="section: the rectangle's mass moments (the physics); match-axial: "
        "the moments about d1, d2 scaled up until the element's shear-rotation "
        "oscillation is no faster than the axial wave across it, so the step "
        "is the axial limit (a mass-scaling trick, not the physics)",
    )
    p.add_argument("--periods", type=int, default=10, help="swim: field periods run")
    p.add_argument(
        "--window",
        type=int,
        default=5,
        help="swim: the speed is the centroid's mean over periods window..periods",
    )
    p.add_argument("--frequency", type=float, default=4.0, help="swim: field frequency, Hz")
    p.add_argument(
        "--settle",
        type=float,
        default=1e-7,
        help="elastica: stop once the tip moves less than this x L per 1/10 period",
    )
    return p.parse_args(argv)


def main(argv=None):
    args = parse(argv)
    import elastica as ea
    import numpy as np

    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from kernels import magnetic_couple, rft_drag

    class Sim(ea.BaseSystemCollection, ea.Constraints, ea.Forcing, ea.Damping):
        pass

    def rectangular_rod(n, L, w, t, E, nu, rho, x0=0.0, scale_inertia=False):
        """A straight rod along x, d1 = z (the strip's normal), d2 = -y, d3 = x, with the
        section constants of a w x t rectangle (PyElastica's factory assumes a disc)."""
        A = w * t
        G = E / (2 * (1 + nu))
        rod = ea.CosseratRod.straight_rod(
            n,
            np.array([x0, 0.0, 0.0]),
            np.array([1.0, 0.0, 0.0]),
            np.array([0.0, 0.0, 1.0]),
            L,
            math.sqrt(A / math.pi),
            rho,
            youngs_modulus=E,
            shear_modulus=G,
        )
        I_d1 = t * w**3 / 12  # about the normal d1: in-plane bending
        I_d2 = w * t**3 / 12  # about d2 (across the width): the soft bending
        a, b = max(w, t), min(w, t)  # St Venant torsion constant of a thin rectangle
        J = a * b**3 * (1 / 3 - 0.21 * b / a * (1 - b**4 / (12 * a**4)))
        rod.bend_matrix[:] = 0.0
        rod.bend_matrix[0, 0, :] = E * I_d1
        rod.bend_matrix[1, 1, :] = E * I_d2
        rod.bend_matrix[2, 2, :] = G * J
        kappa = 5.0 / 6.0
        rod.shear_matrix[:] = 0.0
        rod.shear_matrix[0, 0, :] = kappa * G * A
        rod.shear_matrix[1, 1, :] = kappa * G * A
        rod.shear_matrix[2, 2, :] = E * A
        dl = rod.rest_lengths
        dx = L / n
        w_axial = 2 * math.sqrt(E / rho) / dx
        s = 1.0
        if scale_inertia:
            s = max(1.0, kappa * G * A / (rho * min(I_d1, I_d2)) / w_axial**2)
        I_d1, I_d2 = s * I_d1, s * I_d2
        rod.mass_second_moment_of_inertia[:] = 0.0
        rod.inv_mass_second_moment_of_inertia[:] = 0.0
        for k, I in enumerate((I_d1, I_d2, I_d1 + I_d2)):
            rod.mass_second_moment_of_inertia[k, k, :] = rho * I * dl
            rod.inv_mass_second_moment_of_inertia[k, k, :] = 1.0 / (rho * I * dl)
        # the explicit stability estimate: axial wave across an element, and the
        # shear-rotation oscillation of an element (rotary inertia of the section)
        w_rot = math.sqrt(kappa * G * A / (rho * min(I_d1, I_d2)))
        w_ax_b = 2 * math.sqrt(E * I_d2 / (rho * A)) * (2 / dx) ** 2
        dt_crit = 2.0 / max(w_axial, w_rot, w_ax_b)
        return rod, dt_crit

    class RFTMagnetic(ea.NoForces):
        def __init__(self, drag_per_length, moments, B0, freq):
            super().__init__()
            self.c = drag_per_length
            self.moments = moments
            self.B0, self.omega = B0, 2 * math.pi * freq

        def apply_forces(self, system, time=0.0):
            rft_drag(
                system.velocity_collection,
                system.director_collection,
                system.lengths,
                self.c[0],
                self.c[1],
                self.c[2],
                system.external_forces,
            )

        def apply_torques(self, system, time=0.0):
            magnetic_couple(
                system.director_collection,
                self.moments,
                self.B0,
                0.0,
                self.B0 * math.sin(self.omega * time),
                system.external_torques,
            )

    sim = Sim()
    out = {
        "code": "pyelastica",
        "problem": args.problem,
        "elements": args.elements,
        "rotary_inertia": args.rotary_inertia,
    }
    if args.problem == "swim":
        L, w, t, E, nu, rho = 10.0, 2.0, 0.1, 5.0, 0.0, 1.6e-9
        rod, dt_crit = rectangular_rod(
            args.elements, L, w, t, E, nu, rho, scale_inertia=args.rotary_inertia == "match-axial"
        )
        dl = L / args.elements
        centres = (np.arange(args.elements) + 0.5) * dl
        moments = np.where(centres < 1.0, 62.9 * w * t * dl, 0.0)
        sim.append(rod)
        sim.add_forcing_to(rod).using(
            RFTMagnetic,
            drag_per_length=np.array([1.0e-8 * w, 1.0e-8 * w, 1.89e-8 * w]),
            moments=moments,
            B0=1.0e-5,
            freq=args.frequency,
        )
        period = 1.0 / args.frequency
        t_end = args.periods * period
    else:
        L, w, t, E, nu, rho = 10.0, 1.0, 0.1, 1.2e6, 0.0, 1e-9
        # OneEndFixedBC holds node 0 and element 0's directors: the rod is in effect
        # clamped at the centre of its first element; that centre is put at x = 0, so
        # the cantilever's free length is L (clamping node 0 at x = 0 makes the beam
        # Δl/2 too short: +13 % on the frequency at 8 elements)
        dl = L / (args.elements - 0.5)
        rod, dt_crit = rectangular_rod(
            args.elements,
            L + dl / 2,
            w,
            t,
            E,
            nu,
            rho,
            x0=-dl / 2,
            scale_inertia=args.rotary_inertia == "match-axial",
        )
        EI = E * w * t**3 / 12
        sim.append(rod)
        sim.constrain(rod).using(
            ea.OneEndFixedBC, constrained_position_idx=(0,), constrained_director_idx=(0,)
        )
        omega1 = 1.87510407**2 * math.sqrt(EI / (rho * w * t * L**4))
        period = 2 * math.pi / omega1
    dt = args.dt if args.dt > 0 else args.cfl * dt_crit
    if args.problem == "elastica":
        P = 2.0 * EI / L**2
        sim.add_forcing_to(rod).using(
            ea.EndpointForces,
            start_force=np.zeros(3),
            end_force=np.array([0.0, 0.0, P]),
            ramp_up_time=1e-12,
        )
        # about critical damping of the first mode
        sim.dampen(rod).using(
            ea.AnalyticalLinearDamper, uniform_damping_constant=omega1, time_step=dt
        )
    if args.problem == "frequency":
        bl = 1.87510407
        sig = (math.cosh(bl) + math.cos(bl)) / (math.sinh(bl) + math.sin(bl))

        def phi(x):
            b = bl * x / L
            return np.cosh(b) - np.cos(b) - sig * (np.sinh(b) - np.sin(b))

        def dphi(x):
            b = bl * x / L
            return bl / L * (np.sinh(b) + np.sin(b) - sig * (np.cosh(b) - np.cos(b)))

        amp = 1e-3 * L / phi(L)
        xn = np.maximum(rod.position_collection[0].copy(), 0.0)
        xe = 0.5 * (xn[1:] + xn[:-1])
        rod.velocity_collection[2, :] = amp * omega1 * phi(xn)
        rod.omega_collection[1, :] = amp * omega1 * dphi(xe)
    sim.finalize()
    stepper = ea.PositionVerlet()
    n_steps = None
    if args.problem == "swim":
        n_steps = int(round(t_end / dt))
        if abs(n_steps * dt - t_end) > 1e-9 * t_end:
            n_steps = int(math.ceil(t_end / dt))
        dt = t_end / n_steps
    out.update(dt=dt, dt_crit=dt_crit)
    pos = rod.position_collection
    mass = rod.mass

    def centroid_x():
        return float(np.dot(mass, pos[0]) / mass.sum())

    t_setup = _time.perf_counter()
    time = 0.0
    # the first steps carry numba's JIT (or its cache load)
    time = stepper.step(sim, time, dt)
    t_first = _time.perf_counter()
    steps = 1
    ok = True
    if args.problem == "swim":
        per = int(round(period / dt))
        marks = {0: centroid_x()}
        for k in range(1, n_steps):
            time = stepper.step(sim, time, dt)
            steps += 1
            if steps % per == 0:
                marks[steps // per] = centroid_x()
                if not np.isfinite(marks[steps // per]):
                    ok = False
                    break
        if ok:
            marks[args.periods] = centroid_x()
            x0 = marks[args.window]
            speed = (marks[args.periods] - x0) / ((args.periods - args.window) * period)
            out.update(
                value=speed,
                quantity="centroid x speed, mm/s",
                centroid=[marks[k] for k in sorted(marks)],
            )
    elif args.problem == "elastica":
        check = max(1, int(round(0.1 * period / dt)))
        last = None
        t_max = 40 * period
        while time < t_max:
            for _ in range(check):
                time = stepper.step(sim, time, dt)
            steps += check
            tip = float(pos[2, -1]) / L
            if not np.isfinite(tip):
                ok = False
                break
            if last is not None and abs(tip - last) < args.settle:
                break
            last = tip
        out.update(value=tip, quantity="tip deflection w/L", settled_at=time)
    else:
        t_end = 3.2 * period
        ts, ws = [0.0], [0.0]
        while time < t_end:
            time = stepper.step(sim, time, dt)
            steps += 1
            ts.append(time)
            ws.append(float(pos[2, -1]))
        ts, ws = np.array(ts), np.array(ws)
        if not np.all(np.isfinite(ws)):
            ok = False
        else:
            # the period from the zero crossings, as benchmarks/peer_race.py does for rftfem
            i = np.where(ws[1:-1] * ws[2:] < 0)[0] + 1
            tc = ts[i] - ws[i] * (ts[i + 1] - ts[i]) / (ws[i + 1] - ws[i])
            half = float((tc[-1] - tc[0]) / (len(tc) - 1))
            out.update(
                value=1.0 / (2 * half), quantity="first frequency, Hz", exact=omega1 / (2 * math.pi)
            )
    t_end_wall = _time.perf_counter()
    out.update(
        ok=bool(ok),
        steps=steps,
        wall_import_setup=t_setup - T0,
        wall_first_step=t_first - t_setup,
        wall_loop=t_end_wall - t_first,
        wall_inside=t_end_wall - T0,
        numba_cache=os.environ.get("NUMBA_CACHE_DIR", ""),
    )
    print(json.dumps(out))
    return 0 if ok else 3


if __name__ == "__main__":
    sys.exit(main())
