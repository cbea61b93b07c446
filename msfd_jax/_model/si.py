"""Design quantities of one collision in SI units, for the whole structure (host numpy).

The solver integrates the symmetric half model (quarter ring S->G with half the block on a half
beam O->E; `docs/si.md`). Its energies are exactly half the whole structure's (the symmetry
joints and springs are halved, docs/model.md), and so is its contact force, which acts on half
the beam. What a crash test reports refers to the whole structure, so:

- energies (``k0_J``, ``dissipated_J``, ``energy_left_J``): 2 x half model x M_pr;
- contact forces (``peak_contact_force_N``, ``mean_contact_force_N``): 2 x the half model's
  total contact force x M_pr / R (both halves of the beam);
- lengths (deflection of the mid-span node O, travel of the block node G, crush of the ring,
  the shortening of the distance from its front node S to the block): x R (a motion of the
  symmetry plane or of the block: the same for half and whole);
- ``peak_block_deceleration_m_s2``: the block node's largest |acceleration| x R / T^2;
- ``duration_s``: the run's end (dissipation stopped, or the cap) x T.

Peaks, the impulse and the contact time are kept by the engine at every step (`_batched.peaks`), not
read from saved samples, so they do not depend on `Settings.history_points`. The mean contact
force is the impulse over the time the contact is closed (so it never exceeds the peak).
The unfiltered peak deceleration includes the first-impact spike and the ring's elastic
ringing; ``peak_block_deceleration_10ms_m_s2`` (the largest change of the block's velocity
over 10 ms, as EN 1317's averaged indices, over 10 ms) is the design-level value: it is read
from the block's velocity saved at the history samples (``sample_interval_s``, reported; the
default 1001 samples over the cap resolve 10 ms by ~70 samples in the paper's SI case).
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping
from typing import Any

import numpy as np

from .params import PAPER_SI, Scales, from_si

STANDARD_GRAVITY = 9.80665  # m/s^2
DISSIPATION_KEYS = ("beam_bending", "beam_axial", "ring_bending", "ring_axial", "contact")
LEFT_KEYS = ("kinetic", "elastic")
# Whole structure / half model, for energies and the contact force (docs/si.md).
WHOLE = 2.0


def scales_json(scales: Scales) -> dict[str, float]:
    """The unit scales with their units in the key names."""
    return {
        "energy_J": scales.moment,
        "moment_N_m": scales.moment,
        "length_m": scales.length,
        "time_s": scales.time,
        "velocity_m_s": scales.velocity,
        "force_N": scales.force,
    }


AVERAGING_S = 0.010  # the 10 ms window of EN 1317's ASI / THIV-style averaged decelerations


def _averaged_deceleration(t: np.ndarray, v: np.ndarray, window: float) -> float:
    """Largest |v(t + window) - v(t)| / window over the run, v the block's velocity sampled at
    `t` (linear in between). Past the run's end the velocity is held at its last value (the
    run stops once dissipation has stopped), so a run shorter than the window gives its whole
    change of velocity over the window."""
    change = np.interp(t + window, t, v) - v
    return float(np.max(np.abs(change))) / window


def _whole_run(ts: np.ndarray, t_end: float, values: np.ndarray) -> np.ndarray:
    """The samples inside the run (t <= t_end; diffrax fills the later ones with inf)."""
    return (ts <= t_end + 1e-12) & np.isfinite(values)


def _final_motion(collision) -> dict[str, float]:
    """Deflection of O, travel of G and crush S-G at the end of the run (units of R)."""
    sol, scene = collision.solution, collision.scene
    ring = scene.chains[scene.chain_index("ring")]
    beam = scene.chains[scene.chain_index("beam")]
    x_ring = np.asarray(sol.final.x[scene.chain_index("ring")], float)
    x_beam = np.asarray(sol.final.x[scene.chain_index("beam")], float)
    r0, b0 = np.asarray(ring.reference, float), np.asarray(beam.reference, float)
    return {
        "deflection": abs(x_beam[0, 1] - b0[0, 1]),
        "travel": abs(x_ring[-1, 1] - r0[-1, 1]),
        "crush": float(np.hypot(*(r0[0] - r0[-1])) - np.hypot(*(x_ring[0] - x_ring[-1]))),
    }


def design_quantities(collision, scales: Scales) -> dict[str, Any]:
    """The ``si`` object of ``msfd run --json``: whole-structure values in SI (module doc)."""
    f = collision.fractions
    sol = collision.solution
    peaks = {k: float(np.asarray(v)) for k, v in sol.peaks.items()}
    length, force, time = scales.length, scales.force, scales.time
    accel = length / time**2
    energy = WHOLE * float(sol.k0) * scales.moment  # K0 of the whole structure [J]
    ts = np.asarray(sol.ts, float)
    t_end = float(sol.t_end)
    velocity = np.asarray(sol.history["block_velocity"], float)
    keep = _whole_run(ts, t_end, velocity)
    averaged = _averaged_deceleration(ts[keep], velocity[keep], AVERAGING_S / time) * accel
    final = _final_motion(collision)
    dissipated = {k: f[k] * energy for k in DISSIPATION_KEYS}
    left = {k: f[k] * energy for k in LEFT_KEYS}
    contact_time = peaks["contact_time"]
    mean_force = peaks["contact_impulse"] / contact_time if contact_time > 0 else 0.0
    return {
        "whole_structure": True,
        "k0_J": energy,
        "dissipated_J": dissipated,
        "dissipated_total_J": sum(dissipated.values()),
        "energy_left_J": left,
        "energy_left_total_J": sum(left.values()),
        "peak_beam_deflection_m": peaks["peak_deflection"] * length,
        "final_beam_deflection_m": final["deflection"] * length,
        "peak_block_travel_m": peaks["peak_block_travel"] * length,
        "final_block_travel_m": final["travel"] * length,
        "peak_ring_crush_m": peaks["peak_ring_crush"] * length,
        "final_ring_crush_m": final["crush"] * length,
        "peak_contact_force_N": WHOLE * peaks["peak_contact_force"] * force,
        "mean_contact_force_N": WHOLE * mean_force * force,
        "contact_duration_s": contact_time * time,
        "peak_block_deceleration_m_s2": peaks["peak_block_deceleration"] * accel,
        "peak_block_deceleration_g": peaks["peak_block_deceleration"] * accel / STANDARD_GRAVITY,
        "peak_block_deceleration_10ms_m_s2": averaged,
        "duration_s": t_end * time,
        "sample_interval_s": float(ts[1] - ts[0]) * time,
        "scales": scales_json(scales),
    }


def table_lines(si: dict[str, Any]) -> list[str]:
    """The readable table's SI block (whole structure)."""
    lines = ["SI design quantities (whole structure: both halves of ring and beam)"]
    lines.append(f"  initial kinetic energy K0      {si['k0_J'] / 1e3:10.4g} kJ")
    for key, value in si["dissipated_J"].items():
        lines.append(f"  dissipated, {key:<18} {value / 1e3:10.4g} kJ")
    lines.append(f"  dissipated, total              {si['dissipated_total_J'] / 1e3:10.4g} kJ")
    lines.append(f"  left (kinetic + elastic)       {si['energy_left_total_J'] / 1e3:10.4g} kJ")
    mm = {k: 1e3 * si[k] for k in si if k.endswith("_m")}
    lines += [
        f"  beam deflection (mid-span)      {mm['peak_beam_deflection_m']:10.4g} mm peak,"
        f" {mm['final_beam_deflection_m']:.4g} mm final",
        f"  ring crush (front to block)     {mm['peak_ring_crush_m']:10.4g} mm peak,"
        f" {mm['final_ring_crush_m']:.4g} mm final",
        f"  block travel                    {mm['peak_block_travel_m']:10.4g} mm peak,"
        f" {mm['final_block_travel_m']:.4g} mm final",
        f"  contact force (whole beam)      {si['peak_contact_force_N'] / 1e3:10.4g} kN peak,"
        f" {si['mean_contact_force_N'] / 1e3:.4g} kN mean over"
        f" {1e3 * si['contact_duration_s']:.4g} ms closed",
        f"  block deceleration              {si['peak_block_deceleration_m_s2']:10.4g} m/s^2"
        f" peak ({si['peak_block_deceleration_g']:.3g} g, at every step)",
        f"  block deceleration, 10 ms       {si['peak_block_deceleration_10ms_m_s2']:10.4g}"
        f" m/s^2 ({si['peak_block_deceleration_10ms_m_s2'] / STANDARD_GRAVITY:.3g} g)",
        f"  duration                        {1e3 * si['duration_s']:10.4g} ms",
    ]
    s = si["scales"]
    lines.append(
        f"  scales: energy M_pr {s['energy_J']:.4g} J, length R {s['length_m']:.4g} m, "
        f"time T {1e3 * s['time_s']:.4g} ms, force M_pr/R {s['force_N']:.4g} N"
    )
    return lines


