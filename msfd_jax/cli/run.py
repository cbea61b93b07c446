"""``msfd run``: simulate one ring-on-beam collision (default: the paper's Fig. 13).

``msfd run CASE.toml`` reads the options from a case file (`msfd_jax.cli.case`); ``msfd run
--from-json OUT.json`` reruns the collision an earlier ``--json`` recorded (its params or SI
inputs, mesh and settings); options given on the command line override either. With
``--json`` a failure is printed as one JSON object too (``"ok": false``), exit code 2 or 3.
``--thickness-profile T0,T1,...`` (``thickness_profile = [...]`` in a case file's
``[collision]``) runs a graded beam; its record and table then also give ``beam_mass_ratio``.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
from pathlib import Path
from typing import Any

import numpy as np

import msfd_jax as m

from .._collision.provenance import dumps, now, settings_from_json, versions
from .._model.params import _check_scalar, _check_value
from .._model.si import table_lines
from .._runtime import export as _export
from .common import (
    EXIT_OK,
    EXIT_SOLVE,
    PARAMS,
    PROFILE,
    SI,
    UsageError,
    add_case_argument,
    add_collision_arguments,
    add_numerics_arguments,
    check_plot,
    checked,
    collision_from_args,
    enable_compilation_cache,
    mesh_from_args,
    note,
    settings_from_args,
)

# Settings fields the command line sets (the rest come from --from-json's record, or defaults)
_CLI_SETTINGS = ("safety", "dt", "t_max", "history_points", "shape_times")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_case_argument(parser)
    add_collision_arguments(parser, thickness_profile=True)
    add_numerics_arguments(parser)
    source = parser.add_argument_group("input")
    source.add_argument(
        "--from-json",
        type=Path,
        metavar="OUT.json",
        help="rerun the collision recorded by an earlier `msfd run --json` (default: none)",
    )
    out = parser.add_argument_group("output")
    out.add_argument(
        "--plot", type=Path, metavar="PATH", help="save the four-panel figure (default: none)"
    )
    out.add_argument(
        "--json", action="store_true", help="print one JSON object, nothing else (default: off)"
    )


def read_record(path: Path) -> dict[str, Any]:
    """The JSON object of ``msfd run --json`` at `path` (UsageError if it is not one)."""
    try:
        record = json.loads(Path(path).read_text())
    except (OSError, ValueError) as error:
        raise UsageError(f"--from-json {path}: cannot read a JSON object ({error})") from None
    if not isinstance(record, dict) or "params" not in record:
        raise UsageError(f"--from-json {path}: not a record of `msfd run --json` (no params)")
    # the parts read back: JSON objects with only the keys `msfd run --json` writes
    known = {
        "params": {f.name for f in dataclasses.fields(m.CollisionParams)},
        "si_inputs": {*SI, "axial_constraint"},
        "mesh": {f.name for f in dataclasses.fields(m.Mesh)},
        "settings": {
            *(f.name for f in dataclasses.fields(m.Settings)),
            "contact_smoothing",
            "yield_smoothing",
        },
    }
    for part, keys in known.items():
        value = record.get(part)
        if value is None and part != "params":
            continue
        if not isinstance(value, dict):
            raise UsageError(
                f"--from-json {path}: {part} must be a JSON object, got {dumps(value)}"
            )
        unknown = sorted(set(value) - keys)
        if unknown:
            raise UsageError(
                f"--from-json {path}: unknown {part} {unknown}; allowed: {', '.join(sorted(keys))}"
            )
    shape_times = (record.get("settings") or {}).get("shape_times", [])
    if not isinstance(shape_times, list):
        raise UsageError(f"--from-json {path}: settings.shape_times must be a list of times")
    return record


def _recorded_flag(path: Path, name: str, value: Any) -> bool:
    if isinstance(value, bool) or value in (0, 1):  # JSON true/false, or 0.0/1.0
        return bool(value)
    raise UsageError(f"--from-json {path}: {name} must be true, false, 0 or 1, got {value!r}")


def json_defaults(path: Path) -> dict[str, Any]:
    """Argument defaults (dest -> value) that rerun the collision recorded at `path`."""
    record = read_record(path)
    out: dict[str, Any] = {}
    if record.get("si_inputs"):
        si = dict(record["si_inputs"])
        constraint = si.pop("axial_constraint", True)
        out["axial_constraint"] = _recorded_flag(path, "axial_constraint", constraint)
        out["si"] = True
        out.update({f"si_{k}": v for k, v in si.items() if k in SI})
    else:
        params = record["params"]
        out.update({k: params[k] for k in PARAMS if k in params})
        constraint = params.get("axial_constraint", 1.0)
        out["axial_constraint"] = _recorded_flag(path, "axial_constraint", constraint)
    profile = record["params"].get(PROFILE)
    if profile is not None:  # a graded beam (h_k/h_r, in SI too); the model checks the values
        if not isinstance(profile, list):  # (argparse would parse a string default as text)
            raise UsageError(
                f"--from-json {path}: params.{PROFILE} must be a list of h_k/h_r (one value "
                f"per beam segment, O to E), got {dumps(profile)[:80]}"
            )
        out[PROFILE] = profile
    out.update(record.get("mesh") or {})
    settings = record.get("settings") or {}
    out.update(
        {
            k: settings[k]
            for k in (*_CLI_SETTINGS, "contact_smoothing", "yield_smoothing")
            if k in settings
        }
    )
    if "shape_times" in out:
        out["shape_times"] = tuple(out["shape_times"])
    return out


def _settings(args: argparse.Namespace) -> m.Settings:
    """The command line's settings; with --from-json the record's other fields are kept."""
    settings = settings_from_args(args)
    if args.from_json is None:
        return settings
    recorded = read_record(args.from_json).get("settings")
    if not recorded:
        return settings
    recorded = {
        k: v for k, v in recorded.items() if k not in ("contact_smoothing", "yield_smoothing")
    }
    base = settings_from_json(recorded)
    return dataclasses.replace(base, **{k: getattr(settings, k) for k in _CLI_SETTINGS})


def _check_smoothing(args: argparse.Namespace) -> None:
    for name in ("contact_smoothing", "yield_smoothing"):
        _check_value(name, getattr(args, name), 0.0, 1.0e3, True, True)
        _check_scalar(name, getattr(args, name))


def _check_single(params: m.CollisionParams) -> None:
    """One collision: every group a single value, a thickness profile one list (a --from-json
    record could hold lists, or a list of lists)."""
    for name, value in params.scalars().items():
        _check_scalar(name, value)
    if params.graded and np.ndim(params.thickness_profile) != 1:
        raise ValueError(
            f"{PROFILE} must be one list of h_k/h_r (one value per beam segment, O to E), "
            f"got {np.ndim(params.thickness_profile)} dimensions"
        )


def mass_ratio(params: m.CollisionParams, mesh: m.Mesh) -> float | None:
    """A graded beam's mass over the uniform beam's of `thickness_ratio` (None: uniform)."""
    return float(m.beam_mass_ratio(params, mesh)) if params.graded else None


def with_mass_ratio(record: dict[str, Any], ratio: float | None) -> dict[str, Any]:
    """`record` with ``beam_mass_ratio`` after its ``params`` (a graded beam only: a uniform
    beam's record stays as it was)."""
    if ratio is None:
        return record
    out: dict[str, Any] = {}
    for key, value in record.items():
        out[key] = value
        if key == "params":
            out["beam_mass_ratio"] = ratio
    out.setdefault("beam_mass_ratio", ratio)
    return out


def _si_inputs(args: argparse.Namespace) -> dict[str, float] | None:
    given = {k: getattr(args, f"si_{k}") for k in SI if getattr(args, f"si_{k}") is not None}
    if not (args.si or given):
        return None
    return {**m.PAPER_SI, **given, "axial_constraint": bool(args.axial_constraint)}


def failure_record(status: str, message: str, inputs: dict[str, Any]) -> dict[str, Any]:
    """The one JSON object a failed ``--json`` run prints (status, message, when, inputs)."""
    return {
        "ok": False,
        "status": status,
        "message": message,
        "when": now(),
        **inputs,
        "versions": versions(),
    }


def handle(args: argparse.Namespace) -> int:
    si = _si_inputs(args) is not None
    params, scales = checked(collision_from_args, args, si=si)
    mesh, settings = checked(mesh_from_args, args), checked(_settings, args)
    # What `ring_on_beam` would reject, checked here so that `run` only fails in the solve.
    checked(m.validate, params, mesh, si=si)
    checked(_check_single, params)
    ratio = checked(mass_ratio, params, mesh)
    check_plot(args.plot)
    checked(_check_smoothing, args)
    cache = None if args.no_cache else enable_compilation_cache()
    where = f" (compiled code is cached in {cache})" if cache else ""
    told = []  # the note once, and only when a program is compiled (not loaded from the store)

    def compiling() -> None:
        if not told:
            told.append(True)
            note(f"compiling the solver for this mesh and settings (once){where}...")

    _export.on_compile(compiling)
    try:
        collision = m.run(
            params,
            mesh,
            settings,
            contact_smoothing=args.contact_smoothing,
            yield_smoothing=args.yield_smoothing,
            scales=scales,
            si_inputs=_si_inputs(args),
        )
    except m.SimulationError as error:
        note(f"simulation failed: {error}")
        if args.json and error.collision is not None:
            record = error.collision.to_json()
            failed = {
                "ok": False,
                "message": str(error),
                "when": now(),
                "failed_at": {
                    "tau": record["t_end"],
                    "steps": record["steps"],
                    "seconds": record["wall_time_s"],  # the run's wall time before it stopped
                    **({"t_s": record["t_end"] * scales.time} if scales is not None else {}),
                },
            }
            print(dumps(with_mass_ratio({**record, **failed}, ratio)))
        return EXIT_SOLVE
    if args.plot is not None:
        from .._plot import plot_collision

        plot_collision(collision, args.plot)
    if args.json:
        print(dumps(with_mass_ratio({"ok": True, **collision.to_json()}, ratio)))
    else:
        print(report(collision, scales))
        if args.plot is not None:
            print(f"plot saved to {args.plot}")
    return EXIT_OK


def report(collision: m.Collision, scales: m.Scales | None = None) -> str:
    """A readable summary: the partition table, checks, timing and how the run ended."""
    record = collision.to_json()
    p = record["params"]
    thickness = f"{p['thickness_ratio']:g}"
    if collision.params.graded:
        thickness = f"graded (uniform reference {thickness})"
    lines = [
        f"ring on beam: h_b/h_r = {thickness}, E/Y = {p['modulus_ratio']:g}, "
        f"R/h_r = {p['slenderness']:g}, g = {p['mass_ratio']:g}, v0 = {p['velocity']:g}, "
        f"L_b/R = {p['span_ratio']:g}, b_b/b_r = {p['width_ratio']:g}, "
        + ("axially constrained" if p["axial_constraint"] else "axially free"),
        *_graded_lines(collision),
        "",
        f"energy partition at tau = {record['t_end']:.4g} (fractions of K0 = "
        f"{record['k0']:.4g} M_pr, half model)",
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
        f"run time              {record['wall_time_s']:.3f} s (compile or cache load "
        f"{record.get('compile_time_s', float('nan')):.2f} s, apart)",
    ]
    si = record.get("si")
    if si is None and scales is not None:  # a collision run without scales, shown in SI
        si = dataclasses.replace(collision, scales=scales).si
    if si is not None:
        lines += ["", *table_lines(si)]
    lines.append(f"status: {collision.message}")
    return "\n".join(lines)


def _graded_lines(collision: m.Collision) -> list[str]:
    """The report's lines on a graded beam: its profile and its mass (none for a uniform beam)."""
    if not collision.params.graded:
        return []
    profile = np.asarray(collision.params.thickness_profile, dtype=float)
    ratio = mass_ratio(collision.params, collision.mesh)
    return [
        f"graded beam: h_k/h_r = {', '.join(f'{v:g}' for v in profile)} "
        f"({profile.size} segments, O to E)",
        f"beam_mass_ratio       {ratio:.6g} (beam mass over the uniform h_b/h_r = "
        f"{float(np.asarray(collision.params.thickness_ratio)):g} beam's)",
    ]
