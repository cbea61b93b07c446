"""``msfd design``: a graded guardrail beam under a designer's limits, in SI (`optimise.design`).

Registered in `msfd_jax.cli.COMMANDS` by `msfd_jax.cli.design` (a lazy import, as ``tune``).
The collision is `msfd run`'s SI input (``--si`` and the SI options, or a case file's
``[collision]`` table); its ``thickness_ratio`` (``beam_thickness`` / ``ring_thickness``) is the
uniform beam the design starts from and whose mass the budget refers to. The ``[design]`` table
(or the options of the "design" group) says what to minimise and the limits.

Exit codes: 0 a design meeting every limit (``converged`` or ``feasible``), 2 bad input, 3 a
failed solve, 4 no design in the bounds met every limit (``infeasible``: the JSON gives the
closest design found).
"""

from __future__ import annotations

import argparse
import dataclasses
import itertools

import numpy as np

import msfd_jax as m
from msfd_jax._collision.provenance import dumps
from msfd_jax._model.si import STANDARD_GRAVITY
from msfd_jax.cli import common as cli
from msfd_jax.cli.common import SI

from ._cli import _flat, _pair
from ._conditions import Conditions
from ._graded import METHODS, QUANTITIES, graded_problem
from ._search import design

EXIT_INFEASIBLE = 4


def add_design_arguments(parser: argparse.ArgumentParser) -> None:
    cli.add_case_argument(parser)
    cli.add_collision_arguments(parser)
    cli.add_numerics_arguments(parser)
    group = parser.add_argument_group(
        "design (a graded beam: one thickness per beam segment; limits in SI)"
    )
    group.add_argument(
        "--minimise",
        choices=[q for q in QUANTITIES if q != "contact_force"] + ["contact_force"],
        default="deceleration_10ms",
        help="the quantity to minimise: the 10 ms block deceleration, the peak mid-span "
        "deflection, the beam mass ratio, the peak contact force, or an energy share",
    )
    group.add_argument("--max-deflection-m", type=float, metavar="M", help="peak deflection")
    group.add_argument(
        "--max-deceleration-10ms-g", type=float, metavar="G", help="10 ms deceleration, in g"
    )
    group.add_argument(
        "--max-contact-force-n", type=float, metavar="N", help="peak contact force (whole beam)"
    )
    group.add_argument(
        "--max-beam-mass-ratio",
        type=float,
        metavar="R",
        help="beam mass over the uniform beam of the collision's thickness ratio",
    )
    group.add_argument(
        "--thickness-bounds",
        type=_pair,
        default=(1.0, 5.0),
        metavar="LOW,HIGH",
        help="bounds of every segment's h/h_r",
    )
    group.add_argument(
        "--profile-points",
        type=int,
        metavar="K",
        help="control points of the profile (piecewise linear over the half span); "
        "absent: one free value per beam segment",
    )
    group.add_argument(
        "--method",
        choices=METHODS,
        default="slsqp",
        help="slsqp: scipy's SLSQP on the smoothed surrogate, every point checked on the sharp "
        "model (the default); adam: an augmented Lagrangian around projected Adam steps",
    )
    group.add_argument(
        "--steps", type=int, default=30, help="at most this many points after the start"
    )
    group.add_argument(
        "--impact-speeds",
        type=cli.values,
        nargs="+",
        metavar="V",
        help="robust design: impact speeds [m/s] (with --block-masses: every combination); the "
        "objective is the mean, each limit applies to the worst sample",
    )
    group.add_argument(
        "--block-masses", type=cli.values, nargs="+", metavar="KG", help="robust: block masses"
    )
    cli.add_quiet_argument(group)
    parser.add_argument("--json", action="store_true", help="print one JSON object, nothing else")


def _conditions(args, si_inputs: dict) -> Conditions | None:
    speeds, masses = _flat(args.impact_speeds), _flat(args.block_masses)
    if speeds is None and masses is None:
        return None
    speeds = speeds or [si_inputs["impact_speed"]]
    masses = masses or [si_inputs["block_mass"]]
    pairs = list(itertools.product(speeds, masses))
    groups = []
    for speed, mass in pairs:
        inputs = {**si_inputs, "impact_speed": speed, "block_mass": mass}
        axial = inputs.pop("axial_constraint", True)
        groups.append(m.from_si(**inputs, axial_constraint=bool(axial))[0])
    return Conditions(
        velocity=[float(p.velocity) for p in groups],
        mass_ratio=[float(p.mass_ratio) for p in groups],
    )


