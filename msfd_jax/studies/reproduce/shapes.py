"""Fig. 13 and 14: shapes at the paper's instants, the contact pairs over time, "U" vs "W" rings.

Fig. 13 is g = 10, v0 = 0.82, h_b/h_r = 2.5 with the beam axially constrained; Fig. 14 the final
rings of h_b/h_r = 1 ("U") and 2 ("slightly W"), same g, v0 and constraint.

The shape measure. In our coordinates the beam lies on y = 0 and the ring comes from below
(its apex S, node 0, points in +y, towards the beam). The paper's "U" is a ring whose bottom
has been flattened against the beam between two near-vertical columns: the apex is (one of)
the ring points pushed farthest towards the beam. Its "W" is a ring whose apex has been pushed
back, away from the beam, between two lobes that carry the contact: the apex lies behind the
lobes. So we measure the **dimple depth**

    w = (max_i y_i - y_S) / R  >= 0   over the final ring nodes i,

how far the apex lies behind the ring's foremost point, and call the ring "U" when w < 0.1 h_r/R
(a tenth of the ring's thickness: node-level ripple of a flat bottom), "slightly W" when w is
below the ring thickness h_r/R, and "W" beyond. The thresholds are scales of the section, set
before looking at the runs.

`compute_fig13_14` runs the collisions and measures them, `draw_fig13_14` renders the two
figures, `table_fig13_14` and `judge_fig13_14` write the table and the verdicts from the
numbers alone; `reproduce` composes them.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from . import _batch as b
from ._common import Finding, Reproduction, compose

TITLE = "Fig. 13-14: shapes, contact pairs and the 'U' vs 'W' final ring (g = 10, v0 = 0.82)"
SHOWCASE = 2.5  # Fig. 13
FIG14 = (1.0, 2.0)  # Fig. 14a ("U") and 14b ("slightly W")


def dimple_depth(ring_xy: np.ndarray) -> float:
    """w = (max_i y_i - y_apex) / R of the ring's nodes (apex = node 0): 0 for a "U"."""
    y = np.asarray(ring_xy)[:, 1]
    return float(np.max(y) - y[0])


def classify(w: float, slenderness: float = 10.0) -> str:
    """ "U", "slightly W" or "W" from the dimple depth (thresholds 0.1 and 1 ring thickness)."""
    thickness = 1.0 / slenderness  # h_r / R
    if w < 0.1 * thickness:
        return "U"
    return "slightly W" if w < thickness else "W"


def sweep_thickness(quick: bool) -> np.ndarray:
    return np.array([0.5, 1.0, 2.0, 3.0, 4.0, 5.0]) if quick else np.linspace(0.5, 5.0, 10)


def contact_track(run: b.Run) -> dict[str, np.ndarray]:
    """Per history sample: the outermost and innermost ring / beam node in contact (-1: none)."""
    pairs = run.history["contact_pairs"]  # (samples, ring nodes, beam nodes)
    ring_on = pairs.any(2)
    beam_on = pairs.any(1)

    def extent(on, reduce):
        idx = np.where(on, np.arange(on.shape[1]), -1 if reduce is np.max else on.shape[1])
        out = reduce(idx, axis=1)
        return np.where(on.any(1), out, -1)

    return dict(
        ring_outer=extent(ring_on, np.max),
        ring_inner=extent(ring_on, np.min),
        beam_outer=extent(beam_on, np.max),
        beam_inner=extent(beam_on, np.min),
    )


def _mirrored(ax, xy: np.ndarray, **kwargs) -> None:
    full = np.concatenate([xy[::-1] * [-1.0, 1.0], xy[1:]])
    ax.plot(full[:, 0], full[:, 1], **kwargs)


def _shape_at(run: b.Run, t: float) -> list[np.ndarray] | None:
    if t > run.t_end:
        return None
    i = int(np.argmin(np.abs(run.shape_ts - t)))
    return [s[i] for s in run.shapes]


