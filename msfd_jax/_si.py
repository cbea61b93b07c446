"""Design quantities of one collision in SI units, for the whole structure (host numpy).

The solver integrates the symmetric half model (quarter ring S->G with half the block on a half
beam O->E; `docs/si.md`). Its energies are exactly half the whole structure's (the symmetry
joints and springs are halved, docs/model.md), and so is its contact force, which acts on half
the beam. What a crash test reports refers to the whole structure, so:

- energies (``k0_J``, ``dissipated_J``, ``energy_left_J``): 2 x half model x M_pr;
- ``peak_contact_force_N``: 2 x the half model's total contact force x M_pr / R (both halves
  of the beam);
- ``peak_beam_deflection_m``: the mid-span node O's largest displacement normal to the beam,
  x R (a displacement of the symmetry plane: the same for half and whole);
- ``peak_block_deceleration_m_s2``: the largest acceleration of the rigid block (node G, which
  carries half the block and moves with it) x R / T^2; ``..._g`` the same in standard gravity;
- ``duration_s``: the run's end (dissipation stopped, or the cap) x T.

The peaks are taken on the sampled motion: the node positions are saved at the history's
times (`motion_settings`: ``history_points`` samples over [0, t_max]) and the block's
acceleration is their central second difference, so it is averaged over two sample intervals
(``sample_interval_s``, reported); these unfiltered peaks include the first-impact spike and
the ring's elastic ringing, so ``peak_block_deceleration_10ms_m_s2`` (the largest velocity
change over 10 ms, as EN 1317's averaged indices) and ``mean_contact_force_N`` (impulse over
the time the contact is closed) are the design-level values. The force peak is the history's.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from ._params import Scales

STANDARD_GRAVITY = 9.80665  # m/s^2
DISSIPATION_KEYS = ("beam_bending", "beam_axial", "ring_bending", "ring_axial", "contact")
LEFT_KEYS = ("kinetic", "elastic")
# Whole structure / half model, for energies and the contact force (docs/si.md).
WHOLE = 2.0


def motion_times(settings) -> tuple[float, ...]:
    """The history's sample times, at which a run in SI also saves node positions."""
    return tuple(float(t) for t in np.linspace(0.0, settings.t_max, settings.history_points))


def motion_settings(settings):
    """`settings` with node positions also saved at every history sample (for the peaks)."""
    times = tuple(sorted({*settings.shape_times, *motion_times(settings)}))
    return dataclasses.replace(settings, shape_times=times)


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


def _in_run(ts: np.ndarray, t_end: float, values: np.ndarray) -> np.ndarray:
    finite = np.isfinite(values).reshape(len(ts), -1).all(-1)
    return (ts <= t_end + 1e-12) & finite


def motion(collision) -> dict[str, np.ndarray]:
    """Sampled motion: times, mid-span deflection, block position (non-dimensional, half model).

    Uses every saved shape inside the run (t <= t_end) and the final state; the run must have
    been made with `motion_settings` for the peaks to be resolved.
    """
    sol, scene = collision.solution, collision.scene
    beam, ring = scene.chain_index("beam"), scene.chain_index("ring")
    ts = np.asarray(sol.shape_ts, float)
    t_end = float(sol.t_end)
    beam_xy = np.asarray(sol.shapes[beam], float)
    ring_xy = np.asarray(sol.shapes[ring], float)
    keep = _in_run(ts, t_end, beam_xy) & _in_run(ts, t_end, ring_xy)
    times = np.append(ts[keep], t_end)
    beam_y = np.append(beam_xy[keep, 0, 1], float(np.asarray(sol.final.x[beam])[0, 1]))
    block_y = np.append(ring_xy[keep, -1, 1], float(np.asarray(sol.final.x[ring])[-1, 1]))
    if times.size > 1 and times[-1] - times[-2] < 1e-12:  # the last sample is t_end itself
        times, beam_y, block_y = times[:-1], beam_y[:-1], block_y[:-1]
    y0 = float(beam_xy[0, 0, 1])
    return {"t": times, "deflection": np.abs(beam_y - y0), "block_y": block_y}


def _peak_acceleration(t: np.ndarray, y: np.ndarray) -> float:
    """Largest |d2y/dt2| by central second differences on a (possibly uneven) grid."""
    if t.size < 3:
        return float("nan")
    h1, h2 = np.diff(t)[:-1], np.diff(t)[1:]
    ok = (h1 > 0) & (h2 > 0)
    a = 2.0 * ((y[2:] - y[1:-1]) / h2 - (y[1:-1] - y[:-2]) / h1) / (h1 + h2)
    return float(np.max(np.abs(a[ok]))) if ok.any() else float("nan")


