"""Command line: ``msfd run`` simulates one ring-on-beam collision (default: the paper's Fig. 13).

Subcommands are registered in `COMMANDS` as (add_arguments, handler); the argument groups
below (parameters, SI inputs, mesh, numerics) are shared so that later subcommands (``sweep``,
``tune``, ``bench``, ``reproduce``) read a collision the same way ``run`` does.

Exit codes: 0 success, 2 bad input (argparse or parameter validation), 3 failed solve.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from collections.abc import Callable, Sequence
from pathlib import Path

import msfd_jax as m

from . import _cli_bench as _bench
from . import _cli_reproduce as _reproduce
from . import _cli_sweep as _sweep

EXIT_OK, EXIT_USAGE, EXIT_SOLVE = 0, 2, 3


class UsageError(Exception):
    """Bad input found while reading the arguments (exit code 2, no traceback)."""


# CLI option -> CollisionParams field; defaults are the paper's showcase (CollisionParams()).
_PARAMS = {
    "thickness_ratio": ("--thickness-ratio", "h_b/h_r, beam to ring thickness"),
    "modulus_ratio": ("--modulus-ratio", "E/Y, Young's modulus over yield stress"),
    "slenderness": ("--slenderness", "R/h_r, ring radius over ring thickness"),
    "mass_ratio": ("--mass-ratio", "g = G/(mu_r R), half block mass over ring mass per radius"),
    "velocity": ("--velocity", "v0 = V0 sqrt(mu_r R / M_pr), impact velocity"),
    "span_ratio": ("--span-ratio", "L_b/R, beam half span over ring radius"),
    "width_ratio": ("--width-ratio", "b_b/b_r, beam to ring width"),
}
# CLI option -> from_si keyword; missing values come from m.PAPER_SI.
_SI = {
    "youngs_modulus": ("--youngs-modulus", "E [Pa]"),
    "yield_stress": ("--yield-stress", "Y [Pa]"),
    "density": ("--density", "rho [kg/m^3]"),
    "radius": ("--radius", "R [m]"),
    "width": ("--width", "b, ring width [m]"),
    "ring_thickness": ("--ring-thickness", "h_r [m]"),
    "beam_thickness": ("--beam-thickness", "h_b [m]"),
    "beam_half_span": ("--beam-half-span", "L_b, half the beam span [m]"),
    "velocity": ("--impact-speed", "V0 [m/s]"),
    "block_mass": ("--block-mass", "2G, the whole rigid block [kg]"),
    "beam_width": ("--beam-width", "b_b [m] (default: the ring width)"),
}
_OPTION_NAMES = {
    **{k: v[0] for k, v in _PARAMS.items()},
    **{k: v[0] for k, v in _SI.items() if k != "velocity"},
    "ring_segments": "--ring-segments",
    "beam_contact_segments": "--beam-contact-segments",
    "beam_outer_segments": "--beam-outer-segments",
    "contact_region": "--contact-region",
    "safety": "--safety",
    "dt": "--dt",
    "t_max": "--t-max",
    "history_points": "--history-points",
    "shape_times": "--shape-times",
    "contact_smoothing": "--contact-smoothing",
    "yield_smoothing": "--yield-smoothing",
}


def add_collision_arguments(parser: argparse.ArgumentParser) -> None:
    """Non-dimensional groups (Eq. 1) or their SI alternative, as `from_si` takes them."""
    group = parser.add_argument_group("collision (non-dimensional, Eq. 1; paper's Fig. 13)")
    defaults = m.CollisionParams()
    for field, (flag, text) in _PARAMS.items():
        default = float(getattr(defaults, field))
        group.add_argument(flag, type=float, dest=field, help=f"{text} (default {default:g})")
    group.add_argument(
        "--axial-constraint",
        action=argparse.BooleanOptionalAction,
        default=True,
        help="beam ends held axially (x_E = 0, Eq. 20) or free to slide (default: held)",
    )
    si = parser.add_argument_group(
        "SI inputs (instead of the groups above; missing values are the paper's base case)"
    )
    si.add_argument("--si", action="store_true", help="give the collision in SI units")
    for field, (flag, text) in _SI.items():
        si.add_argument(flag, type=float, dest=f"si_{field}", metavar="X", help=text)


def add_numerics_arguments(parser: argparse.ArgumentParser) -> None:
    """Mesh counts (static: a new mesh compiles anew) and integration settings."""
    mesh, settings = m.Mesh(), m.Settings()
    group = parser.add_argument_group("mesh (paper: 15 ring, 20 + 5 beam segments)")
    for field in ("ring_segments", "beam_contact_segments", "beam_outer_segments"):
        default = getattr(mesh, field)
        group.add_argument(_OPTION_NAMES[field], type=int, default=default, help=f"({default})")
    group.add_argument("--contact-region", type=float, default=mesh.contact_region, help="OC / R")
    group = parser.add_argument_group("numerics")
    group.add_argument("--safety", type=float, default=settings.safety, help="dt / dt_crit")
    group.add_argument("--dt", type=float, help="fixed time step (overrides --safety)")
    group.add_argument("--t-max", type=float, default=settings.t_max, help="cap on tau")
    group.add_argument("--history-points", type=int, default=settings.history_points)
    group.add_argument(
        "--shape-times",
        type=_times,
        metavar="T1,T2,...",
        help="times at which shapes are saved (default: the paper's 0.15,0.49,0.75,1.5 up to "
        "--t-max)",
    )
    group.add_argument("--contact-smoothing", type=float, default=0.0, help="ramp width / R")
    group.add_argument("--yield-smoothing", type=float, default=0.0, help="fraction of yield")
    group.add_argument("--no-cache", action="store_true", help="no persistent compile cache")


def collision_from_args(args: argparse.Namespace) -> tuple[m.CollisionParams, m.Scales | None]:
    """The parameters (and SI scales when SI inputs were given); raises ValueError if bad."""
    given_si = {k: getattr(args, f"si_{k}") for k in _SI if getattr(args, f"si_{k}") is not None}
    given = {k: getattr(args, k) for k in _PARAMS if getattr(args, k) is not None}
    if not (args.si or given_si):
        return m.CollisionParams(**given, axial_constraint=float(args.axial_constraint)), None
    if given:
        flags = ", ".join(_PARAMS[k][0] for k in given)
        raise ValueError(f"{flags} cannot be combined with SI inputs; give the SI value instead")
    si = {**m.PAPER_SI, **given_si}
    return m.from_si(**si, axial_constraint=args.axial_constraint)


def mesh_from_args(args: argparse.Namespace) -> m.Mesh:
    return m.Mesh(
        args.ring_segments,
        args.beam_contact_segments,
        args.beam_outer_segments,
        args.contact_region,
    )


def _times(text: str) -> tuple[float, ...]:
    try:
        return tuple(sorted(float(t) for t in text.split(",") if t.strip()))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected comma-separated numbers, got {text!r}"
        ) from None


def settings_from_args(args: argparse.Namespace) -> m.Settings:
    m.Settings(t_max=args.t_max, shape_times=())  # t_max first: shape times are judged by it
    shape_times = args.shape_times
    if shape_times is None:  # the paper's times (Fig. 13b) that fall inside the run
        shape_times = tuple(t for t in m.Settings().shape_times if t <= args.t_max)
    elif any(t > args.t_max for t in shape_times):  # asked for explicitly: refuse, not drop
        raise ValueError(f"shape_times {shape_times} must lie in [0, t_max = {args.t_max}]")
    return m.Settings(
        safety=args.safety,
        dt=args.dt,
        t_max=args.t_max,
        history_points=args.history_points,
        shape_times=shape_times,
    )


def enable_compilation_cache() -> Path:
    """JAX's persistent compilation cache, so a second process skips compiling (CLI only).

    The directory is ``$MSFD_CACHE_DIR`` or ``~/.cache/msfd-jax/jax``. JAX never writes an
    executable that contains host callbacks to the cache, and equinox's runtime checks (used
    by diffrax on ``dt0`` and ``SaveAt.ts``) are host callbacks under its default
    ``EQX_ON_ERROR=raise``; so unless the user chose a mode, the CLI switches them to ``nan``:
    a failed check then gives NaN, which the solver's non-finite guard reports (exit code 3).
    Our inputs are validated before they reach diffrax, so these checks cannot fire anyway.
    """
    import equinox._errors
    import jax

    if "EQX_ON_ERROR" not in os.environ and hasattr(equinox._errors, "EQX_ON_ERROR"):
        # Read by equinox at import, before this module runs; its module-level default is
        # what `error_if` consults at trace time. (Private: guarded, so a future equinox
        # without it only loses the cache, never breaks the CLI.)
        equinox._errors.EQX_ON_ERROR = "nan"
    default = Path.home() / ".cache" / "msfd-jax" / "jax"
    path = Path(os.environ.get("MSFD_CACHE_DIR") or default).expanduser()
    jax.config.update("jax_compilation_cache_dir", str(path))
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 0)
    jax.config.update("jax_persistent_cache_min_entry_size_bytes", -1)
    return path


def _add_run(parser: argparse.ArgumentParser) -> None:
    add_collision_arguments(parser)
    add_numerics_arguments(parser)
    out = parser.add_argument_group("output")
    out.add_argument("--plot", type=Path, metavar="PATH", help="save the four-panel figure")
    out.add_argument("--json", action="store_true", help="print one JSON object, nothing else")


def checked(build: Callable, *args, **kwargs):
    """Call an input-building function, turning its validation errors into `UsageError`."""
    try:
        return build(*args, **kwargs)
    except (ValueError, TypeError) as error:
        raise UsageError(_name_the_option(str(error))) from None


def _check_smoothing(args: argparse.Namespace) -> None:
    for name in ("contact_smoothing", "yield_smoothing"):
        value = getattr(args, name)
        if not 0.0 <= value <= 1.0e3:  # also rejects nan
            raise ValueError(f"{name} = {value:g} is out of range; allowed [0, 1000]")


def _run(args: argparse.Namespace) -> int:
    params, scales = checked(collision_from_args, args)
    mesh, settings = checked(mesh_from_args, args), checked(settings_from_args, args)
    # What `ring_on_beam` would reject, checked here so that `run` only fails in the solve.
    checked(m.validate, params, mesh)
    checked(_check_smoothing, args)
    cache = None if args.no_cache else enable_compilation_cache()
    where = f" (compiled code is cached in {cache})" if cache else ""
    _note(f"running; the first run of a mesh compiles for a while{where}...")
    try:
        collision = m.run(
            params,
            mesh,
            settings,
            contact_smoothing=args.contact_smoothing,
            yield_smoothing=args.yield_smoothing,
        )
    except m.SimulationError as error:
        _note(f"simulation failed: {error}")
        return EXIT_SOLVE
    if args.plot is not None:
        from ._plot import plot_collision

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


def _add_tune(parser: argparse.ArgumentParser) -> None:
    from optimise._cli import add_tune_arguments  # lazy: msfd_jax never imports optimise

    add_tune_arguments(parser)


def _tune(args: argparse.Namespace) -> int:
    from optimise._cli import tune_command

    return tune_command(args)


COMMANDS: dict[str, tuple[str, Callable, Callable]] = {
    "run": ("simulate one collision (default: the paper's Fig. 13 showcase)", _add_run, _run),
    "bench": ("recorded studies: msfd bench stability", _bench.add_bench_arguments, _bench.bench),
    "sweep": (
        "run a grid or list of collisions, batched (vmap)",
        _sweep.add_arguments,
        _sweep.handle,
    ),
    "reproduce": (
        "regenerate the paper's Sect. 4 figures and numbers",
        _reproduce.add_arguments,
        _reproduce.handle,
    ),
    "tune": ("tune the beam thickness to a target energy split", _add_tune, _tune),
}


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="msfd", description="Ring-on-beam collisions with the MS-FD model (Ruan & Yu 2003)."
    )
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name, (text, add_arguments, handler) in COMMANDS.items():
        sub = commands.add_parser(name, help=text, description=text)
        add_arguments(sub)
        sub.set_defaults(handler=handler)
    return parser


def _note(text: str) -> None:
    print(f"msfd: {text}", file=sys.stderr, flush=True)


def _name_the_option(message: str) -> str:
    """Append the CLI spelling of a parameter named in a validation message."""
    for field, flag in _OPTION_NAMES.items():
        if message.startswith(field):
            return f"{message} (option {flag})"
    return message


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``msfd``; returns the exit code (0 ok, 2 bad input, 3 failed solve)."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exit_:  # argparse has printed its message
        return EXIT_OK if exit_.code is None else int(exit_.code)
    try:
        return args.handler(args)
    except UsageError as error:
        print(f"msfd: error: {error}", file=sys.stderr)
        return EXIT_USAGE


if __name__ == "__main__":
    sys.exit(main())
