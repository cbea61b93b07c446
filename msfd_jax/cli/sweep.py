"""``msfd sweep``: a grid (or a CSV list) of collisions, batched; a summary table and a CSV.

Each non-dimensional group takes a list ``5,10``, a range ``0.5:5:10`` (10 values from 0.5 to
5, ends included) or one value; the grid is their Cartesian product. ``--axial-constraint``
takes ``held``, ``free`` or ``both``. ``--from-csv`` reads a list of collisions instead (a
header of input names, one collision per row). Exit codes as ``msfd run``: 0, 2 bad input,
3 if any collision of the sweep failed (the CSV is still written, with its status and message).

Rows go to ``--csv PATH`` (or ``--parquet DIR.parquet``) as they finish, so a killed sweep
keeps them; ``--resume`` computes only the collisions missing there. ``--cluster local:N``
runs the collisions as Dask tasks in N worker processes, ``--cluster tcp://HOST:PORT`` on a
running scheduler (docs/scaling.md). Progress on stderr unless ``-q/--quiet``.
"""

from __future__ import annotations

import argparse
import csv
import importlib.util
import math
from pathlib import Path

import numpy as np

from .._collision.run import FRACTION_KEYS
from .._model.params import CollisionParams
from .._sweeps import cluster as _cluster
from .._sweeps.queue import GPU_DEFAULT_SLOTS
from .._sweeps.sweep import DEFAULT_CHUNK, INPUTS, SweepTable, sweep
from . import common, sweep_si

_CONSTRAINT = {"held": [1.0], "free": [0.0], "both": [0.0, 1.0]}
_SUMMARY = (*FRACTION_KEYS[:5], "t_end", "status")
_NETCDF_MODULES = ("xarray", "netCDF4", "h5netcdf", "h5py")


values = common.values  # one list syntax for every subcommand


def add_arguments(parser: argparse.ArgumentParser) -> None:
    common.add_case_argument(parser)
    group = parser.add_argument_group(
        "grid (lists x,y,... or ranges a:b:n; unset groups keep the paper's Fig. 13 value)"
    )
    defaults = CollisionParams()
    for field, (flag, text) in common.PARAMS.items():
        default = float(getattr(defaults, field))
        group.add_argument(
            flag, type=values, dest=field, metavar="VALUES", help=f"{text} (default {default:g})"
        )
    group.add_argument(
        "--axial-constraint",
        choices=sorted(_CONSTRAINT),
        default="held",
        help="beam ends held axially, free to slide, or both (default: held)",
    )
    group.add_argument(
        "--from-csv",
        type=Path,
        metavar="PATH",
        help="a list of collisions instead of a grid: CSV with a header of input names "
        "(default: none)",
    )
    sweep_si.add_si_arguments(parser)
    common.add_numerics_arguments(parser)
    # a sweep keeps final values only: two history samples and no shapes unless asked
    parser.set_defaults(history_points=2, shape_times=())
    batch = parser.add_argument_group("batching")
    batch.add_argument(
        "--chunk-size", type=int, default=None,
        help=f"slots per worker (default: {DEFAULT_CHUNK} on a CPU, {GPU_DEFAULT_SLOTS} on a GPU)",
    )  # fmt: skip
    batch.add_argument(
        "--workers",
        type=int,
        metavar="N",
        help="threads, each with its own --chunk-size slots fed from one queue "
        "(default: one per core this process may use; refused with --cluster, whose workers "
        "are single-threaded processes)",
    )
    batch.add_argument("--shard", action="store_true", help="split chunks across JAX devices")
    batch.add_argument(
        "--host-devices",
        type=int,
        metavar="N",
        help="with --shard on CPU: run as N host devices, one per core (sets XLA_FLAGS)",
    )
    batch.add_argument(
        "--cluster",
        metavar="SPEC",
        help="run on Dask: local:N (N worker processes here) or tcp://HOST:PORT (a scheduler; "
        "needs msfd-jax[cluster])",
    )
    batch.add_argument(
        "--task-size",
        type=int,
        metavar="N",
        help="with --cluster: collisions per Dask task (default: --chunk-size)",
    )
    common.add_quiet_argument(parser, "--no-progress")
    out = parser.add_argument_group("output (rows written as they finish; --resume continues)")
    out.add_argument("--csv", type=Path, metavar="PATH", help="write the table as CSV")
    out.add_argument(
        "--parquet", type=Path, metavar="DIR", help="write the table as Parquet (DIR.parquet)"
    )
    out.add_argument(
        "--resume",
        action="store_true",
        help="keep the rows already in --csv/--parquet (matched by inputs), compute the rest",
    )
    out.add_argument(
        "--netcdf",
        type=Path,
        metavar="PATH",
        help="grid as NetCDF (needs xarray, h5netcdf and h5py: pip install 'msfd-jax[sweep]')",
    )
    out.add_argument("--json", action="store_true", help="print the rows as JSON, nothing else")
    out.add_argument(
        "--plot",
        type=Path,
        metavar="PNG",
        help="draw the final partition against the swept input (bars per row for a sweep over "
        "several inputs or a list)",
    )


