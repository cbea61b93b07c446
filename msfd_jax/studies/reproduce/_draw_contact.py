"""The figures of Fig. 15 and Fig. 16, drawn from `contact`'s computed numbers (rendering only)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from . import _batch as b


def draw_fig15(numbers: dict, figures_dir: Path) -> list[str]:
    """``fig15.png``: per case a row, the fine run's force and the whole response's; panels
    lettered (a), (b), (c), ... row by row, so that no two panels share a letter."""
    cases, curves = numbers["cases"], numbers["curves"]
    fig = Figure(figsize=(13, 3.6 * len(cases)), layout="constrained")
    axes = fig.subplots(len(cases), 2, squeeze=False)
    letters = iter("abcdefghijklmnopqrstuvwxyz")
    for r, c, (ax_a, ax_c) in zip(cases, curves, axes, strict=True):
        first, second = next(letters), next(letters)
        ax_a.plot(c["fine_ts"], c["fine_force"], "k-", lw=0.6, label="raw")
        ax_a.plot(
            c["fine_ts"],
            c["fine_average"],
            "r-",
            lw=1.5,
            label=f"moving average ({numbers['window']:g})",
        )
        ax_a.set(
            xlabel=r"$\tau$",
            ylabel="contact force $PR/M_{pr}$",
            title=f"({first}) {r['case']}: tau <= {b.FINE_T_MAX:g}, "
            f"{r['separations_fine']} separations",
            xlim=(0, b.FINE_T_MAX),
        )
        ts = c["whole_ts"]
        ax_c.plot(
            ts, c["whole_force"], "-", color="0.6", lw=0.5, label=f"raw (every {ts[1] - ts[0]:.0e})"
        )
        ax_c.plot(ts, c["whole_average"], "r-", lw=1.5, label="moving average")
        last_avg, last_raw = r["real_separation"], r["last_contact"]
        ax_c.axvline(last_avg, color="b", ls="--", lw=1, label=f"real separation {last_avg:.2f}")
        closed = not np.isnan(last_raw)  # the raw contact closed at some sample
        ax_c.set(
            xlabel=r"$\tau$",
            title=f"({second}) whole response: {r['separations_whole']} separations in the "
            "raw force",
            xlim=(0, min(r["t_end"], 1.2 * last_raw + 0.1) if closed else r["t_end"]),
        )
        for ax in (ax_a, ax_c):
            ax.grid(alpha=0.3)
            ax.legend(fontsize=8)
    fig.suptitle("Fig. 15: contact force (half model), g = 10, v0 = 0.82")
    return [b.save(fig, figures_dir, "fig15.png")]


def draw_fig16(numbers: dict, figures_dir: Path) -> list[str]:
    """``fig16.png``: (a) contact dissipation against K0 per series, (b) against v0."""
    absolute = numbers["contact_absolute"]
    fig = Figure(figsize=(11, 4), layout="constrained")
    ax, ax_v = fig.subplots(1, 2)
    for (name, rows), style in zip(numbers["series"].items(), ("o-", "s-", "^-"), strict=True):
        ax.plot(numbers["k0"][rows], absolute[rows], style, ms=4, label=f"varying {name}")
    ax.set(
        xlabel="initial kinetic energy $K_0$ ($M_{pr}$, half model)",
        ylabel="contact dissipation ($M_{pr}$)",
        title="(a) Fig. 16: local contact dissipation, h_b/h_r = 1, constrained",
    )
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    v = numbers["series"]["velocity (g = 10)"]
    ax_v.plot(numbers["velocity"][v], absolute[v], "o-", ms=4)
    ax_v.set(xlabel="$v_0$", ylabel="contact dissipation ($M_{pr}$)", title="(b) against v0")
    ax_v.grid(alpha=0.3)
    return [b.save(fig, figures_dir, "fig16.png")]
