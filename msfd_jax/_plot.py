"""Figures of one collision: energy histories, shapes, contact force and contact pairs (Fig. 13).

Figures are built on `matplotlib.figure.Figure` directly, not through `pyplot`: no global
figure registry (nothing to close, no "too many figures" warning in loops) and no GUI backend,
so they render on a machine without a display (saving uses Agg). In a notebook a returned
figure shows as the cell's value (`_repr_png_`, IPython's display protocol, since such a figure
is not known to pyplot's inline backend); in a script save it with ``path=`` or
``fig.savefig``.
"""

from __future__ import annotations

import io
import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from ._collision.run import FRACTION_KEYS, Collision

# One colour per energy store, shared by every figure (tab10, dissipation warm, recoverable cool).
COLOURS = {
    "beam_bending": "tab:red",
    "beam_axial": "tab:orange",
    "ring_bending": "tab:purple",
    "ring_axial": "tab:pink",
    "contact": "tab:brown",
    "kinetic": "tab:blue",
    "elastic": "tab:cyan",
}
LABELS = {
    "beam_bending": "beam bending",
    "beam_axial": "beam axial",
    "ring_bending": "ring bending",
    "ring_axial": "ring axial",
    "contact": "contact",
    "kinetic": "kinetic",
    "elastic": "elastic",
}
# Ring and beam keep one colour in every figure: the hue of their bending energy above.
_CHAIN_COLOURS = {"ring": COLOURS["ring_bending"], "beam": COLOURS["beam_bending"]}


def _units(collision: Collision, si: bool | None):
    """(time, energy, length, force) factors and labels: non-dimensional or SI, whole."""
    scales = collision.scales if si or si is None else None
    if si and scales is None:
        raise ValueError("si=True needs a collision given in SI (msfd_jax.run_si)")
    if scales is None:
        return dict(t=1.0, e=None, x=1.0, f=1.0, tl=r"$\tau$", xl="R", fl=r"$P R / M_{pr}$ (half)")
    return dict(
        t=1e3 * scales.time,
        e=2e-3 * scales.moment * float(collision.solution.k0),
        x=scales.length,
        f=2e-3 * scales.force,
        tl="t [ms]",
        xl="m",
        fl="contact force [kN] (whole beam)",
    )


class _Figure(Figure):
    """A figure that shows itself in Jupyter without pyplot."""

    def _repr_png_(self) -> bytes:
        buffer = io.BytesIO()
        self.savefig(buffer, format="png", dpi=100)
        return buffer.getvalue()


def _save(fig: Figure, path: str | Path | None) -> Figure:
    if path is not None:
        fig.savefig(path, dpi=150)
    return fig


def _finished(collision: Collision) -> np.ndarray:
    """Mask of history samples inside the run (t <= t_end; later samples are inf)."""
    sol = collision.solution
    ts = np.asarray(sol.ts)
    return (ts <= float(sol.t_end) + 1e-12) & np.isfinite(np.asarray(sol.history["elastic"]))


def energy_histories(collision: Collision) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """(tau, {key: E_key(tau)/K0}) for the seven `FRACTION_KEYS`, cut at the end of the run."""
    sol, scene = collision.solution, collision.scene
    keep = _finished(collision)
    h = {k: np.asarray(v)[keep] for k, v in sol.history.items() if k != "contact_pairs"}
    k0 = float(sol.k0)
    zeros = np.zeros(int(keep.sum()))
    out: dict[str, np.ndarray] = {}
    for name in ("beam", "ring"):
        i = scene.chain_index(name)
        out[f"{name}_bending"] = zeros if i is None else h["bending"][:, i] / k0
        out[f"{name}_axial"] = zeros if i is None else h["axial"][:, i] / k0
    out["contact"] = h["contact"].sum(-1) / k0
    out["kinetic"] = h["kinetic"].sum(-1) / k0
    out["elastic"] = h["elastic"] / k0
    return np.asarray(sol.ts)[keep], out