def grid_from_args(args: argparse.Namespace):
    """The sweep specification: a dict of value lists (grid) or a list of dicts (CSV)."""

    given = {k: getattr(args, k) for k in common.PARAMS if getattr(args, k) is not None}
    if args.from_csv is None:
        common.check_grid_size({common.PARAMS[k][0]: v for k, v in given.items()})
        return {**given, "axial_constraint": _CONSTRAINT[args.axial_constraint]}
    if given:
        raise ValueError("--from-csv gives the collisions; do not combine it with grid values")
    return read_collisions(args.from_csv)


def read_collisions(path: Path) -> list[dict[str, float]]:
    """The collisions of a ``--from-csv`` table: its input columns (others, such as a sweep's
    own outputs, are ignored), one collision per row; UsageError naming --from-csv if bad."""
    where = f"--from-csv {path}"
    expected = f"a header naming some of {', '.join(INPUTS)}, then one row per collision"
    try:
        with Path(path).open(newline="") as stream:
            reader = csv.reader(stream)
            lines = [(reader.line_num, row) for row in reader if row]
    except (OSError, UnicodeDecodeError, csv.Error) as error:
        raise common.UsageError(f"{where}: cannot read a CSV table ({error})") from None
    if not lines:
        raise common.UsageError(f"{where}: the table is empty; expected {expected}")
    header = [name.strip() for name in lines[0][1]]
    used = [name for name in header if name in INPUTS]
    if not used:
        raise common.UsageError(f"{where}: no input column in {header}; expected {expected}")
    if len(set(header)) != len(header):
        raise common.UsageError(f"{where}: a column is named twice in {header}")
    if len(lines) == 1:
        raise common.UsageError(f"{where}: a header but no collisions; expected {expected}")
    rows = []
    for number, row in lines[1:]:
        if len(row) != len(header):
            raise common.UsageError(
                f"{where}: line {number} has {len(row)} fields, the header {len(header)}"
            )
        collision = {}
        for name, text in zip(header, row, strict=True):
            if name in INPUTS:
                try:
                    collision[name] = float(text)
                except ValueError:
                    raise common.UsageError(
                        f"{where}: line {number}, {name} = {text!r} is not a number"
                    ) from None
        rows.append(collision)
    return rows


def _use_host_devices(n: int, shard: bool) -> None:
    """Ask XLA for `n` CPU devices; only possible before JAX has started its backends."""
    import os

    from jax._src import xla_bridge

    if not shard:
        raise common.UsageError("--host-devices needs --shard (it only splits sharded chunks)")
    if n < 1 or n > (os.cpu_count() or 1):
        raise common.UsageError(f"--host-devices must be in 1..{os.cpu_count()} (cores), got {n}")
    if xla_bridge.backends_are_initialized():
        raise common.UsageError("--host-devices must be set before JAX starts (use XLA_FLAGS)")
    flag = f"--xla_force_host_platform_device_count={n}"
    os.environ["XLA_FLAGS"] = f"{os.environ.get('XLA_FLAGS', '')} {flag}".strip()


