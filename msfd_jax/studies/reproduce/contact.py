"""Fig. 15 (contact force, raw and moving-averaged, separations) and Fig. 16 (local contact
dissipation against K0, by mass and by velocity).

Fig. 15: the paper does not name its case; it follows Fig. 13-14, so we take Fig. 13's
(h_b/h_r = 2.5, g = 10, v0 = 0.82, constrained) and add h_b/h_r = 1 (constrained) and 3
(free, Fig. 19a) for comparison. Two runs per case: a fine one over tau <= 0.5 (one Verlet step
per diffrax step, sampled every 1e-4: the collision stage resolved, Fig. 15a) and the whole
response (sampled every 1e-3, Fig. 15c).

Definitions.
- The contact is closed at a sample when the total contact force (half model, P R / M_pr) is
  positive: the sharp contact law gives exactly zero when every pair is open.
- A separation is contact lost and regained: a run of samples with zero force between two
  samples in contact. Gaps shorter than the sampling interval can be missed (fine run: 1e-4).
- The moving average is centred, over a window of 0.02 (about three periods of the contact
  force's oscillation, whose frequency we measure from the fine run). The real separation is
  the last instant at which the averaged force exceeds 1 % of its peak.

Fig. 16: h_b/h_r = 1, beam constrained (the paper's case): g = 10 at v0 from 0.3 to 2; g from
0.5 to 70 at v0 = 0.82 (the paper's velocity) and from 2 to 40 at v0 = 1.6 (where contact
dissipates). The same runs serve Fig. 23-24 (`energy.py`).
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from . import _batch as b
from ._common import Finding, Reproduction

WINDOW = 0.02
STAGE = 0.05  # the collision stage of Fig. 15a ("only the initial very brief period")
FIG15_CASES = (
    dict(thickness_ratio=2.5, axial_constraint=1.0),  # Fig. 13's case
    dict(thickness_ratio=1.0, axial_constraint=1.0),
    dict(thickness_ratio=3.0, axial_constraint=0.0),  # Fig. 19a's case
)


def _label(row: dict) -> str:
    return f"h_b/h_r = {row['thickness_ratio']:g}, {b.constraint_name(row['axial_constraint'])}"


def moving_average(ts: np.ndarray, force: np.ndarray, window: float = WINDOW) -> np.ndarray:
    """Centred moving average over `window` (uniform samples; shrinks at the ends)."""
    dt = float(ts[1] - ts[0])
    half = max(int(round(0.5 * window / dt)), 0)
    kernel = np.ones(2 * half + 1)
    total = np.convolve(force, kernel, mode="same")
    count = np.convolve(np.ones_like(force), kernel, mode="same")
    return total / count


def separations(force: np.ndarray, threshold: float = 0.0) -> tuple[int, np.ndarray]:
    """(number of separations, closed mask): gaps of force <= threshold between contacts."""
    closed = force > threshold
    if not closed.any():
        return 0, closed
    first, last = np.argmax(closed), len(closed) - 1 - np.argmax(closed[::-1])
    inner = closed[first : last + 1]
    opens = np.sum(inner[:-1] & ~inner[1:])
    return int(opens), closed


def dominant_frequency(ts: np.ndarray, force: np.ndarray, detrend: float = 0.05) -> float:
    """Angular frequency (rad per unit tau) of the largest peak of the detrended force.

    The force is detrended by a moving average over `detrend` (which must be shorter than the
    record) so that the slow global response does not mask the oscillation.
    """
    closed = force > 0
    if closed.sum() < 16:
        return float("nan")
    f = force[closed.argmax() : len(force) - closed[::-1].argmax()]
    f = f - moving_average(ts[: len(f)], f, detrend)
    spectrum = np.abs(np.fft.rfft(f * np.hanning(len(f))))
    freqs = np.fft.rfftfreq(len(f), float(ts[1] - ts[0]))
    spectrum[0] = 0.0
    return float(2 * np.pi * freqs[int(np.argmax(spectrum))])


def segment_frequencies(quick: bool) -> dict[str, float]:
    """Natural angular frequencies of one ring segment (non-dimensional, Eq. 1 units).

    Axial: a bar of stiffness kappa / l (kappa = 4 (E/Y)(R/h_r)) and mass l: sqrt(kappa) / l.
    Bending: a bar of mass l turning on rotational springs EI / l: sqrt(EI) / l^2, with
    EI = (E/Y)(h_r/R) / 3 in units of M_pr R. Order-of-magnitude estimates (Fig. 15b).
    """
    from ..._params import CollisionParams

    p = CollisionParams()
    beta, slender = float(p.modulus_ratio), float(p.slenderness)
    length = 2.0 * np.sin(0.25 * np.pi / b.mesh(quick).ring_segments)  # chord of one arc
    return dict(
        length=length,
        axial=float(np.sqrt(4.0 * beta * slender) / length),
        bending=float(np.sqrt(beta / (3.0 * slender)) / length**2),
    )


def reproduce_fig15(quick: bool, figures_dir: Path) -> Reproduction:
    start = time.perf_counter()
    rows = list(FIG15_CASES)
    fine = b.histories(rows, quick, b.fine_settings(quick))
    whole = b.histories(rows, quick)
    fig = Figure(figsize=(13, 3.6 * len(rows)), layout="constrained")
    axes = fig.subplots(len(rows), 2, squeeze=False)
    results = []
    for row, f, w, (ax_a, ax_c) in zip(rows, fine, whole, axes, strict=True):
        force_f = f.history["contact_force"].sum(-1)
        force_w = w.history["contact_force"].sum(-1)
        avg_f = moving_average(f.ts, force_f)
        avg_w = moving_average(w.ts, force_w)
        n_fine, _ = separations(force_f)
        n_whole, closed = separations(force_w)
        n_avg, closed_avg = separations(avg_w, 0.01 * avg_w.max())
        last_raw = float(w.ts[closed].max()) if closed.any() else float("nan")
        last_avg = float(w.ts[closed_avg].max()) if closed_avg.any() else float("nan")
        omega = dominant_frequency(f.ts, force_f)
        stage = f.ts <= STAGE
        omega_stage = dominant_frequency(f.ts[stage], force_f[stage], 0.2 * STAGE)
        results.append(
            dict(
                case=_label(row),
                peak_force=float(force_f.max()),
                peak_time=float(f.ts[np.argmax(force_f)]),
                peak_average=float(avg_w.max()),
                separations_fine=n_fine,
                separations_whole=n_whole,
                separations_average=n_avg,
                last_contact=last_raw,
                real_separation=last_avg,
                omega=omega,
                omega_stage=omega_stage,
                status=w.status,
                t_end=w.t_end,
            )
        )
        ax_a.plot(f.ts, force_f, "k-", lw=0.6, label="raw")
        ax_a.plot(f.ts, avg_f, "r-", lw=1.5, label=f"moving average ({WINDOW:g})")
        ax_a.set(
            xlabel=r"$\tau$",
            ylabel="contact force $PR/M_{pr}$",
            title=f"(a) {_label(row)}: tau <= {b.FINE_T_MAX:g}, {n_fine} separations",
            xlim=(0, b.FINE_T_MAX),
        )
        ax_c.plot(
            w.ts, force_w, "-", color="0.6", lw=0.5, label=f"raw (every {w.ts[1] - w.ts[0]:.0e})"
        )
        ax_c.plot(w.ts, avg_w, "r-", lw=1.5, label="moving average")
        ax_c.axvline(last_avg, color="b", ls="--", lw=1, label=f"real separation {last_avg:.2f}")
        ax_c.set(
            xlabel=r"$\tau$",
            title=f"(c) whole response: {n_whole} separations in the raw force",
            xlim=(0, min(w.t_end, 1.2 * last_raw + 0.1) if closed.any() else w.t_end),
        )
        for ax in (ax_a, ax_c):
            ax.grid(alpha=0.3)
            ax.legend(fontsize=8)
    fig.suptitle("Fig. 15: contact force (half model), g = 10, v0 = 0.82")
    name = b.save(fig, figures_dir, "fig15.png")
    text = "\n".join(
        [
            f"Moving average: centred, window {WINDOW:g}. Separations: contact (total force "
            "> 0) lost and regained, counted in the fine run (tau <= 0.5, every 1e-4), in the "
            "whole response (every 1e-3) and in the averaged force (below 1 % of its peak). "
            "Real separation: last instant the averaged force exceeds 1 % of its peak. omega: "
            "dominant angular frequency of the force's oscillation in the fine run (tau <= "
            f"{b.FINE_T_MAX:g}) and in the collision stage alone (tau <= {STAGE:g}, detrended "
            f"over {0.2 * STAGE:g}).",
            "",
            b.table(
                [
                    "case",
                    "peak force (tau)",
                    "peak of average",
                    "separations fine / whole / averaged",
                    "last raw contact",
                    "real separation",
                    "omega (fine run)",
                    "omega (collision stage)",
                    "status",
                ],
                [
                    (
                        r["case"],
                        f"{r['peak_force']:.1f} ({r['peak_time']:.4f})",
                        f"{r['peak_average']:.1f}",
                        f"{r['separations_fine']} / {r['separations_whole']} / "
                        f"{r['separations_average']}",
                        f"{r['last_contact']:.3f}",
                        f"{r['real_separation']:.3f}",
                        f"{r['omega']:.0f}",
                        f"{r['omega_stage']:.0f}",
                        r["status"],
                    )
                    for r in results
                ],
            ),
        ]
    )
    show = results[0]
    seg = segment_frequencies(quick)
    text += (
        f"\n\nA ring segment's natural angular frequencies (estimates, this mesh): axial "
        f"sqrt(kappa)/l = {seg['axial']:.0f}, bending sqrt(EI/(mu R^4))(R/l)^2 = "
        f"{seg['bending']:.0f} (l = {seg['length']:.4f} R)."
    )
    findings = [
        Finding(
            "Fig. 15a-b",
            "the contact force oscillates at a very high frequency, of the order of a "
            "segment's natural frequency (~10^3)",
            f"{show['case']}: dominant angular frequency {show['omega_stage']:.0f} per unit "
            f"tau in the collision stage (tau <= {STAGE:g}; cases: "
            + ", ".join(f"{r['omega_stage']:.0f}" for r in results)
            + f"), {show['omega']:.0f} over tau <= {b.FINE_T_MAX:g}; peak force "
            f"{show['peak_force']:.1f} at tau = {show['peak_time']:.4f}; a segment's axial "
            f"{seg['axial']:.0f}, bending {seg['bending']:.0f}",
            bool(10**2.5 <= show["omega_stage"] <= 10**3.5),  # "of the order of 10^3"
            "Fig. 15a shows only the initial brief period: there the force oscillates at the "
            "contact pair's own frequency sqrt(k/mu) (1253 for S-O) and the segments' (10^3); "
            "over tau <= 0.5 the slower bending of a few segments (10^2) dominates",
        ),
        Finding(
            "Fig. 15a",
            "in the initial short period the contact force drops to zero in short intervals "
            "(separations)",
            f"{show['separations_fine']} separations for tau <= {b.FINE_T_MAX:g} (cases: "
            + ", ".join(str(r["separations_fine"]) for r in results)
            + ")",
            bool(show["separations_fine"] >= 1),
            "the contact pair rebounds between plastic flattening and the beam's local "
            "vibration; the count depends on the mesh and on the sampling (1e-4)",
        ),
        Finding(
            "Fig. 15c",
            "separation and multi-collision occur a few times; the real separation comes "
            "later, seen in the moving-averaged force",
            f"{show['separations_whole']} separations over the whole response (cases: "
            + ", ".join(str(r["separations_whole"]) for r in results)
            + f"); the averaged force stays above 1 % of its peak until tau = "
            f"{show['real_separation']:.3f} (last raw contact {show['last_contact']:.3f})",
            bool(show["separations_whole"] >= 1 and show["real_separation"] > 0.1),
            "the ring rebounds off the beam's vibration and hits again before the last separation",
        ),
    ]
    return Reproduction(
        key="fig15",
        title="Fig. 15: contact force, raw and moving-averaged; separations",
        figures=[name],
        table=text,
        numbers=b.jsonable({"window": WINDOW, "cases": results, "segment": seg}),
        findings=findings,
        wall_time_s=time.perf_counter() - start,
    )


# ---- Fig. 16 (and the runs of Fig. 23-24) --------------------------------------------------


def h1_series(quick: bool) -> dict[str, list[dict]]:
    """h_b/h_r = 1, constrained: velocity at g = 10, mass at v0 = 0.82 and at v0 = 1.6."""
    if quick:
        velocity, mass_paper, mass_fast = (0.82, 1.2, 1.6, 2.0), (2.0, 20.0), (5.0, 20.0)
    else:
        velocity = (0.3, 0.5, 0.82, 1.0, 1.2, 1.4, 1.6, 1.8, 2.0)
        mass_paper = (0.5, 2.0, 5.0, 20.0, 35.0, 50.0, 70.0)
        mass_fast = (2.0, 5.0, 20.0, 40.0)
    base = dict(thickness_ratio=1.0, axial_constraint=1.0)
    return {
        "velocity": [dict(base, mass_ratio=10.0, velocity=v) for v in velocity],
        "mass_v082": [dict(base, mass_ratio=g, velocity=0.82) for g in mass_paper],
        "mass_v16": [dict(base, mass_ratio=g, velocity=1.6) for g in mass_fast],
    }


def h1_table(quick: bool):
    """The runs of Fig. 16 and 23-24 in one sweep: (table, {series: row indices})."""
    series = h1_series(quick)
    rows, index = [], {}
    for name, items in series.items():
        index[name] = list(range(len(rows), len(rows) + len(items)))
        rows += items
    return b.partition(rows, quick), index


def with_g10(table, index: dict, series: str, velocity: float) -> np.ndarray:
    """A mass series' rows plus the g = 10 run of the velocity series at the same v0."""
    extra = [i for i in index["velocity"] if abs(table["velocity"][i] - velocity) < 1e-12]
    rows = np.array(index[series] + extra)
    return rows[np.argsort(table["mass_ratio"][rows])]


