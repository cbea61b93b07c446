"""The figures of Fig. 17(c) and Fig. 18/22, drawn from `quasistatic`'s computed numbers (their
``plot`` entries; rendering only)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure


def draw_fig17(numbers: dict, figures_dir: Path) -> list[str]:
    """``fig17c.png``: the slow MS-FD runs, their moving average and the Appendix's phases."""
    plot = numbers["plot"]
    runs, curve = plot["runs"], plot["curve"]
    figures_dir.mkdir(parents=True, exist_ok=True)
    fig = Figure(figsize=(6.4, 4.2))
    ax = fig.add_subplot()
    for r, colour in zip(runs, ("0.65", "C0"), strict=True):
        ax.plot(r["y"], r["p"], color=colour, lw=0.6, label=f"MS-FD, v = {r['speed']:g}")
    ax.plot(runs[-1]["y"], plot["smooth"], "C0", lw=1.6, label="MS-FD, moving average 0.02")
    for ph, colour in ((1, "k"), (2, "C3"), (3, "C2"), (4, "0.5")):
        sel = curve.phase == ph
        ax.plot(
            curve.y[sel],
            curve.p[sel],
            color=colour,
            lw=1.8,
            label=f"rigid-plastic, phase {ph}" if ph < 4 else "rigid-plastic, after III",
        )
    py, pp = plot["printed"]
    ax.plot(py, pp, "k:", lw=1.0, label="printed Phase I (contact kept at crown)")
    ax.set(
        xlabel=r"$y_r = Y_r/R$",
        ylabel=r"$p = PR/M_{pr}$ (half ring)",
        xlim=(0, plot["y_max"]),
        ylim=(0, 22),
        title="Fig. 17(c): half ring pressed by a rigid plate",
    )
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(figures_dir / "fig17c.png", dpi=130)
    return ["fig17c.png"]


def draw_fig18_22(numbers: dict, figures_dir: Path) -> list[str]:
    """``fig18_fig22.png``: per case the beam (left, MS-FD and rigid-plastic) and the ring
    (right, MS-FD and Appendix) on one load axis."""
    plot = numbers["plot"]
    ring, appendix = plot["ring"], plot["appendix"]
    fig = Figure(figsize=(11, 4.2))
    for j, (detail, beam) in enumerate(zip(numbers["detail"]["cases"], plot["beams"], strict=True)):
        name = detail["name"]
        case = numbers[name.replace(". ", "").lower()]
        lam, axial = case["thickness_ratio"], case["axial_constraint"]
        ax = fig.add_subplot(1, 2, j + 1)
        ax.plot(-beam["y"], beam["p"], color="0.7", lw=0.5)
        ax.plot(-beam["y"], beam["smooth"], "C1", lw=1.4, label="beam, MS-FD")
        ax.plot(
            -beam["y_rigid"],
            beam["p_rigid"],
            "k--",
            lw=1.2,
            label="beam, Eq. 25" if axial else r"beam, $2m_p/\sqrt{l_b^2-y^2}$",
        )
        ax.plot(ring["y"], ring["p"], color="0.7", lw=0.5)
        ax.plot(ring["y"], ring["smooth"], "C0", lw=1.4, label="ring, MS-FD")
        ax.plot(appendix["y"], appendix["p"], "k-", lw=1.2, label="ring, Appendix (rigid-plastic)")
        ax.axvline(0.0, color="k", lw=0.6)
        ax.set(
            xlabel=r"$\leftarrow y_b$ (beam)     $y_r$ (ring) $\rightarrow$",
            ylabel="p (load on the whole structure, $M_{pr}/R$)",
            xlim=(-0.6, 0.6),
            ylim=(0, 30 if axial else 20),
            title=f"{name}: $h_b/h_r$ = {lam:g}, beam {'constrained' if axial else 'free'}",
        )
        ax.set_xticks(
            np.linspace(-0.6, 0.6, 7), [f"{abs(t):.1f}" for t in np.linspace(-0.6, 0.6, 7)]
        )
        ax.legend(fontsize=7, loc="upper left" if axial else "upper right")
    fig.tight_layout()
    figures_dir.mkdir(parents=True, exist_ok=True)
    fig.savefig(figures_dir / "fig18_fig22.png", dpi=130)
    return ["fig18_fig22.png"]