def _limits(args) -> dict[str, float]:
    limits = {}
    if args.max_deflection_m is not None:
        limits["deflection"] = args.max_deflection_m
    if args.max_deceleration_10ms_g is not None:
        limits["deceleration_10ms"] = args.max_deceleration_10ms_g * STANDARD_GRAVITY
    if args.max_contact_force_n is not None:
        limits["contact_force"] = args.max_contact_force_n
    for name, value in limits.items():
        if not (np.isfinite(value) and value > 0):
            raise ValueError(f"the limit on {name} must be a positive number, got {value!r}")
    return limits


def design_command(args: argparse.Namespace) -> int:
    params, scales = cli.checked(cli.collision_from_args, args)
    if scales is None:
        raise cli.UsageError(
            "msfd design works in SI (its limits are metres and g): give --si and the SI "
            "options, or SI values in the case file's [collision] table"
        )
    if params.graded:
        raise cli.UsageError(
            "msfd design finds the thickness profile: give the uniform beam it starts from "
            "(beam_thickness) and no thickness_profile"
        )
    mesh = cli.checked(cli.mesh_from_args, args)
    settings = cli.checked(cli.settings_from_args, args)
    cli.checked(m.validate, params, mesh)
    limits = cli.checked(_limits, args)
    si_inputs = {
        **m.PAPER_SI,
        **{k: getattr(args, f"si_{k}") for k in SI if getattr(args, f"si_{k}") is not None},
        "axial_constraint": bool(args.axial_constraint),
    }
    conditions = cli.checked(_conditions, args, si_inputs)
    if not args.no_cache:
        cli.enable_compilation_cache()
    if not args.json or not args.quiet:
        cli.note("designing; the first iteration compiles for a minute or two...")
    progress = None if args.quiet else cli.LineProgress(args.steps + 1, "design", unit=" its")

    def step(i, record):
        if progress is not None:
            progress(
                f"iteration {i}: {args.minimise} {record['objective']:.5g}, largest excess "
                f"over the limits {100 * record['violation']:.2f} %"
            )

    try:
        problem = cli.checked(
            graded_problem,
            params,
            scales,
            mesh,
            profile_points=args.profile_points,
            conditions=conditions,
            bounds=args.thickness_bounds,
            settings=settings if settings.t_max is not None else None,
        )
        result = cli.checked(
            design,
            problem,
            minimise=args.minimise,
            limits=limits,
            max_beam_mass_ratio=args.max_beam_mass_ratio,
            thickness_bounds=args.thickness_bounds,
            steps=args.steps,
            progress=step,
            method=args.method,
        )
        graded = dataclasses.replace(params, thickness_profile=result.thickness_profile)
        found = m.run(graded, mesh, scales=scales)
    except m.SimulationError as error:
        cli.note(f"simulation failed: {error}")
        return cli.EXIT_SOLVE
    finally:
        if progress is not None:
            progress.close()
    record = result.as_json()
    record["si"] = found.si
    record["fractions"] = {k: float(v) for k, v in found.fractions.items()}
    record["mesh"] = {
        "ring_segments": mesh.ring_segments,
        "beam_contact_segments": mesh.beam_contact_segments,
        "beam_outer_segments": mesh.beam_outer_segments,
    }
    record["profile_points"] = problem.points
    if args.json:
        print(dumps(record))  # strict: a non-finite number raises, never writes NaN
    else:
        print(report(record))
    return EXIT_INFEASIBLE if result.status == "infeasible" else cli.EXIT_OK


def report(record: dict) -> str:
    """The readable summary of a design."""
    v, s = record["values"], record["start"]
    lines = [
        f"design: {record['status']} after {record['iterations']} iterations "
        f"({record['evaluations']:.0f} forward-run equivalents, {record['wall_time_s']:.1f} s)",
        f"  minimised {record['minimise']}: {s[record['minimise']]:.4g} (uniform start) -> "
        f"{v[record['minimise']]:.4g}",
        "  thickness profile h/h_r, O to E: "
        + ", ".join(f"{t:.3f}" for t in record["thickness_profile"]),
        f"  beam mass ratio {record['beam_mass_ratio']:.4f}",
        f"  peak deflection {1e3 * v['deflection']:.1f} mm, 10 ms deceleration "
        f"{v['deceleration_10ms'] / STANDARD_GRAVITY:.1f} g, peak contact force "
        f"{v['contact_force'] / 1e3:.1f} kN",
    ]
    for name, c in record["constraints"].items():
        met = "met" if c["margin"] >= 0 else "NOT met"
        lines.append(f"  limit {name}: {c['value']:.5g} <= {c['limit']:.5g} ({met})")
    return "\n".join(lines)


__all__ = ["add_design_arguments", "design_command", "report"]