def reproduce_fig16(quick: bool, figures_dir: Path) -> Reproduction:
    start = time.perf_counter()
    table, index = h1_table(quick)
    absolute = table["contact"] * table["k0"]  # M_pr
    series = {
        "velocity (g = 10)": np.array(index["velocity"]),
        "mass (v0 = 0.82)": with_g10(table, index, "mass_v082", 0.82),
        "mass (v0 = 1.6)": with_g10(table, index, "mass_v16", 1.6),
    }
    fig = Figure(figsize=(11, 4), layout="constrained")
    ax, ax_v = fig.subplots(1, 2)
    for (name, rows), style in zip(series.items(), ("o-", "s-", "^-"), strict=True):
        ax.plot(table["k0"][rows], absolute[rows], style, ms=4, label=f"varying {name}")
    ax.set(
        xlabel="initial kinetic energy $K_0$ ($M_{pr}$, half model)",
        ylabel="contact dissipation ($M_{pr}$)",
        title="(a) Fig. 16: local contact dissipation, h_b/h_r = 1, constrained",
    )
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    v = series["velocity (g = 10)"]
    ax_v.plot(table["velocity"][v], absolute[v], "o-", ms=4)
    ax_v.set(xlabel="$v_0$", ylabel="contact dissipation ($M_{pr}$)", title="(b) against v0")
    ax_v.grid(alpha=0.3)
    name = b.save(fig, figures_dir, "fig16.png")

    rows_md = []
    for label, rows in series.items():
        for i in rows:
            rows_md.append(
                (
                    label,
                    f"{table['mass_ratio'][i]:g}",
                    f"{table['velocity'][i]:g}",
                    f"{table['k0'][i]:.2f}",
                    f"{absolute[i]:.4f}",
                    f"{table['contact'][i]:.5f}",
                    table["status"][i],
                )
            )
    text = b.table(["series", "g", "v0", "K0", "contact (M_pr)", "contact / K0", "status"], rows_md)
    vel = table["velocity"][v]
    on = absolute[v] > 1e-6
    onset = float(vel[on][0]) if on.any() else float("nan")
    below = float(vel[~on & (vel < onset)].max()) if (~on & (vel < onset)).any() else float("nan")
    slow = series["mass (v0 = 0.82)"]
    fast = series["mass (v0 = 1.6)"]
    spread = (
        float(np.ptp(absolute[fast]) / np.mean(absolute[fast]))
        if absolute[fast].mean() > 0
        else float("nan")
    )
    findings = [
        Finding(
            "Fig. 16",
            "the local contact dissipation is a very small portion of K0",
            f"at most {table['contact'].max():.4f} K0 ({absolute.max():.3f} M_pr) over "
            f"{len(table)} runs",
            bool(table["contact"].max() < 0.05),
            "the contact springs yield only in the first instants of a fast impact",
        ),
        Finding(
            "Fig. 16",
            "at fixed v0 the contact dissipation does not change with the attached mass",
            f"v0 = 0.82: {absolute[slow].max():.4f} M_pr for every g from "
            f"{table['mass_ratio'][slow].min():g} to {table['mass_ratio'][slow].max():g}; "
            f"v0 = 1.6: {absolute[fast].min():.4f}-{absolute[fast].max():.4f} M_pr for g "
            f"from {table['mass_ratio'][fast].min():g} to {table['mass_ratio'][fast].max():g} "
            f"(spread {100 * spread:.1f} % of the mean)",
            bool(spread < 0.05),
            "the collision stage is local: the block is far from the contact and cannot "
            "change the velocity there in time (Sect. 4.3.2)",
        ),
        Finding(
            "Fig. 16",
            "the contact dissipation increases with the initial velocity",
            f"g = 10: zero for v0 <= {below:g}, first non-zero at v0 = {onset:g}, "
            f"{absolute[v][-1]:.4f} M_pr at v0 = {vel[-1]:g}; non-decreasing: "
            f"{bool(np.all(np.diff(absolute[v]) >= -1e-9))}",
            bool(np.all(np.diff(absolute[v]) >= -1e-9) and absolute[v][-1] > 0),
            "the contact pair force grows with the approach speed and passes the contact "
            "yield force (Y b l_t) only above a threshold velocity",
        ),
        Finding(
            "Fig. 16",
            "the contact springs dissipate at the paper's velocities (Fig. 16's fixed-v0 "
            "mass series is a constant, non-zero level; read by eye)",
            f"v0 = 0.82: {absolute[slow].min():.4f}-{absolute[slow].max():.4f} M_pr over "
            f"every mass; dissipation starts between v0 = {below:g} and {onset:g}",
            bool(absolute[slow].min() > 0),
            "the first impact's two-mass peak force v0 sqrt(k mu) (S-O pair: 41.9 at "
            "h_b/h_r = 1, v0 = 0.82) passes the pair's yield force Y b l_t (20 M_pr/R) above "
            "v0 ~ 0.4, so the contact flattens plastically in the collision stage",
        ),
    ]
    return Reproduction(
        key="fig16",
        title="Fig. 16: local contact dissipation against K0 (h_b/h_r = 1, constrained)",
        figures=[name],
        table=text,
        numbers=b.jsonable(
            {
                "k0": table["k0"],
                "mass_ratio": table["mass_ratio"],
                "velocity": table["velocity"],
                "contact_absolute": absolute,
                "status": table["status"],
                "onset_velocity": [below, onset],
            }
        ),
        findings=findings,
        wall_time_s=time.perf_counter() - start,
    )