# ---- sweeps in SI: inputs in SI units, the design quantities as columns ----

SI_INPUTS = (*PAPER_SI, "beam_width")  # `from_si`'s keywords, as `run_si` takes them
SI_UNITS = {"_J": "J", "_N": "N", "_m": "m", "_s": "s", "_m_s2": "m/s^2", "_g": "g"}
INPUT_UNITS = {
    "youngs_modulus": "Pa",
    "yield_stress": "Pa",
    "density": "kg/m^3",
    "radius": "m",
    "width": "m",
    "ring_thickness": "m",
    "beam_thickness": "m",
    "beam_half_span": "m",
    "impact_speed": "m/s",
    "block_mass": "kg",
    "beam_width": "m",
}


def units_of(column: str) -> str | None:
    """The SI unit of a sweep column (NetCDF's ``units`` attribute), None if non-dimensional."""
    if column.startswith("si_"):
        return INPUT_UNITS.get(column[3:])
    if column.startswith("scale_"):
        return {"moment": "J", "length": "m", "time": "s", "force": "N"}.get(column[6:])
    for suffix in sorted(SI_UNITS, key=len, reverse=True):
        if column.endswith(suffix):
            return SI_UNITS[suffix]
    return None


def si_sweep(grid_or_list) -> tuple[list[dict], list[dict], dict | None] | None:
    """A sweep given in SI (`SI_INPUTS` keys, missing ones `PAPER_SI`'s) as a list of
    collisions in groups, each row's SI inputs and scales, and the SI grid's axes (a dict of
    value lists: its Cartesian product, last key fastest); None for a sweep given in groups.
    Mixing SI inputs and groups (other than ``axial_constraint``) is refused."""
    rows = [grid_or_list] if isinstance(grid_or_list, Mapping) else list(grid_or_list)
    keys = {k for row in rows if isinstance(row, Mapping) for k in row}
    if "velocity" in keys and keys & set(SI_INPUTS):
        raise ValueError(
            "velocity is the non-dimensional v0; give the SI speed as impact_speed [m/s]"
        )
    if not keys & set(SI_INPUTS):
        return None
    groups = sorted(keys - set(SI_INPUTS) - {"axial_constraint"})
    if groups:
        raise ValueError(
            f"{groups} cannot be combined with SI inputs in one sweep; give SI values only "
            f"(allowed: {', '.join(SI_INPUTS)}, axial_constraint)"
        )
    if isinstance(grid_or_list, Mapping):
        axes = {k: list(np.atleast_1d(np.asarray(v, dtype=object))) for k, v in rows[0].items()}
        points = [dict(zip(axes, p, strict=True)) for p in itertools.product(*axes.values())]
        grid = {_column(k): np.asarray(v, float) for k, v in axes.items()}
    else:
        points, grid = rows, None
    collisions, info = [], []
    for point in points:
        inputs = {**PAPER_SI, **point}
        params, scales = from_si(
            **{k: v for k, v in inputs.items() if k != "axial_constraint"},
            axial_constraint=bool(inputs.get("axial_constraint", True)),
        )
        collisions.append({k: float(np.asarray(v)) for k, v in params.scalars().items()})
        info.append({"inputs": inputs, "scales": scales})
    return collisions, info, grid


