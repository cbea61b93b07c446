"""What every ``msfd`` subcommand shares: argument groups, exit codes, `UsageError`, the cache.

A leaf of the CLI: it imports the solver (`msfd_jax`) and no subcommand, so each subcommand
module (``run``, ``sweep``, ``bench``, ``reproduce``, and ``tune`` from `optimise`) reads a
collision the same way and none of them imports another. Public, because `optimise` uses it.

Exit codes: 0 success, 2 bad input (argparse or parameter validation), 3 failed solve.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np

import msfd_jax as m
from msfd_jax._collision.provenance import dumps  # noqa: F401 (strict JSON for every --json output)
from msfd_jax._model.cap import T_MAX_FLOOR
from msfd_jax._runtime import export as _export
from msfd_jax._runtime.progress import LineProgress  # noqa: F401 (for optimise: msfd tune)

EXIT_OK, EXIT_USAGE, EXIT_SOLVE = 0, 2, 3


class UsageError(Exception):
    """Bad input found while reading the arguments (exit code 2, no traceback)."""


# CLI option -> CollisionParams field; defaults are the paper's showcase (CollisionParams()).
PARAMS = {
    "thickness_ratio": ("--thickness-ratio", "h_b/h_r, beam to ring thickness"),
    "modulus_ratio": ("--modulus-ratio", "E/Y, Young's modulus over yield stress"),
    "slenderness": ("--slenderness", "R/h_r, ring radius over ring thickness"),
    "mass_ratio": ("--mass-ratio", "g = G/(mu_r R), half block mass over ring mass per radius"),
    "velocity": ("--velocity", "v0 = V0 sqrt(mu_r R / M_pr), impact velocity"),
    "span_ratio": ("--span-ratio", "L_b/R, beam half span over ring radius"),
    "width_ratio": ("--width-ratio", "b_b/b_r, beam to ring width"),
}
# CLI option -> from_si keyword; missing values come from m.PAPER_SI.
SI = {
    "youngs_modulus": ("--youngs-modulus", "E [Pa]"),
    "yield_stress": ("--yield-stress", "Y [Pa]"),
    "density": ("--density", "rho [kg/m^3]"),
    "radius": ("--radius", "R [m]"),
    "width": ("--width", "b, ring width [m]"),
    "ring_thickness": ("--ring-thickness", "h_r [m]"),
    "beam_thickness": ("--beam-thickness", "h_b [m]"),
    "beam_half_span": ("--beam-half-span", "L_b, half the beam span [m]"),
    "impact_speed": ("--impact-speed", "V0 [m/s]"),
    "block_mass": ("--block-mass", "2G, the whole rigid block [kg]"),
    "beam_width": ("--beam-width", "b_b [m]"),  # its default (the ring width) is added where used
}
# A graded beam (`CollisionParams.thickness_profile`): h_k/h_r per beam segment, O to E.
PROFILE = "thickness_profile"
PROFILE_FLAG = "--thickness-profile"
OPTION_NAMES = {
    **{k: v[0] for k, v in PARAMS.items()},
    PROFILE: PROFILE_FLAG,
    **{k: v[0] for k, v in SI.items()},
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
    "chunk_size": "--chunk-size",
    "task_size": "--task-size",
    "workers": "--workers",
}


# Largest grid a sweep expands (and values a:b:n gives): beyond, the expansion alone exhausts
# memory before anything runs (10^6 collisions are days of one core).
MAX_GRID = 1_000_000


def check_grid_size(axes: dict[str, list]) -> None:
    """Refuse a grid (flag -> values) of more than `MAX_GRID` collisions, naming its axes."""
    size = math.prod(len(v) for v in axes.values())
    if size > MAX_GRID:
        shape = " x ".join(f"{len(v)} ({flag})" for flag, v in axes.items() if len(v) > 1)
        raise ValueError(f"the grid {shape} has {size} collisions; allowed <= {MAX_GRID}")


def values(text: str) -> list[float]:
    """One list syntax for every subcommand: ``a:b:n`` (n values from a to b inclusive),
    ``x,y,...`` or ``x``."""
    try:
        if ":" in text:
            low, high, count = text.split(":")
            n = int(count)
            if n < 1 or n > MAX_GRID:
                raise ValueError
            return [float(v) for v in np.linspace(float(low), float(high), n)]
        out = [float(v) for v in text.split(",") if v.strip()]
        if not out:
            raise ValueError
        return out
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected a:b:n (1 <= n <= {MAX_GRID} values), x,y,... or x; got {text!r}"
        ) from None


def profile_values(text: str) -> list[float]:
    """A thickness profile: ``t0,t1,...`` (h_k/h_r of every beam segment, O to E). Only parsed
    here: the count and the range are the model's checks (`CollisionParams`, `validate`)."""
    try:
        out = [float(v) for v in text.split(",")]
    except ValueError:
        out = []
    if not out:
        raise argparse.ArgumentTypeError(
            f"expected t0,t1,... (h_k/h_r of every beam segment, O to E, comma-separated); "
            f"got {text!r}"
        )
    return out


