"""``msfd tune``: find the beam thickness (and more) that gives a target energy split.

Registered in `msfd_jax.cli.COMMANDS` by `msfd_jax.cli.tune`, a lazy import (msfd_jax never
imports this package at module import). The collision, mesh and numerics options are
`msfd run`'s (`msfd_jax.cli.common`).

Robust tuning: ``--velocity-samples 0.6 0.82 1.0 --mass-samples 5 10 20`` tunes the *expected*
split over every combination of the samples (9 collisions, vmapped in one program; with
``--pair-samples`` sample i is (v_i, g_i) instead), and the JSON adds each sample's fractions.

With SI inputs (``--si``, ``--impact-speed``, ``--block-mass``, ... as for ``msfd run``), the
result also gives the beam thickness in mm, h_b = (h_b/h_r) h_r (text, and ``"si"`` in the
JSON: ``beam_thickness_mm``, ``ring_thickness_mm``, the bounds in mm); the tuned variable stays
the ratio h_b/h_r (``--thickness-bounds`` are ratios).

Exit codes: 0 target met by the sharp model, 2 bad input, 3 a failed solve, 4 target not met
(``unreachable`` within the bounds, or not converged); the JSON says which.
"""

from __future__ import annotations

import argparse
import json

import msfd_jax as m
from msfd_jax.cli import common as cli  # the leaf: importing msfd_jax.cli would cycle

from ._conditions import Conditions
from ._design import DEFAULT_BOUNDS, Design, default_box
from ._gradient import MODES
from ._objective import ShareAtLeast, ShareAtMost, TargetShare, objective
from ._problem import make_problem
from ._tune import DEFAULT_STAGES, Stage, tune

EXIT_NOT_MET = 4

# option -> (term, structure)
_TERMS = {
    "target_beam_share": (TargetShare, "beam"),
    "target_ring_share": (TargetShare, "ring"),
    "max_beam_share": (ShareAtMost, "beam"),
    "max_ring_share": (ShareAtMost, "ring"),
    "min_beam_share": (ShareAtLeast, "beam"),
    "min_ring_share": (ShareAtLeast, "ring"),
}


