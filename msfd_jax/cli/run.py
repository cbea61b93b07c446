"""``msfd run``: simulate one ring-on-beam collision (default: the paper's Fig. 13)."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import msfd_jax as m

from .common import (
    EXIT_OK,
    EXIT_SOLVE,
    add_collision_arguments,
    add_numerics_arguments,
    checked,
    collision_from_args,
    enable_compilation_cache,
    mesh_from_args,
    note,
    settings_from_args,
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_collision_arguments(parser)
    add_numerics_arguments(parser)
    out = parser.add_argument_group("output")
    out.add_argument("--plot", type=Path, metavar="PATH", help="save the four-panel figure")
    out.add_argument("--json", action="store_true", help="print one JSON object, nothing else")


def _check_smoothing(args: argparse.Namespace) -> None:
    for name in ("contact_smoothing", "yield_smoothing"):
        value = getattr(args, name)
        if not 0.0 <= value <= 1.0e3:  # also rejects nan
            raise ValueError(f"{name} = {value:g} is out of range; allowed [0, 1000]")


def handle(args: argparse.Namespace) -> int:
    params, scales = checked(collision_from_args, args)
    mesh, settings = checked(mesh_from_args, args), checked(settings_from_args, args)
    # What `ring_on_beam` would reject, checked here so that `run` only fails in the solve.
    checked(m.validate, params, mesh)
    checked(_check_smoothing, args)
    cache = None if args.no_cache else enable_compilation_cache()
    where = f" (compiled code is cached in {cache})" if cache else ""
    note(f"running; the first run of a mesh compiles for a while{where}...")
    try:
        collision = m.run(
            params,
            mesh,
            settings,
            contact_smoothing=args.contact_smoothing,
            yield_smoothing=args.yield_smoothing,
        )
    except m.SimulationError as error:
        note(f"simulation failed: {error}")
        return EXIT_SOLVE
    if args.plot is not None:
        from .._plot import plot_collision

        plot_collision(collision, args.plot)
    if args.json:
        record = collision.to_json()
        if scales is not None:
            record["si_scales"] = vars(scales)
        print(json.dumps(record))
    else:
        print(report(collision, scales))
        if args.plot is not None:
            print(f"plot saved to {args.plot}")
    return EXIT_OK


def report(collision: m.Collision, scales: m.Scales | None = None) -> str:
    """A readable summary: the partition table, checks, timing and how the run ended."""
    record = collision.to_json()
    p = record["params"]
    lines = [
        f"ring on beam: h_b/h_r = {p['thickness_ratio']:g}, E/Y = {p['modulus_ratio']:g}, "
        f"R/h_r = {p['slenderness']:g}, g = {p['mass_ratio']:g}, v0 = {p['velocity']:g}, "
        f"L_b/R = {p['span_ratio']:g}, b_b/b_r = {p['width_ratio']:g}, "
        + ("axially constrained" if p["axial_constraint"] else "axially free"),
        "",
        f"energy partition at tau = {record['t_end']:.4g} (fractions of K0 = "
        f"{record['k0']:.4g} M_pr)",
    ]
    total = 0.0
    for key, value in record["fractions"].items():
        total += value
        bar = "#" * round(40 * max(value, 0.0))
        lines.append(f"  {key:<13} {value:8.4f} {100 * value:7.2f} %  {bar}")
    lines += [
        f"  {'sum':<13} {total:8.4f}",
        "",
        f"energy balance error  {record['energy_balance_error']:+.2e} K0",
        f"t_end                 {record['t_end']:.4g}",
        f"steps                 {record['steps']}",
        f"dt                    {record['dt']:.3e} = {record['dt'] / record['dt_critical']:.2f}"
        f" x dt_crit ({record['dt_critical']:.3e})",
        f"wall time             {record['wall_time_s']:.2f} s (including any compilation)",
    ]
    if scales is not None:
        t_end_ms = 1e3 * record["t_end"] * scales.time
        k0_joule = record["k0"] * scales.moment
        lines += [
            f"SI time scale T       {scales.time:.4g} s (t_end = {t_end_ms:.4g} ms)",
            f"SI energy unit M_pr   {scales.moment:.4g} J (K0 = {k0_joule:.4g} J)",
        ]
    lines.append(f"status: {collision.message}")
    return "\n".join(lines)