def add_case_argument(parser: argparse.ArgumentParser) -> None:
    """The optional case file: ``msfd run CASE.toml`` (options given on the line override it)."""
    parser.add_argument(
        "case",
        nargs="?",
        type=Path,
        metavar="CASE.toml",
        help="a case file: one [section] per option group, keys named as the long options "
        "with _ for - (docs/si.md); options given on the command line override it "
        "(default: none)",
    )


def add_collision_arguments(
    parser: argparse.ArgumentParser, thickness_profile: bool = False
) -> None:
    """Non-dimensional groups (Eq. 1) or their SI alternative, as `from_si` takes them
    (`thickness_profile`: also ``--thickness-profile``, a graded beam; ``msfd run``)."""
    group = parser.add_argument_group("collision (non-dimensional, Eq. 1; paper's Fig. 13)")
    defaults = m.CollisionParams()
    for field, (flag, text) in PARAMS.items():
        default = float(getattr(defaults, field))
        group.add_argument(flag, type=float, dest=field, help=f"{text} (default {default:g})")
    if thickness_profile:
        group.add_argument(
            PROFILE_FLAG,
            type=profile_values,
            dest=PROFILE,
            metavar="T0,T1,...",
            help="a graded beam: h_k/h_r of every beam segment, O to E, comma-separated (one "
            "value per segment: --beam-contact-segments + --beam-outer-segments, 25 on the "
            "paper's mesh; each in (0, 100]). Ratios to the ring thickness h_r also with --si "
            "(h_k = value x --ring-thickness). --thickness-ratio (with --si: --beam-thickness) "
            "stays the uniform beam whose mass the graded one is compared with "
            "(beam_mass_ratio) (default: none, a uniform beam)",
        )
    group.add_argument(
        "--axial-constraint",
        action=argparse.BooleanOptionalAction,
        default=True,
        help="beam ends held axially (x_E = 0, Eq. 20) or free to slide (default: held)",
    )
    si = parser.add_argument_group(
        "SI inputs (instead of the groups above; missing values are the paper's base case)"
    )
    si.add_argument(
        "--si", action="store_true", help="give the collision in SI units (default: off)"
    )
    for field, (flag, text) in SI.items():
        default = m.PAPER_SI.get(field)
        shown = "the ring width" if default is None else f"{default:g}"
        si.add_argument(
            flag, type=float, dest=f"si_{field}", metavar="X", help=f"{text} (default {shown})"
        )