def _column(key: str) -> str:
    return "axial_constraint" if key == "axial_constraint" else f"si_{key}"


def si_columns(columns: dict[str, np.ndarray], info: list[dict]) -> dict[str, np.ndarray]:
    """The SI columns of a sweep's table (whole structure, as `design_quantities`): the SI
    inputs (``si_*``), the scales (``scale_*``), energies in J, the engine's peaks in SI and
    the duration. The 10 ms deceleration and the final positions need a run's histories and
    final state: `run_si` gives them."""
    out = {}
    for name in SI_INPUTS:
        values = [row["inputs"].get(name) for row in info]
        if any(v is not None for v in values):
            out[f"si_{name}"] = np.asarray([np.nan if v is None else v for v in values], float)
    scale = {k: np.asarray([vars(r["scales"])[k] for r in info]) for k in vars(info[0]["scales"])}
    for key in ("moment", "length", "time", "force"):
        out[f"scale_{key}"] = scale[key]
    energy = WHOLE * columns["k0"] * scale["moment"]
    out["k0_J"] = energy
    for key in (*DISSIPATION_KEYS, *LEFT_KEYS):
        out[f"{key}_J"] = columns[key] * energy
    out["dissipated_total_J"] = sum(columns[k] for k in DISSIPATION_KEYS) * energy
    out["energy_left_J"] = sum(columns[k] for k in LEFT_KEYS) * energy
    length, force, time = scale["length"], scale["force"], scale["time"]
    if "peak_deflection" in columns:
        out["peak_beam_deflection_m"] = columns["peak_deflection"] * length
        out["peak_ring_crush_m"] = columns["peak_ring_crush"] * length
        out["peak_block_travel_m"] = columns["peak_block_travel"] * length
        out["peak_contact_force_N"] = WHOLE * columns["peak_contact_force"] * force
        closed = columns["contact_time"]
        mean = np.divide(
            columns["contact_impulse"], closed, out=np.zeros_like(closed), where=closed > 0
        )
        out["mean_contact_force_N"] = WHOLE * mean * force
        out["contact_duration_s"] = closed * time
        decel = columns["peak_block_deceleration"] * length / time**2
        out["peak_block_deceleration_m_s2"] = decel
        out["peak_block_deceleration_g"] = decel / STANDARD_GRAVITY
    out["duration_s"] = columns["t_end"] * time
    return out