def plot_energies(collision: Collision, ax=None, *, si: bool | None = None):
    """Energy histories on `ax` (a new figure if None): E/K0 over tau, or kJ over ms in SI."""
    fig, ax = _axes(ax, (6, 4))
    u = _units(collision, si)
    ts, energies = energy_histories(collision)
    scale = 1.0 if u["e"] is None else u["e"]
    for key in FRACTION_KEYS:
        if np.any(energies[key] != 0):
            ax.plot(u["t"] * ts, scale * energies[key], color=COLOURS[key], label=LABELS[key])
    ylabel = r"$E / K_0$" if u["e"] is None else "energy [kJ] (whole structure)"
    ax.set(xlabel=u["tl"], ylabel=ylabel, title="(a) energy partition")
    ax.set_xlim(0.0, u["t"] * ts[-1])
    ax.set_ylim(bottom=0.0)
    ax.grid(alpha=0.3)
    ax.legend(fontsize="small", ncols=2)
    return fig


def _axes(ax, size):
    if ax is not None:
        return ax.figure, ax
    fig = _Figure(figsize=size, layout="constrained")
    return fig, fig.subplots()


def plot_shapes(collision: Collision, ax=None, *, si: bool | None = None):
    """Half-model shapes mirrored about x = 0, so the whole ring and beam are drawn.

    Intermediate shapes are those at the settings' `shape_times` (a run in SI saves more).
    """
    fig, ax = _axes(ax, (8, 3))
    u = _units(collision, si)
    sol, scene = collision.solution, collision.scene
    shape_ts = np.asarray(sol.shape_ts)
    t_end = float(sol.t_end)
    wanted = None if collision.settings is None else collision.settings.shape_times
    for chain, shapes, final in zip(scene.chains, sol.shapes, sol.final.x, strict=True):
        colour = _CHAIN_COLOURS.get(chain.name, "k")
        shapes = u["x"] * np.asarray(shapes)
        for t, xy in zip(shape_ts[1:], shapes[1:], strict=True):
            asked = wanted is None or any(abs(t - w) < 1e-12 for w in wanted)
            if asked and t < t_end and np.all(np.isfinite(xy)):
                _mirrored(ax, xy, color=colour, alpha=0.3, lw=0.9)
        _mirrored(ax, shapes[0], color="0.5", ls="--", lw=1.0)
        _mirrored(ax, u["x"] * np.asarray(final), color=colour, lw=1.8, label=chain.name)
    ax.plot([], [], color="0.5", ls="--", label="initial")
    ax.plot([], [], color="0.4", alpha=0.3, label="intermediate")
    ax.set_aspect("equal")
    end = f"t = {u['t'] * t_end:.3g} ms" if u["e"] is not None else rf"$\tau$ = {t_end:.3g}"
    unit = "/ R" if u["e"] is None else "[m]"
    ax.set(xlabel=f"x {unit}", ylabel=f"y {unit}", title=f"(c) shapes (final at {end})")
    ax.legend(fontsize="small", loc="lower right")
    return fig


def _mirrored(ax, xy: np.ndarray, **kwargs) -> None:
    full = np.concatenate([xy[::-1] * [-1.0, 1.0], xy[1:]])
    ax.plot(full[:, 0], full[:, 1], **kwargs)


def plot_contact_force(collision: Collision, ax=None, *, si: bool | None = None):
    """Total contact force over time: P R / M_pr of the half model, or kN on the whole beam."""
    fig, ax = _axes(ax, (6, 4))
    u = _units(collision, si)
    sol = collision.solution
    keep = _finished(collision)
    force = u["f"] * np.asarray(sol.history["contact_force"])[keep][:, 0]
    ts = u["t"] * np.asarray(sol.ts)[keep]
    ax.plot(ts, force, color="k", lw=1.0)
    ax.set_xlim(0.0, ts[-1])
    ax.set_ylim(bottom=0.0)
    ax.set(xlabel=u["tl"], ylabel=u["fl"], title="(b) contact force")
    ax.grid(alpha=0.3)
    return fig