def _draw(ax, chains: list[np.ndarray], title: str) -> None:
    # drawn upside down (-y): the ring above the beam, moving down, as in the paper's figures
    for xy, colour in zip(chains, ("tab:red", "tab:blue"), strict=True):
        xy = xy * np.array([1.0, -1.0])
        _mirrored(ax, xy, color=colour, lw=1.4)
        ax.plot(xy[:, 0], xy[:, 1], "o", color=colour, ms=2)
    ax.set_aspect("equal")
    ax.set_xlim(-1.6, 1.6)
    ax.set_ylim(-0.6, 1.3)
    ax.set_title(title, fontsize=9)
    ax.grid(alpha=0.3)


def plot_fig13(run: b.Run):
    """Fig. 13a-d (shapes at the paper's instants), the final shape and the contact pairs."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(14, 6.5), layout="constrained")
    top, bottom = fig.subfigures(2, 1, height_ratios=(1.0, 1.1))
    axes = top.subplots(1, 5)
    labels = "abcd"
    for ax, t, label in zip(axes[:4], b.PAPER_SHAPE_TIMES, labels, strict=True):
        chains = _shape_at(run, t)
        if chains is None:
            ax.set_axis_off()
            continue
        _draw(ax, chains, rf"({label}) $\tau$ = {t:g}")
    w = dimple_depth(run.final[b.RING])
    _draw(axes[4], run.final, rf"final, $\tau$ = {run.t_end:.2f}: w = {w:.3f} ({classify(w)})")
    ax_pairs, ax_track = bottom.subplots(1, 2)
    pairs = run.history["contact_pairs"]
    step, ring, beam = np.nonzero(pairs)
    last = run.ts[step].max() if step.size else run.t_end
    points = ax_pairs.scatter(beam, ring, c=run.ts[step], s=12, cmap="viridis", vmax=last)
    bottom.colorbar(points, ax=ax_pairs, label=r"$\tau$")
    ax_pairs.set(
        xlabel="beam node (0 = mid-span O)",
        ylabel="ring node (0 = apex S)",
        title="(e) contact node pairs, coloured by time",
    )
    ax_pairs.grid(alpha=0.3)
    track = contact_track(run)
    on = track["ring_outer"] >= 0
    for key, style in (  # ring drawn 0.1 above, beam 0.1 below the index, to tell them apart
        ("ring_inner", ("tab:red", "v", 0.1)),
        ("ring_outer", ("tab:red", "^", 0.1)),
        ("beam_inner", ("tab:blue", "v", -0.1)),
        ("beam_outer", ("tab:blue", "^", -0.1)),
    ):
        ax_track.plot(
            run.ts[on],
            track[key][on] + style[2],
            style[1],
            color=style[0],
            ms=2,
            label=key.replace("_", " "),
        )
    ax_track.set(
        xlabel=r"$\tau$",
        ylabel="node index in contact",
        title="(e') innermost and outermost contact nodes against time",
        xlim=(0, last * 1.05),
    )
    ax_track.legend(fontsize=8, markerscale=3)
    ax_track.grid(alpha=0.3)
    fig.suptitle(
        f"Fig. 13: h_b/h_r = {run.params['thickness_ratio']:g}, g = 10, v0 = 0.82, beam "
        "axially constrained (ring red, beam blue, mirrored about x = 0; drawn with the ring above)"
    )
    return fig


def plot_fig14(cases: list[b.Run], sweep: list[b.Run]):
    """Fig. 14's final rings and the dimple depth against h_b/h_r."""
    from matplotlib.figure import Figure

    # titles on two lines and a wider figure: on one line a title was cut off at 14 in
    fig = Figure(figsize=(4.2 * len(cases) + 5.0, 4.6), layout="constrained")
    axes = fig.subplots(1, len(cases) + 1, width_ratios=[1.0] * len(cases) + [1.2])
    for ax, run in zip(axes[:-1], cases, strict=True):
        w = dimple_depth(run.final[b.RING])
        _draw(
            ax,
            run.final,
            f"h_b/h_r = {run.params['thickness_ratio']:g}\nw = {w:.3f} ({classify(w)})",
        )
    ax = axes[-1]
    h = np.array([r.params["thickness_ratio"] for r in sweep])
    w = np.array([dimple_depth(r.final[b.RING]) for r in sweep])
    ring = np.array([r.energy("ring")[-1] for r in sweep])
    ax.plot(h, w, "ko-", ms=4, label="dimple depth w = (max y - y_S)/R")
    ax.axhline(0.01, color="0.5", ls=":", lw=1)
    ax.axhline(0.1, color="0.5", ls="--", lw=1)
    ax.text(h[0], 0.012, "U | slightly W (0.1 h_r/R)", fontsize=7)
    ax.text(h[0], 0.105, "slightly W | W (h_r/R)", fontsize=7)
    ax.plot(h, ring, "s-", color="tab:red", ms=3, label="ring share of K0")
    ax.set(xlabel="$h_b/h_r$", title="'U' to 'W' against beam thickness\n(constrained)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.suptitle("Fig. 14: final rings (g = 10, v0 = 0.82, beam axially constrained)")
    return fig


def describe(run: b.Run) -> dict:
    """One run's row of the report: shape, shares, contact extent and times."""
    w = dimple_depth(run.final[b.RING])
    track = contact_track(run)
    on = track["ring_outer"] >= 0
    apex = run.history["contact_pairs"][:, 0, :].any(1)
    return dict(
        thickness_ratio=run.params["thickness_ratio"],
        status=run.status,
        t_end=run.t_end,
        dimple_depth=w,
        shape=classify(w, run.params["slenderness"]),
        ring=float(run.energy("ring")[-1]),
        beam=float(run.energy("beam")[-1]),
        apex_last_contact=float(run.ts[apex].max()) if apex.any() else float("nan"),
        ring_node_max=int(track["ring_outer"].max()),
        beam_node_max=int(track["beam_outer"].max()),
        last_contact=float(run.ts[on].max()) if on.any() else float("nan"),
    )


def contact_drift(run: b.Run) -> dict[str, float]:
    """The innermost ring node in contact, averaged over the first and the last 0.1 of contact."""
    track = contact_track(run)
    on = track["ring_outer"] >= 0
    ts = run.ts[on]
    early = ts <= ts[0] + 0.1
    late = ts >= ts[-1] - 0.1
    return dict(
        inner_early=float(np.mean(track["ring_inner"][on][early])),
        inner_late=float(np.mean(track["ring_inner"][on][late])),
    )


def compute_fig13_14(quick: bool) -> dict:
    """The Fig. 13 and 14 cases and the sweep of h_b/h_r (constrained), run and measured.

    ``cases`` and ``sweep`` are `describe`'s rows (the published numbers), ``drift`` is
    `contact_drift` of Fig. 13's case and ``runs`` the runs themselves (for the figures).
    """
    thickness = sweep_thickness(quick)
    cases = (SHOWCASE, *FIG14)
    rows = [dict(thickness_ratio=h, axial_constraint=1.0) for h in (*cases, *thickness)]
    runs = b.histories(rows, quick)
    return dict(
        cases=[describe(r) for r in runs[:3]],
        sweep=[describe(r) for r in runs[3:]],
        drift=contact_drift(runs[0]),
        runs=dict(showcase=runs[0], fig14=runs[1:3], sweep=runs[3:]),
    )


def draw_fig13_14(numbers: dict, figures_dir: Path) -> list[str]:
    """``fig13.png`` (Fig. 13's case over time) and ``fig14.png`` (final rings, U to W)."""
    runs = numbers["runs"]
    return [
        b.save(plot_fig13(runs["showcase"]), figures_dir, "fig13.png"),
        b.save(
            plot_fig14([*runs["fig14"], runs["showcase"]], runs["sweep"]), figures_dir, "fig14.png"
        ),
    ]


HEADER = [
    "h_b/h_r",
    "w = (max y - y_S)/R",
    "shape",
    "ring",
    "beam",
    "apex S last in contact (tau)",
    "outermost ring / beam node in contact",
    "last contact (tau)",
    "tau end",
    "status",
]


def _line(d: dict) -> tuple:
    return (
        f"{d['thickness_ratio']:g}",
        f"{d['dimple_depth']:.3f}",
        d["shape"],
        d["ring"],
        d["beam"],
        f"{d['apex_last_contact']:.3f}",
        f"{d['ring_node_max']} / {d['beam_node_max']}",
        f"{d['last_contact']:.3f}",
        f"{d['t_end']:.2f}",
        d["status"],
    )


def table_fig13_14(numbers: dict) -> str:
    """The markdown tables of the cases and of the sweep."""
    return "\n".join(
        [
            "Dimple depth w (see `msfd_jax/studies/reproduce/shapes.py`): 'U' when w < 0.1 h_r/R = "
            "0.01, 'slightly W' when w < h_r/R = 0.1, 'W' beyond. Ring / beam: their plastic "
            "dissipation, fractions of K0. Nodes are numbered from the mid-points (0 = apex S, "
            "mid-span O), as in Fig. 13e.",
            "",
            "Fig. 13 and 14 cases:",
            "",
            b.table(HEADER, [_line(d) for d in numbers["cases"]]),
            "",
            "Sweep of h_b/h_r (beam axially constrained):",
            "",
            b.table(HEADER, [_line(d) for d in numbers["sweep"]]),
        ]
    )


def reproduce(quick: bool, figures_dir: Path) -> Reproduction:
    return compose(
        "fig13_14",
        TITLE,
        quick,
        figures_dir,
        compute=compute_fig13_14,
        draw=draw_fig13_14,
        table=table_fig13_14,
        judge=judge_fig13_14,
        publish=lambda n: b.jsonable({"cases": n["cases"], "sweep": n["sweep"]}),
    )


def judge_fig13_14(numbers: dict) -> list[Finding]:
    """The verdicts on Fig. 13e, 14a-b and Sect. 4.2's U-to-W statement."""
    show, u_case, w_case = numbers["cases"]
    sweep = numbers["sweep"]
    inner_early, inner_late = numbers["drift"]["inner_early"], numbers["drift"]["inner_late"]
    out = [
        Finding(
            "Fig. 13e",
            "the contact region moves away from the mid-points of the ring and the beam, "
            "and the half ring finally deforms into a 'W'",
            f"h_b/h_r = 2.5: innermost ring node in contact {inner_early:.1f} (mean over the "
            f"first 0.1 of contact) -> {inner_late:.1f} (last 0.1); the apex S leaves the beam "
            f"for good at tau = {show['apex_last_contact']:.3f}; final w = "
            f"{show['dimple_depth']:.3f} ({show['shape']})",
            bool(inner_late > inner_early and show["shape"] == "W"),
            "the thick constrained beam stops the apex while the flanks, carried by the block, "
            "keep going: the contact moves out to two lobes and the apex is pushed back",
        ),
        Finding(
            "Fig. 14a",
            "h_b/h_r = 1 (g = 10, constrained): a 'U'-shaped final ring",
            f"w = {u_case['dimple_depth']:.4f} ({u_case['shape']})",
            u_case["shape"] == "U",
            "the thin beam yields (mostly in stretching) and wraps the ring, whose bottom stays "
            "flat between two columns",
        ),
        Finding(
            "Fig. 14b",
            "h_b/h_r = 2 (g = 10, constrained): a slightly 'W'-shaped final ring",
            f"w = {w_case['dimple_depth']:.4f} ({w_case['shape']})",
            w_case["shape"] == "slightly W",
            "between the two: the apex is pushed back by less than the ring's thickness",
        ),
    ]
    h = np.array([d["thickness_ratio"] for d in sweep])
    w = np.array([d["dimple_depth"] for d in sweep])
    ring = np.array([d["ring"] for d in sweep])
    shapes = [d["shape"] for d in sweep]
    first_w = next((f"{hh:g}" for hh, s in zip(h, shapes, strict=True) if s == "W"), "none")
    last_u = max((hh for hh, s in zip(h, shapes, strict=True) if s == "U"), default=float("nan"))
    out.append(
        Finding(
            "Sect. 4.2",
            "with a stiffer beam the final ring changes from a 'U' to a 'W', and the ring "
            "dissipates more",
            f"w from {w[0]:.3f} (h_b/h_r = {h[0]:g}) to {w[-1]:.3f} ({h[-1]:g}); last 'U' at "
            f"{last_u:g}, first 'W' at {first_w}; w rises in {int(np.sum(np.diff(w) > 0))} of "
            f"{len(w) - 1} steps; ring share {ring[0]:.3f} -> {ring[-1]:.3f}",
            bool(shapes[0] == "U" and shapes[-1] == "W" and ring[-1] > ring[0]),
            "a stiffer beam deflects less, so the ring's apex is stopped and the ring folds "
            "around it (W) instead of being carried into a wrapping beam (U)",
        )
    )
    return out