def add_numerics_arguments(parser: argparse.ArgumentParser) -> None:
    """Mesh counts (static: a new mesh compiles anew) and integration settings."""
    mesh, settings = m.Mesh(), m.Settings()
    group = parser.add_argument_group("mesh (paper: 15 ring, 20 + 5 beam segments)")
    for field in ("ring_segments", "beam_contact_segments", "beam_outer_segments"):
        default = getattr(mesh, field)
        text = field.replace("_", " ")
        group.add_argument(
            OPTION_NAMES[field], type=int, default=default, help=f"{text} (default %(default)s)"
        )
    group.add_argument(
        "--contact-region",
        type=float,
        default=mesh.contact_region,
        help="OC / R, length of the finely meshed contact region (default %(default)s)",
    )
    group.add_argument(
        "--collapse-contacts",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="the contacts of a collapsing structure (ring on the block, on itself and on the "
        "symmetry plane, ring bars' crush stops, beam on its mirror image): --collapse-contacts "
        "always, --no-collapse-contacts never (the paper's model alone); default: the paper's "
        "model, and a collision it leaves without an answer is solved again with them",
    )
    group = parser.add_argument_group("numerics")
    group.add_argument(
        "--safety", type=float, default=settings.safety, help="dt / dt_crit (default %(default)s)"
    )
    group.add_argument(
        "--dt", type=float, help="fixed time step (overrides --safety; default: from --safety)"
    )
    group.add_argument(
        "--t-max",
        type=float,
        default=settings.t_max,
        help="cap on tau (default: derived from the inputs, 3 x the time the collapse loads "
        "take to stop the block + 2, within [10, 100])",
    )
    group.add_argument(
        "--history-points",
        type=int,
        default=settings.history_points,
        help="samples of the histories over [0, t_max] (default %(default)s)",
    )
    group.add_argument(
        "--shape-times",
        type=_times,
        metavar="T1,T2,...",
        help="times at which shapes are saved (default: the paper's 0.15,0.49,0.75,1.5 up to "
        "--t-max)",
    )
    group.add_argument(
        "--contact-smoothing",
        type=float,
        default=0.0,
        help="ramp width / R (default %(default)s: sharp)",
    )
    group.add_argument(
        "--yield-smoothing",
        type=float,
        default=0.0,
        help="fraction of yield (default %(default)s: sharp)",
    )
    group.add_argument(
        "--no-cache", action="store_true", help="no persistent compile cache (default: cached)"
    )


def add_quiet_argument(parser: argparse.ArgumentParser, *aliases: str) -> None:
    """``-q/--quiet``: no progress on stderr (every subcommand that shows progress has it)."""
    parser.add_argument(
        "-q", "--quiet", *aliases, action="store_true", help="no progress on stderr"
    )


def collision_from_args(args: argparse.Namespace) -> tuple[m.CollisionParams, m.Scales | None]:
    """The parameters (and SI scales when SI inputs were given); raises ValueError if bad."""
    given_si = {k: getattr(args, f"si_{k}") for k in SI if getattr(args, f"si_{k}") is not None}
    given = {k: getattr(args, k) for k in PARAMS if getattr(args, k) is not None}
    profile = getattr(args, PROFILE, None)  # h_k/h_r, in SI too (a graded beam)
    if not (args.si or given_si):
        constraint = float(args.axial_constraint)
        return m.CollisionParams(**given, axial_constraint=constraint, **{PROFILE: profile}), None
    if given:
        flags = ", ".join(PARAMS[k][0] for k in given)
        raise ValueError(f"{flags} cannot be combined with SI inputs; give the SI value instead")
    si = {**m.PAPER_SI, **given_si}
    params, scales = m.from_si(**si, axial_constraint=args.axial_constraint)
    if profile is not None:
        params = dataclasses.replace(params, **{PROFILE: profile})
    return params, scales


def mesh_from_args(args: argparse.Namespace) -> m.Mesh:
    return m.Mesh(
        args.ring_segments,
        args.beam_contact_segments,
        args.beam_outer_segments,
        args.contact_region,
        collapse_contacts=getattr(args, "collapse_contacts", None),
    )


def _times(text: str) -> tuple[float, ...]:
    if not text.strip():
        return ()
    return tuple(sorted(values(text)))