def check_netcdf_dependencies(args: argparse.Namespace) -> None:
    """Refuse ``--netcdf`` before the sweep runs when the modules that write it are missing
    (found afterwards, the sweep's table would be lost): xarray, and netCDF4 or h5netcdf with
    h5py (xarray's engines for NetCDF-4; h5netcdf does not require h5py itself)."""
    if args.netcdf is None:
        return
    present = {name: importlib.util.find_spec(name) is not None for name in _NETCDF_MODULES}
    missing = [] if present["xarray"] else ["xarray"]
    if not present["netCDF4"]:
        missing += [name for name in ("h5netcdf", "h5py") if not present[name]]
    if missing:
        raise common.UsageError(
            f"--netcdf needs {', '.join(missing)}, not installed here; nothing was run. "
            "Install them with: pip install 'msfd-jax[sweep]'"
        )


def handle(args: argparse.Namespace) -> int:
    check_netcdf_dependencies(args)
    common.check_plot(args.plot)
    if args.host_devices is not None:
        _use_host_devices(args.host_devices, args.shard)
    spec = common.checked(grid_from_args, args)
    si = args.si or any(getattr(args, f"si_{k}") is not None for k in common.SI)
    spec, si_info = common.checked(sweep_si.si_rows, args, spec, si=si)
    sweep_si.check_netcdf(args)
    mesh = common.checked(common.mesh_from_args, args)
    settings = common.checked(common.settings_from_args, args)
    output = _output(args)
    if args.no_cache:
        cache = None
    elif args.cluster is None:
        cache = common.enable_compilation_cache()
    else:  # the workers compile; this process only sends them tasks
        cache = common.compilation_cache_dir()
    client = _client(args)
    try:
        table = sweep(
            spec,
            mesh,
            settings,
            chunk_size=args.chunk_size,
            progress=not args.quiet,
            contact_smoothing=args.contact_smoothing,
            yield_smoothing=args.yield_smoothing,
            shard=args.shard,
            output=output,
            resume=args.resume,
            client=client,
            task_size=args.task_size,
            compile_cache=cache,
            workers=args.workers,
        )
    except (ValueError, TypeError) as error:  # raised before anything is compiled
        raise common.UsageError(common.name_the_option(str(error), si=si)) from None
    finally:
        if client is not None:
            _cluster.close(client)
    sweep_si.add_columns(table, si_info, mesh, settings, args)
    record = sweep_si.provenance(mesh, settings, args)
    if args.csv is not None:  # the finished table, now with its SI and provenance columns
        table.to_csv(args.csv)
        sweep_si.write_provenance(args.csv, record)
    if args.netcdf is not None:
        sweep_si.write_netcdf(table, args.netcdf, record)
    if args.plot is not None:
        from .._plot import plot_sweep

        plot_sweep(table, args.plot)
    if args.json:
        print(common.dumps([{**row, "versions": record["versions"]} for row in table.rows()]))
    else:
        print(summary(table))
        if output is not None:
            print(f"table written to {output}")
        if args.plot is not None:
            print(f"plot saved to {args.plot}")
    return common.EXIT_SOLVE if table.failed.any() else common.EXIT_OK