def _pair(text: str) -> tuple[float, float]:
    try:
        low, high = (float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected LOW,HIGH, got {text!r}") from None
    return low, high


def add_tune_arguments(parser: argparse.ArgumentParser) -> None:
    cli.add_collision_arguments(parser)
    cli.add_numerics_arguments(parser)
    goal = parser.add_argument_group(
        "targets (fractions of K0; beam = beam bending + axial, ring = ring bending + axial)"
    )
    texts = {
        TargetShare: "the share to reach, within --tolerance",
        ShareAtMost: "an upper limit on the share",
        ShareAtLeast: "a lower limit on the share",
    }
    for field, (term, structure) in _TERMS.items():
        flag = "--" + field.replace("_", "-")
        goal.add_argument(
            flag,
            type=float,
            dest=field,
            metavar="X",
            help=f"{texts[term]} of K0 dissipated in the {structure} (default: none)",
        )
    tuning = parser.add_argument_group("tuning (the design starts at --thickness-ratio)")
    low, high = DEFAULT_BOUNDS["thickness_ratio"]
    tuning.add_argument(
        "--thickness-bounds",
        type=_pair,
        default=(low, high),
        metavar="LOW,HIGH",
        help=f"bounds of h_b/h_r (default {low:g},{high:g})",
    )
    tuning.add_argument("--mode", choices=MODES, default="forward", help="gradient mode")
    tuning.add_argument(
        "--tolerance", type=float, default=0.01, help="K0 (default 0.01): the sharp model's miss"
    )
    tuning.add_argument(
        "--iterations",
        type=int,
        default=DEFAULT_STAGES[0].iterations,
        help="iterations per annealing stage (default %(default)s)",
    )
    cli.add_quiet_argument(tuning)
    robust = parser.add_argument_group(
        "robust tuning (the targets apply to the expected split over impact samples)"
    )
    robust.add_argument(
        "--velocity-samples",
        type=cli.values,
        nargs="+",
        metavar="V0",
        help="samples of v0: x,y,... or a:b:n (as every list option; default: none)",
    )
    robust.add_argument(
        "--mass-samples",
        type=cli.values,
        nargs="+",
        metavar="G",
        help="samples of the mass ratio g: x,y,... or a:b:n (default: none)",
    )
    robust.add_argument(
        "--pair-samples",
        action="store_true",
        help="sample i is (v0_i, g_i) (equal counts) instead of every combination",
    )
    parser.add_argument("--json", action="store_true", help="print one JSON object, nothing else")


def _objective(args: argparse.Namespace):
    terms = [
        term(structure, getattr(args, field))
        for field, (term, structure) in _TERMS.items()
        if getattr(args, field) is not None
    ]
    if not terms:
        raise ValueError("give a target, e.g. --target-beam-share 0.6 (see --help)")
    for term in terms:
        value = float(getattr(term, "target", getattr(term, "limit", 0.0)))
        if not 0.0 <= value <= 1.0:
            raise ValueError(f"targets are fractions of K0 in [0, 1], got {value:g}")
    if args.contact_smoothing or args.yield_smoothing:
        raise ValueError(
            "tune anneals its own smoothing (optimise.DEFAULT_STAGES) and judges the design on "
            "the sharp model; drop --contact-smoothing / --yield-smoothing"
        )
    if not (args.tolerance > 0 and args.iterations >= 1):
        raise ValueError("--tolerance must be > 0 and --iterations >= 1")
    return objective(*terms)


def _flat(lists):
    return None if lists is None else [v for values in lists for v in values]


def _conditions(args: argparse.Namespace) -> Conditions | None:
    velocity, mass = _flat(args.velocity_samples), _flat(args.mass_samples)
    if velocity is None and mass is None:
        if args.pair_samples:
            raise ValueError("--pair-samples needs --velocity-samples and --mass-samples")
        return None
    if args.pair_samples:
        return Conditions(velocity=velocity, mass_ratio=mass)
    return Conditions.grid(velocity=velocity, mass_ratio=mass)


def tune_command(args: argparse.Namespace) -> int:
    params, scales = cli.checked(cli.collision_from_args, args)
    mesh, settings = (
        cli.checked(cli.mesh_from_args, args),
        cli.checked(cli.settings_from_args, args),
    )
    cli.checked(m.validate, params, mesh)
    goal = cli.checked(_objective, args)
    conditions = cli.checked(_conditions, args)
    design = cli.checked(Design, thickness_ratio=float(params.thickness_ratio))
    box = cli.checked(default_box, design, thickness_ratio=args.thickness_bounds)
    low, high = args.thickness_bounds  # start inside the box
    design = Design(thickness_ratio=min(max(float(params.thickness_ratio), low), high))
    if not args.no_cache:
        cli.enable_compilation_cache()
    stages = tuple(
        Stage(s.yield_smoothing, s.contact_smoothing, args.iterations, s.learning_rate)
        for s in DEFAULT_STAGES
    )
    if not args.json or not args.quiet:
        cli.note("tuning; the first iteration compiles for a while...")
    total = sum(s.iterations for s in stages)
    progress = None if args.quiet else cli.LineProgress(total, "tune", unit=" iterations")
    try:
        problem = make_problem(params, mesh, settings, box, conditions)
        result = tune(
            design,
            problem,
            goal,
            box=box,
            stages=stages,
            mode=args.mode,
            tolerance=args.tolerance,
            progress=progress,
        )
    except m.SimulationError as error:
        cli.note(f"simulation failed: {error}")
        return cli.EXIT_SOLVE
    finally:
        if progress is not None:
            progress.close()
    si = None if scales is None else si_thickness(result, params, scales, args.thickness_bounds)
    if args.json:
        # strict JSON (allow_nan=False): a number that is not finite raises, never writes NaN
        print(json.dumps({**result.to_json(), **({"si": si} if si else {})}, allow_nan=False))
    else:
        print(report(result, si))
    return cli.EXIT_OK if result.status == "converged" else EXIT_NOT_MET


def si_thickness(result, params: m.CollisionParams, scales: m.Scales, bounds) -> dict:
    """The found design in SI: beam thickness h_b = (h_b/h_r) h_r, in mm.

    The ring thickness is h_r = R / (R/h_r): the length scale over the slenderness, so it is
    read from what `from_si` made of the SI inputs, whatever they were called.
    """
    ring = scales.length / float(params.slenderness)  # h_r [m]
    ratio = float(result.design.thickness_ratio)
    return {
        "thickness_ratio": ratio,
        "ring_thickness_mm": 1e3 * ring,
        "beam_thickness_mm": 1e3 * ratio * ring,
        "beam_thickness_bounds_mm": [1e3 * float(b) * ring for b in bounds],
    }


def report(result, si: dict | None = None) -> str:
    lines = [result.message, "", "sharp-model energy partition at the design (fractions of K0)"]
    if si is not None:
        low, high = si["beam_thickness_bounds_mm"]
        lines[1:1] = [
            f"beam thickness h_b = {si['beam_thickness_mm']:.2f} mm "
            f"(h_b/h_r = {si['thickness_ratio']:.4f} x ring thickness "
            f"{si['ring_thickness_mm']:.2f} mm; bounds {low:.2f}-{high:.2f} mm)"
        ]
    for key in m.FRACTION_KEYS:
        lines.append(f"  {key:<13} {result.fractions[key]:8.4f}")
    if result.samples is not None:
        lines[2] = "expected (mean over the impact samples) " + lines[2]
        lines.append("per impact sample (sharp model): v0, g, beam share, ring share")
        for c, f in zip(result.conditions, result.samples, strict=True):
            v0 = c.get("velocity", "base")
            g = c.get("mass_ratio", "base")
            beam = f["beam_bending"] + f["beam_axial"]
            ring = f["ring_bending"] + f["ring_axial"]
            lines.append(f"  {v0!s:>6} {g!s:>6}  {beam:8.4f} {ring:8.4f}")
    lines.append(
        "final collision: "
        + ("settled" if result.settled else "NOT settled (" + ", ".join(result.final_status) + ")")
    )
    lines.append(f"iterations {result.iterations}, wall time {result.wall_time_s:.1f} s")
    return "\n".join(lines)