def _plot_contact_pairs(fig: Figure, ax, collision: Collision, si: bool | None = None) -> None:
    """Ring node vs beam node of every active contact spring, coloured by time (Fig. 13e):
    tau, or ms in SI (as the other panels)."""
    sol = collision.solution
    keep = _finished(collision)
    u = _units(collision, si)
    ts = np.asarray(sol.ts)[keep] * u["t"]
    pairs = sol.history["contact_pairs"]
    if not pairs:
        ax.set_axis_off()
        return
    active = np.asarray(pairs[0])[keep]
    step, ring, beam = np.nonzero(active)
    # Later times are drawn on top, so the final contact zone stays visible; the colour scale
    # ends at the last contact, not at t_end (contact usually ends well before dissipation).
    last = ts[step].max() if step.size else ts[-1]
    points = ax.scatter(beam, ring, c=ts[step], s=14, cmap="viridis", vmin=0.0, vmax=last)
    fig.colorbar(points, ax=ax, label=u["tl"])
    ax.set_xlim(-0.5, active.shape[2] - 0.5)
    ax.set_ylim(-0.5, active.shape[1] - 0.5)
    ax.set(xlabel="beam node (from O)", ylabel="ring node (from S)", title="(d) contact pairs")
    ax.grid(alpha=0.3)


def plot_collision(
    collision: Collision, path: str | Path | None = None, *, si: bool | None = None
) -> Figure:
    """Four panels of one collision, after the paper's Fig. 13.

    (a) energy fractions E/K0 over tau, (b) total contact force, (c) initial, intermediate
    (light) and final shapes, (d) active contact node pairs coloured by time.

    **Arguments:**
    - `collision`: the result of `msfd_jax.run`.
    - `path`: if given, the figure is also saved there (format from the suffix).
    - `si`: SI axes (ms, kJ and kN of the whole structure, m); default: when the collision
      was given in SI (`Collision.scales`).
    """
    fig = _Figure(figsize=(12, 8.5), layout="constrained")
    top, bottom = fig.subfigures(2, 1, height_ratios=(1.0, 0.75))
    ax_energy, ax_force = top.subplots(1, 2)
    # The shapes are drawn to scale (about 6R by 1.5R), so they get the wider bottom panel.
    ax_shapes, ax_pairs = bottom.subplots(1, 2, width_ratios=(2.2, 1.0))
    plot_energies(collision, ax_energy, si=si)
    plot_contact_force(collision, ax_force, si=si)
    plot_shapes(collision, ax_shapes, si=si)
    _plot_contact_pairs(bottom, ax_pairs, collision, si)
    p = collision.params
    fig.suptitle(
        rf"$h_b/h_r$ = {float(p.thickness_ratio):g}, g = {float(p.mass_ratio):g}, "
        rf"$v_0$ = {float(p.velocity):g}, "
        f"{'axially constrained' if float(p.axial_constraint) else 'axially free'} beam"
        f" — {collision.status}"
    )
    return _save(fig, path)


Partition = Collision | Mapping[str, Any]


def _partitions(partition: Partition | Sequence[Partition]) -> list[dict[str, float]]:
    """Normalise to a list of {key: fraction}; a mapping of 1-D arrays gives one per entry."""
    if isinstance(partition, Collision):
        return [partition.fractions]
    if isinstance(partition, Mapping) or hasattr(partition, "columns"):  # a SweepTable too
        arrays = {k: np.atleast_1d(np.asarray(partition[k], float)) for k in FRACTION_KEYS}
        n = len(arrays[FRACTION_KEYS[0]])
        return [{k: float(arrays[k][i]) for k in FRACTION_KEYS} for i in range(n)]
    return [p for item in partition for p in _partitions(item)]


