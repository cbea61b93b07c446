"""``msfd sweep`` in SI and with provenance: SI grids, SI columns, mesh/settings/versions.

SI grids take the ``msfd run`` SI options (``--beam-thickness 0.1,0.15``, ``--impact-speed
20:30:3``; missing values are `PAPER_SI`'s); their Cartesian product (last option fastest) is
converted row by row with `from_si` and swept as a list. The table then gains the SI inputs
(``si_<name>``), the unit scales (``scale_*``) and the design quantities of the whole structure
(`msfd_jax._model.si.si_columns`: energies in J, the engine's peaks in SI, ``duration_s``); the
10 ms deceleration and the final positions of ``msfd run``'s ``si`` object need a run's
histories and final state. NetCDF variables carry their SI ``units`` attribute.

Provenance: numeric columns ``mesh_*`` and ``settings_*`` (so ``--from-csv`` can read the table
back), and the versions in the NetCDF attributes, the ``--json`` rows and, beside a ``--csv``,
a ``PATH.provenance.json``.
"""

from __future__ import annotations

import argparse
import itertools
from pathlib import Path
from typing import Any

import numpy as np

import msfd_jax as m

from .._collision.provenance import mesh_json, now, settings_json, versions
from .._model.si import si_columns, units_of
from . import common

_CONSTRAINT = {"held": [True], "free": [False], "both": [False, True]}


def add_si_arguments(parser: argparse.ArgumentParser) -> None:
    si = parser.add_argument_group(
        "SI grid (instead of the groups above; lists x,y,... or ranges a:b:n; missing values "
        "are the paper's base case)"
    )
    si.add_argument("--si", action="store_true", help="give the grid in SI units (default: off)")
    for field, (flag, text) in common.SI.items():
        default = m.PAPER_SI.get(field)
        shown = "the ring width" if default is None else f"{default:g}"
        si.add_argument(
            flag,
            type=common.values,
            dest=f"si_{field}",
            metavar="VALUES",
            help=f"{text} (default {shown})",
        )


def si_rows(args: argparse.Namespace, spec) -> tuple[Any, list[dict[str, Any]] | None]:
    """The sweep list from SI grids (and each row's SI inputs and scales), or `spec` as is."""
    given = {k: getattr(args, f"si_{k}") for k in common.SI if getattr(args, f"si_{k}") is not None}
    if not (args.si or given):
        return spec, None
    si_flags = ", ".join(common.SI[k][0] for k in given) or "--si"
    if not isinstance(spec, dict):
        raise ValueError(f"{si_flags} (SI grid) cannot be combined with --from-csv")
    if set(spec) != {"axial_constraint"}:
        flags = ", ".join(common.PARAMS[k][0] for k in spec if k != "axial_constraint")
        raise ValueError(
            f"{flags} cannot be combined with an SI grid ({si_flags}); give SI values only"
        )
    axes = {k: given.get(k, [v]) for k, v in m.PAPER_SI.items()}
    if "beam_width" in given:
        axes["beam_width"] = given["beam_width"]
    axes["axial_constraint"] = _CONSTRAINT[args.axial_constraint]
    common.check_grid_size({common.SI[k][0]: v for k, v in given.items()})
    rows, info = [], []
    for point in itertools.product(*axes.values()):
        inputs = dict(zip(axes, point, strict=True))
        params, scales = m.from_si(**inputs)
        rows.append({k: float(np.asarray(v)) for k, v in params.scalars().items()})
        info.append({"inputs": inputs, "scales": scales})
    return rows, info


def si_grid(args: argparse.Namespace) -> dict[str, np.ndarray] | None:
    """The SI axes with more than one value (a NetCDF grid over them)."""
    axes = {
        f"si_{k}": np.asarray(getattr(args, f"si_{k}"), float)
        for k in common.SI
        if getattr(args, f"si_{k}") is not None
    }
    return axes or None


def add_columns(table, info, mesh: m.Mesh, settings: m.Settings, args) -> None:
    """SI columns (when `info` is given) and numeric provenance columns, in place."""
    n = len(table)
    if info is not None:
        table.columns.update(si_columns(table.columns, info))
        grid = si_grid(args)
        if grid is not None and args.axial_constraint != "both":
            table.grid = grid
    for key, value in mesh_json(mesh).items():
        table.columns[f"mesh_{key}"] = np.full(n, float(value))
    for key in ("safety", "dt", "t_max", "history_points"):
        value = getattr(settings, key)
        table.columns[f"settings_{key}"] = np.full(n, np.nan if value is None else float(value))
    for key in ("contact_smoothing", "yield_smoothing"):
        table.columns[f"settings_{key}"] = np.full(n, float(getattr(args, key)))


def provenance(mesh: m.Mesh, settings: m.Settings, args) -> dict[str, Any]:
    return {
        "mesh": mesh_json(mesh),
        "settings": {
            **settings_json(settings),
            "contact_smoothing": args.contact_smoothing,
            "yield_smoothing": args.yield_smoothing,
        },
        "versions": versions(),
        "when": now(),
    }


def write_provenance(path: Path, record: dict[str, Any]) -> Path:
    side = path.with_name(path.name + ".provenance.json")
    side.write_text(common.dumps(record, indent=1))
    return side


def write_netcdf(table, path: Path, record: dict[str, Any]) -> None:
    """The grid as NetCDF with the provenance as attributes; UsageError if it cannot be."""
    try:
        data = table.to_xarray()
    except ImportError:
        raise common.UsageError("--netcdf needs xarray (pip install 'msfd-jax[sweep]')") from None
    except ValueError as error:
        raise common.UsageError(f"--netcdf {path}: {error}") from None
    data.attrs.update({k: common.dumps(v) for k, v in record.items()})
    for name in data.variables:
        if units_of(str(name)) is not None:
            data[name].attrs["units"] = units_of(str(name))
    try:
        data.to_netcdf(path)
    except (OSError, ValueError, ImportError) as error:
        raise common.UsageError(f"--netcdf {path} could not be written: {error}") from None


def check_netcdf(args: argparse.Namespace) -> None:
    """Refuse --netcdf before the sweep runs when it could not be written afterwards."""
    if args.netcdf is None:
        return
    try:
        import xarray  # noqa: F401
    except ImportError:
        raise common.UsageError("--netcdf needs xarray (pip install 'msfd-jax[sweep]')") from None
    if args.from_csv is not None:
        raise common.UsageError("--netcdf needs a grid; a --from-csv list has none (use --csv)")
    if not Path(args.netcdf).resolve().parent.is_dir():
        raise common.UsageError(f"--netcdf {args.netcdf}: no such directory")