AVERAGING_S = 0.010  # the 10 ms window of EN 1317's ASI / THIV-style averaged decelerations


def _averaged_deceleration(t: np.ndarray, y: np.ndarray, window: float) -> float:
    """Largest |v(t + window) - v(t)| / window, v the block's velocity (linear in between)."""
    if t.size < 3 or window <= 0 or t[-1] - t[0] <= window:
        return float("nan")
    tm = 0.5 * (t[1:] + t[:-1])
    v = np.diff(y) / np.diff(t)
    start = tm[tm + window <= tm[-1]]
    change = np.interp(start + window, tm, v) - np.interp(start, tm, v)
    return float(np.max(np.abs(change))) / window if start.size else float("nan")


def design_quantities(collision, scales: Scales) -> dict[str, Any]:
    """The ``si`` object of ``msfd run --json``: whole-structure values in SI (module doc)."""
    f = collision.fractions
    sol = collision.solution
    energy = WHOLE * float(sol.k0) * scales.moment  # K0 of the whole structure [J]
    ts = np.asarray(sol.ts, float)
    t_end = float(sol.t_end)
    force = np.asarray(sol.history["contact_force"], float)
    force = force.reshape(len(ts), -1)[:, 0]  # set 0 is ring on beam (not collapse contacts)
    force_keep = (ts <= t_end + 1e-12) & np.isfinite(force)
    peak_force = float(force[force_keep].max()) if force_keep.any() else float("nan")
    moved = motion(collision)
    dissipated = {k: f[k] * energy for k in DISSIPATION_KEYS}
    left = {k: f[k] * energy for k in LEFT_KEYS}
    acceleration = _peak_acceleration(moved["t"], moved["block_y"])
    accel_si = acceleration * scales.length / scales.time**2
    averaged = _averaged_deceleration(moved["t"], moved["block_y"], AVERAGING_S / scales.time) * (
        scales.length / scales.time**2
    )
    active = force_keep & (force > 0)
    duration = np.trapezoid(active, ts) if active.any() else 0.0
    impulse = np.trapezoid(np.where(force_keep, force, 0.0), ts)
    mean_force = impulse / duration if duration > 0 else float("nan")
    samples = moved["t"]
    interval = float(np.median(np.diff(samples))) if samples.size > 1 else float("nan")
    return {
        "whole_structure": True,
        "k0_J": energy,
        "dissipated_J": dissipated,
        "dissipated_total_J": sum(dissipated.values()),
        "energy_left_J": left,
        "energy_left_total_J": sum(left.values()),
        "peak_beam_deflection_m": float(moved["deflection"].max()) * scales.length,
        "final_beam_deflection_m": float(moved["deflection"][-1]) * scales.length,
        "peak_contact_force_N": WHOLE * peak_force * scales.force,
        "peak_block_deceleration_m_s2": accel_si,
        "peak_block_deceleration_g": accel_si / STANDARD_GRAVITY,
        "peak_block_deceleration_10ms_m_s2": averaged,
        "mean_contact_force_N": WHOLE * mean_force * scales.force,
        "duration_s": t_end * scales.time,
        "sample_interval_s": interval * scales.time,
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
    lines += [
        f"  peak beam deflection (mid-span) {1e3 * si['peak_beam_deflection_m']:9.4g} mm"
        f" (final {1e3 * si['final_beam_deflection_m']:.4g} mm)",
        f"  peak contact force (whole beam) {si['peak_contact_force_N'] / 1e3:9.4g} kN",
        f"  peak block deceleration         {si['peak_block_deceleration_m_s2']:10.4g} m/s^2"
        f" ({si['peak_block_deceleration_g']:.3g} g, over {1e3 * si['sample_interval_s']:.3g}"
        " ms samples)",
        f"  peak block deceleration, 10 ms  {si['peak_block_deceleration_10ms_m_s2']:10.4g}"
        f" m/s^2 ({si['peak_block_deceleration_10ms_m_s2'] / STANDARD_GRAVITY:.3g} g)",
        f"  mean contact force while open   {si['mean_contact_force_N'] / 1e3:9.4g} kN",
        f"  duration                        {1e3 * si['duration_s']:10.4g} ms",
    ]
    s = si["scales"]
    lines.append(
        f"  scales: energy M_pr {s['energy_J']:.4g} J, length R {s['length_m']:.4g} m, "
        f"time T {1e3 * s['time_s']:.4g} ms, force M_pr/R {s['force_N']:.4g} N"
    )
    return lines