def plot_partition(
    partition: Partition | Sequence[Partition],
    path: str | Path | None = None,
    *,
    labels: Sequence[str] | None = None,
    title: str = "final energy partition",
    ax=None,
) -> Figure:
    """Stacked bars of the final energy partition (fractions of K0), one bar per run.

    **Arguments:**
    - `partition`: a `Collision`, a mapping key -> fraction (as `Collision.fractions` or
      `msfd_jax.fractions` of a vmapped solution, whose 1-D arrays give one bar per entry),
      or a sequence of these.
    - `path`: if given, the figure is also saved there.
      A `SweepTable` gives one bar per row, labelled by the inputs that vary.
    - `labels`: one label per bar (e.g. the swept parameter's values).
    - `ax`: draw on these axes (a new figure if None).
    """
    rows = _partitions(partition)
    if labels is None and hasattr(partition, "columns"):
        labels = _table_labels(partition)
    labels = [str(i) for i in range(len(rows))] if labels is None else list(labels)
    if len(labels) != len(rows):
        raise ValueError(f"labels has {len(labels)} entries for {len(rows)} partitions")
    fig, ax = _axes(ax, (7.5, 1.6 + 0.55 * len(rows)))
    y = np.arange(len(rows))[::-1]
    left = np.zeros(len(rows))
    for key in FRACTION_KEYS:
        width = np.array([r[key] for r in rows])
        if not np.any(width > 0):
            continue
        ax.barh(y, width, left=left, color=COLOURS[key], label=LABELS[key], height=0.7)
        for yi, li, wi in zip(y, left, width, strict=True):
            if wi >= 0.04:
                ax.text(li + wi / 2, yi, f"{100 * wi:.0f}%", ha="center", va="center", fontsize=8)
        left = left + width
    ax.set_yticks(y, labels)
    ax.set_xlim(0.0, max(1.0, math.ceil(left.max() * 20) / 20))
    ax.set(xlabel=r"fraction of $K_0$", title=title)
    if ax.figure.get_layout_engine() is not None and ax is fig.axes[0] and len(fig.axes) == 1:
        fig.legend(loc="outside lower center", ncols=4, fontsize="small")
    else:
        ax.legend(fontsize="small", ncols=2)
    return _save(fig, path)


def _table_labels(table) -> list[str]:
    from ._sweeps.sweep import INPUTS

    varying = [k for k in INPUTS if k in table.keys() and np.unique(table[k]).size > 1]
    return [
        ", ".join(f"{k} = {float(table[k][i]):.3g}" for k in varying) or str(i)
        for i in range(len(table))
    ]


def plot_sweep(table, path: str | Path | None = None) -> Figure:
    """The final partition against the swept input: stacked fractions of K0 over the one input
    that varies (SI inputs preferred, as `si_*`), one panel per axial constraint when both are
    swept; failed rows are marked, not drawn as data. A sweep over several inputs, or a list,
    gets `plot_partition`'s bars, one per row.
    """
    from ._sweeps.sweep import INPUTS

    names = [k for k in table.keys() if k.startswith("si_")] or [
        k for k in INPUTS if k in table.keys()
    ]
    varying = [
        k for k in names if k != "axial_constraint" and np.unique(np.asarray(table[k])).size > 1
    ]
    if len(varying) != 1:
        return plot_partition(table, path)
    x_name = varying[0]
    held = np.asarray(table["axial_constraint"], float)
    groups = [v for v in (1.0, 0.0) if np.any(held == v)]
    fig = _Figure(figsize=(6.5 * len(groups), 4.5), layout="constrained")
    failed = np.asarray(table.failed, bool)
    for ax, value in zip(np.atleast_1d(fig.subplots(1, len(groups))), groups, strict=True):
        rows = np.flatnonzero((held == value) & ~failed)
        rows = rows[np.argsort(np.asarray(table[x_name], float)[rows])]
        x = np.asarray(table[x_name], float)[rows]
        shares = [np.asarray(table[k], float)[rows] for k in FRACTION_KEYS]
        ax.stackplot(x, *shares, colors=[COLOURS[k] for k in FRACTION_KEYS], alpha=0.85,
                     labels=[LABELS[k] for k in FRACTION_KEYS])  # fmt: skip
        bad = np.flatnonzero((held == value) & failed)
        if bad.size:
            ax.plot(np.asarray(table[x_name], float)[bad], np.zeros(bad.size), "rx", ms=8,
                    clip_on=False, label="failed run (not data)")  # fmt: skip
        unit = x_name.removeprefix("si_")
        ax.set(xlabel=unit, ylabel=r"fraction of $K_0$", ylim=(0.0, 1.0),
               title=f"axially {'constrained' if value else 'free'} beam")  # fmt: skip
        ax.grid(alpha=0.3)
    fig.axes[0].legend(fontsize="small", loc="best")
    return _save(fig, path)
