"""The ``[time]`` table of a scene: its keys, and the checks of its step and of the
error control that fill its step bounds (the rules that read the rest of the scene
are :mod:`rftfem.scene.time_rules`)."""

from __future__ import annotations

from rftfem.errors import SceneError
from rftfem.scene.schema import MAX_STEPS, POSITIVE, Int, Leaf, Num, Str, Table, fmt
from rftfem.scene.time_rules import resolved_scheme

TIME = Table(
    {
        "end": Leaf(
            POSITIVE,
            1.0,
            unit="time",
            doc="The time the run stops at; linear load ramps reach their full value "
            'there. With scheme = "static" time is only a load parameter.',
        ),
        "dt": Leaf(
            POSITIVE,
            0.01,
            unit="time",
            doc="The nominal step, at most `end`: the run makes ceil(end / dt) steps, "
            "the last one ending at `end`. A step that fails is halved and "
            "retried, then grown back. With arc-length: the first step's "
            "increment of the load factor.",
        ),
        "scheme": Leaf(
            Str(
                (
                    "auto",
                    "generalized-alpha",
                    "hht",
                    "backward-euler",
                    "bdf2",
                    "static",
                    "arc-length",
                )
            ),
            "auto",
            doc='The time integrator. "generalized-alpha" and "hht" are second '
            'order and need density; "backward-euler" (first order) and '
            '"bdf2" (second order, variable steps) are for drag without '
            'inertia; "static" steps the loads with no velocity '
            '(refused with [fluid]); "arc-length" follows the static '
            "equilibrium path with the load factor as an unknown, through "
            "limit points and snap-backs (refused with [fluid]; time is then "
            'the load factor λ). "auto" takes generalized-alpha with '
            "density, backward-euler with [fluid] alone, static otherwise.",
        ),
        "start": Leaf(
            Str(("rest", "equilibrium")),
            "rest",
            doc='How a run in time starts. "rest": in its initial state, at '
            "rest: the reference, or the shape the t = 0 motions impose "
            "with the rest of the body in elastic equilibrium; loads on at "
            "t = 0 act from the first step on (a free plate in drag under a "
            "constant force F has u(t) = F t / (C A) at every row). "
            '"equilibrium": at rest in static equilibrium with the t = 0 '
            "loads as well, to release a pre-loaded body (a load table that "
            "drops to 0 after t = 0). Static runs always start in "
            "equilibrium with their t = 0 loads.",
        ),
        "rho_inf": Leaf(
            Num(0.0, 1.0),
            0.9,
            doc="Generalized-alpha's spectral radius at infinite frequency: 1 "
            "damps nothing, smaller values damp the highest frequencies "
            "more. Used by generalized-alpha only.",
        ),
        "alpha": Leaf(
            Num(-1.0 / 3.0, 0.0),
            -0.05,
            doc="The α of the HHT scheme; 0 is the trapezoidal rule, more "
            "negative values damp high frequencies. Used by hht only.",
        ),
        "output_every": Leaf(
            Int(1),
            1,
            doc="Write a row of probes.csv and body.csv, and the fields, "
            "every this many nominal steps (and after the last one).",
        ),
        "until": Leaf(
            Str(("end", "periodic")),
            "end",
            doc='When the run stops: "end" at time.end; "periodic" once the '
            "period means of every probes.csv and body.csv column (the drift "
            "over a period for positions) have settled, extrapolated from "
            "successive periods (Aitken), to steady_tolerance; time.end is then "
            "the latest it may stop. summary.json's `steady` holds the values.",
        ),
        "period": Leaf(
            POSITIVE,
            None,
            unit="time",
            default_doc="from the travelling-wave motions or the rotating field",
            doc='The period of time.until = "periodic"; dt must divide it.',
        ),
        "steady_tolerance": Leaf(
            POSITIVE,
            1e-3,
            doc='time.until = "periodic": how closely two successive '
            "periods' extrapolated steady values must agree, "
            "relative to each column's value (or its swing over "
            "a period, if larger).",
        ),
        "max_steps": Leaf(
            Int(1),
            1000,
            doc='With scheme = "arc-length": the run stops after this many '
            "steps if the load factor has not reached `end` by then.",
        ),
        "max_cuts": Leaf(
            Int(0),
            8,
            doc="How many times one nominal step may be halved before the "
            "run fails (exit status 3); a failed attempt may halve it "
            "several times at once.",
        ),
        "tolerance": Leaf(
            POSITIVE,
            None,
            default_doc="none: fixed steps of `dt`",
            doc="Error-controlled steps: the largest local error a step may "
            "make, relative to the body's size for displacements (and in "
            "radians for rotations), estimated from the step's distance "
            "to its prediction. `dt` is then the first step, steps grow "
            "and shrink within [`dt_min`, `dt_max`], and outputs still "
            "fall every `output_every` × `dt`. Not with static.",
        ),
        "dt_min": Leaf(
            POSITIVE,
            None,
            unit="time",
            default_doc="dt × 1e-6 (with `tolerance` only)",
            doc="The smallest step the error control may take; a step that "
            "needs a smaller one fails the run (exit status 3).",
        ),
        "dt_max": Leaf(
            POSITIVE,
            None,
            unit="time",
            default_doc="end (with `tolerance` only)",
            doc="The largest step the error control may take.",
        ),
        "max_rotation": Leaf(
            POSITIVE,
            0.2,
            unit="rad",
            doc="The most any director may turn within one converged step "
            "of a scheme with velocity (not static); a step that turns "
            "one further is halved, as it would skip fast motion.",
        ),
    },
    required=True,
    doc="Time span, step and integration scheme.",
)


def check_time(scene: dict) -> None:
    """The checks of [time] once the scene is validated (in place: error control gets
    its step bounds)."""
    time = scene["time"]
    if time["dt"] > time["end"]:
        raise SceneError(
            f"time.dt: expected a number <= time.end = {fmt(time['end'])}, found {fmt(time['dt'])}"
        )
    if time["end"] / time["dt"] > MAX_STEPS:
        raise SceneError(
            f"time.dt: expected at most {MAX_STEPS:.0e} steps up to time.end = "
            f"{fmt(time['end'])}, found dt = {fmt(time['dt'])} "
            f"({time['end'] / time['dt']:.1e} steps)"
        )

    if time["tolerance"] is None:
        for key in ("dt_min", "dt_max"):
            if time[key] is not None:
                raise SceneError(
                    f"time.{key}: bounds the error-controlled step; it needs time.tolerance"
                )
    else:
        if resolved_scheme(scene) in ("static", "arc-length"):
            raise SceneError(
                "time.tolerance: the scheme is static (load steps have no time "
                "error to control); remove time.tolerance or use a scheme in time"
            )
        if time["dt_min"] is None:
            time["dt_min"] = time["dt"] * 1e-6
        if time["dt_max"] is None:
            time["dt_max"] = time["end"]
        if not time["dt_min"] <= time["dt"] <= time["dt_max"]:
            raise SceneError(
                f"time.dt: the first step must lie within [time.dt_min, "
                f"time.dt_max] = [{fmt(time['dt_min'])}, {fmt(time['dt_max'])}], "
                f"found {fmt(time['dt'])}"
            )