def _output(args: argparse.Namespace) -> Path | None:
    """The one file the rows go to as they finish (--csv or --parquet), checked."""
    if args.csv is not None and args.parquet is not None:
        raise common.UsageError("give one of --csv and --parquet (the rows go to one store)")
    path, flag = (args.csv, "--csv") if args.csv is not None else (args.parquet, "--parquet")
    if path is None:
        if args.resume:
            raise common.UsageError("--resume needs --csv PATH or --parquet DIR to continue")
        return None
    suffix = ".csv" if flag == "--csv" else ".parquet"
    if path.suffix != suffix:
        raise common.UsageError(f"{flag} {path}: the name must end in {suffix}")
    if path.exists() and not args.resume:
        raise common.UsageError(f"{flag} {path} exists: add --resume to continue it, or remove it")
    if path.exists() and path.is_dir() != (flag == "--parquet"):
        kind = "directory" if flag == "--parquet" else "file"
        raise common.UsageError(f"{flag} {path}: expected a {kind}")
    return path


def _client(args: argparse.Namespace):
    """A Dask client for --cluster (None without it); bad syntax or no scheduler: exit 2."""
    if args.task_size is not None and args.cluster is None:
        raise common.UsageError("--task-size needs --cluster (it sizes the Dask tasks)")
    if args.task_size is not None and args.task_size < 1:
        raise common.UsageError(f"--task-size must be an integer >= 1, got {args.task_size}")
    if args.cluster is None:
        return None
    if args.shard:
        raise common.UsageError(
            "--shard splits chunks over this process's devices; with --cluster each worker is "
            "one single-threaded process: ask for more workers instead"
        )
    if args.workers is not None:
        raise common.UsageError(
            f"--workers {args.workers} sets this process's threads; with --cluster each Dask "
            "worker is one single-threaded process, so the threads would be ignored: size the "
            "cluster instead (local:N for N processes)"
        )
    try:
        _cluster.parse(args.cluster)
        return _cluster.connect(args.cluster)
    except ValueError as error:
        raise common.UsageError(f"--cluster: {error}") from None
    except ImportError as error:
        raise common.UsageError(f"--cluster: {error}") from None
    except OSError as error:  # TimeoutError included: no scheduler at that address
        raise common.UsageError(
            f"--cluster {args.cluster}: no scheduler reached ({error})"
        ) from None


def summary(table: SweepTable, max_rows: int = 40) -> str:
    """Inputs that vary (the SI ones first, for an SI grid) and the main fractions of K0, one
    line per collision."""
    si = [f"si_{k}" for k in common.SI if f"si_{k}" in table.keys()]
    varying = [k for k in (*si, *INPUTS) if np.unique(table[k]).size > 1]
    names = [*varying, *_SUMMARY]
    head = "  ".join(f"{_short(k):>12}" for k in names)
    lines = [head, "-" * len(head)]
    n = len(table)
    shown = range(n) if n <= max_rows else [*range(max_rows // 2), *range(n - max_rows // 2, n)]
    for i in shown:
        if n > max_rows and i == n - max_rows // 2:
            lines.append(f"  ... {n - max_rows} more rows (see --csv)")
        lines.append("  ".join(_cell(table[k][i]) for k in names))
    failed = int(table.failed.sum())
    rate = n / table.wall_time_s if table.wall_time_s > 0 else math.inf
    lines += [
        "",
        f"{n} collisions in {table.wall_time_s:.1f} s ({rate:.3g} per second, including "
        f"compilation); {failed} failed" + (" (see the message column)" if failed else ""),
    ]
    if table.computed is not None and not table.computed.all():
        kept = int((~table.computed).sum())
        lines.append(f"{kept} of them read back from the output (--resume), {n - kept} computed")
    return "\n".join(lines)


def _short(name: str) -> str:
    field = name.removeprefix("si_")
    if name.startswith("si_") and field in common.SI:  # "L_b, half the beam span [m]" -> "L_b [m]"
        text = common.SI[field][1]
        symbol, unit = text.split(" ")[0].rstrip(","), text[text.rfind("[") :]
        return f"{symbol} {unit}"[:12]
    return name.replace("_ratio", "").replace("axial_constraint", "constrained")[:12]


def _cell(value) -> str:
    if isinstance(value, str | np.str_):
        return f"{value:>12}"
    return f"{float(value):12.4g}"