def settings_from_args(args: argparse.Namespace) -> m.Settings:
    m.Settings(t_max=args.t_max, shape_times=())  # t_max first: shape times are judged by it
    shape_times = args.shape_times
    # a derived cap (t_max None) is at least its floor: times up to it are always reached
    reached = T_MAX_FLOOR if args.t_max is None else args.t_max
    if shape_times is None:  # the paper's times (Fig. 13b) that fall inside the run
        shape_times = tuple(t for t in m.Settings().shape_times if t <= reached)
    elif any(t > reached for t in shape_times):  # asked for explicitly: refuse, not drop
        cap = f"t_max = {args.t_max}" if args.t_max is not None else "the derived cap >= 10"
        raise ValueError(
            f"shape_times {shape_times} must lie in [0, {cap}]"
            + ("; give --t-max for later times" if args.t_max is None else "")
        )
    return m.Settings(
        safety=args.safety,
        dt=args.dt,
        t_max=args.t_max,
        history_points=args.history_points,
        shape_times=shape_times,
    )


def enable_compilation_cache() -> Path:
    """JAX's persistent compilation cache, so a second process skips compiling (CLI only),
    and the store of traced programs in it, so it skips tracing too.

    The directory is ``$MSFD_CACHE_DIR`` or ``~/.cache/msfd-jax/jax``; equinox's runtime
    checks become NaN unless ``EQX_ON_ERROR`` is set (`_export.use_with_compile_cache` says
    why): a failed check then gives NaN, which the solver's guard reports (exit code 3).
    """
    return _export.use_with_compile_cache(compilation_cache_dir())


def compilation_cache_dir() -> Path:
    """``$MSFD_CACHE_DIR`` or ``~/.cache/msfd-jax/jax`` (what `enable_compilation_cache` uses)."""
    default = Path.home() / ".cache" / "msfd-jax" / "jax"
    return Path(os.environ.get("MSFD_CACHE_DIR") or default).expanduser()


def checked(build: Callable, *args, si: bool = False, **kwargs):
    """Call an input-building function, turning its validation errors into `UsageError`
    (`si`: the collision was given in SI, so a group is named with the SI inputs it is from)."""
    try:
        return build(*args, **kwargs)
    except (ValueError, TypeError) as error:
        raise UsageError(name_the_option(str(error), si=si)) from None


def note(text: str) -> None:
    print(f"msfd: {text}", file=sys.stderr, flush=True)


# The SI inputs each non-dimensional group is computed from (`from_si`).
SI_SOURCES = {
    "thickness_ratio": ("beam_thickness", "ring_thickness"),
    "modulus_ratio": ("youngs_modulus", "yield_stress"),
    "slenderness": ("radius", "ring_thickness"),
    "mass_ratio": ("block_mass", "density", "width", "ring_thickness", "radius"),
    "velocity": ("impact_speed", "density", "yield_stress", "ring_thickness", "radius"),
    "span_ratio": ("beam_half_span", "radius"),
    "width_ratio": ("beam_width", "width"),
}


def name_the_option(message: str, si: bool = False) -> str:
    """Append the CLI spelling of a parameter named in a validation message (with `si`, the
    SI options a non-dimensional group is computed from)."""
    if si:
        for field, sources in SI_SOURCES.items():
            if message.startswith(field):
                flags = ", ".join(SI[k][0] for k in sources)
                return f"{message} (computed from the SI inputs {flags})"
    for field, flag in OPTION_NAMES.items():
        if message.startswith(field):
            # a limit set by another input ("... contact_region = 3") names its option too
            others = [f for k, f in OPTION_NAMES.items() if k != field and f" {k} = " in message]
            return f"{message} (option{'s' if others else ''} {', '.join([flag, *others])})"
    return message


def check_plot(path: Path | None) -> None:
    """Refuse a --plot file that could not be written, before the run rather than after."""
    if path is None:
        return
    from matplotlib.backend_bases import FigureCanvasBase

    formats = sorted(FigureCanvasBase.get_supported_filetypes())
    if path.suffix and path.suffix[1:].lower() not in formats:
        raise UsageError(f"--plot {path}: unknown format {path.suffix!r}; allowed: {formats}")
    if not path.resolve().parent.is_dir():
        raise UsageError(f"--plot {path}: no such directory {str(path.parent)!r}")
