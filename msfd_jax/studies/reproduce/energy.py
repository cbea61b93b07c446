"""Fig. 19 (energy histories, the restoring instant) and Fig. 20, 21, 23, 24 (the effects of the
attached mass and of the initial velocity on the partition).

The restoring instant (Sect. 4.3.2): "the instant at which the stiffer structure transforms
from an energy-dissipation state to a non-dissipation state". The stiffer structure is the one
that dissipates less in the end. We take t_R as the first instant after which it dissipates
less than 1 % of K0 more (D(t_end) - D(t_R) <= 0.01 K0); D_R = its dissipation at t_R (the
restoring energy), K_R the kinetic energy left then.

Cases: Fig. 19a h_b/h_r = 3, beam free; 19b h_b/h_r = 1.2, constrained; both g = 10,
v0 = 0.82. Fig. 20a h_b/h_r = 3, free: g from 1.5 to 25 at v0 = 0.82, v0 from 0.42 to 1.25 at
g = 10 (K0 from ~1 to ~9, the paper's axis); 20b the same case at a fixed K0 (Fig. 13's,
g = 10 and v0 = 0.82) with v0 from 0.3 to 1.8 (g = 2 K0 / v0^2 - pi/2). Fig. 21 h_b/h_r = 2.5,
constrained, K0 up to ~6. Fig. 23-24 h_b/h_r = 1, constrained, K0 up to ~25 (the runs of
Fig. 16).

`compute_fig19` runs and measures Fig. 19's cases, `draw_fig19` renders them, `table_fig19` and
`judge_fig19` write the table and the verdicts from the numbers alone; `reproduce_fig19`
composes them (Fig. 20-24: `mass_velocity`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from . import _batch as b
from ._common import Finding, Reproduction, compose

RESTORE_TOLERANCE = 0.01  # of K0, dissipated by the stiffer structure after t_R
FIG19 = (
    dict(thickness_ratio=3.0, axial_constraint=0.0),
    dict(thickness_ratio=1.2, axial_constraint=1.0),
)
HALF_PI = 0.5 * np.pi


def restoring(run: b.Run) -> dict:
    """The restoring instant and the energies of Eq. (26) for one run."""
    ring, beam = run.energy("ring"), run.energy("beam")
    stiffer = "ring" if ring[-1] < beam[-1] else "beam"
    softer = "beam" if stiffer == "ring" else "ring"
    d = run.energy(stiffer)
    i = int(np.argmax(d >= d[-1] - RESTORE_TOLERANCE))
    return dict(
        stiffer=stiffer,
        t_restore=float(run.ts[i]),
        d_stiffer=float(d[i]),
        d_stiffer_final=float(d[-1]),
        d_softer_at_restore=float(run.energy(softer)[i]),
        d_softer_final=float(run.energy(softer)[-1]),
        kinetic_at_restore=float(run.energy("kinetic")[i]),
        elastic_at_restore=float(run.energy("elastic")[i]),
        d_local=float(run.energy("contact")[-1]),
        t_local_90=_time_to_fraction(run.ts, run.energy("contact"), 0.9),
        kinetic_final=float(run.energy("kinetic")[-1]),
        t_end=run.t_end,
        status=run.status,
    )


def _time_to_fraction(ts: np.ndarray, energy: np.ndarray, fraction: float) -> float:
    """First tau at which a dissipated energy reaches `fraction` of its final value."""
    if energy[-1] <= 0:
        return float("nan")
    return float(ts[int(np.argmax(energy >= fraction * energy[-1]))])


def alternations(run: b.Run, window: float = 0.05) -> int:
    """How often the structure dissipating faster changes (rates averaged over `window`,
    counted only while the total plastic rate exceeds 0.05 K0 per unit tau and each spell
    lasts at least `window`): the 'steps' of Fig. 19b."""
    ts = run.ts
    dt = float(ts[1] - ts[0])
    n = max(int(round(window / dt)), 1)

    def rate(x):
        return np.gradient(np.convolve(x, np.ones(n) / n, mode="same"), dt)

    r, bm = rate(run.energy("ring")), rate(run.energy("beam"))
    active = (r + bm) > 0.05
    leader = np.where(r > bm, 1, -1)[active]
    if leader.size == 0:
        return 0
    changes = np.flatnonzero(np.diff(leader)) + 1
    spells = np.diff(np.concatenate([[0], changes, [leader.size]]))
    kept = leader[np.concatenate([[0], changes])][spells >= n]
    return int(np.sum(np.diff(kept) != 0))


def compute_fig19(quick: bool) -> dict:
    """`FIG19`'s runs: ``cases`` (parameters, `restoring`, `alternations`), the final ring and
    beam shares (``shares``) and the runs themselves (``runs``, for the figure)."""
    runs = b.histories(list(FIG19), quick)
    return dict(
        cases=[
            dict(run.params) | restoring(run) | {"alternations": alternations(run)} for run in runs
        ],
        shares=[{name: run_share(run, name) for name in ("ring", "beam")} for run in runs],
        runs=runs,
    )


def draw_fig19(numbers: dict, figures_dir: Path) -> list[str]:
    """``fig19.png``: each case's energy histories and its restoring instant."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(13, 4.5), layout="constrained")
    axes = fig.subplots(1, 2)
    for ax, run, r, label in zip(axes, numbers["runs"], numbers["cases"], "ab", strict=True):
        for key, style in (
            ("ring_bending", "r-"),
            ("ring_axial", "r:"),
            ("beam_bending", "b-"),
            ("beam_axial", "b:"),
            ("contact", "g-"),
            ("kinetic", "k--"),
            ("elastic", "m--"),
        ):
            ax.plot(run.ts, run.energy(key), style, lw=1.2, label=key.replace("_", " "))
        ax.plot(run.ts, run.energy("ring"), "r-", lw=2.5, alpha=0.4, label="ring")
        ax.plot(run.ts, run.energy("beam"), "b-", lw=2.5, alpha=0.4, label="beam")
        ax.axvline(r["t_restore"], color="0.3", ls="-.", lw=1)
        ax.annotate(
            f"restoring instant {r['t_restore']:.2f}",
            (r["t_restore"], 0.9),
            fontsize=8,
            xytext=(4, 0),
            textcoords="offset points",
        )
        p = run.params
        ax.set(
            xlabel=r"$\tau$",
            ylabel="fraction of $K_0$",
            title=f"({label}) h_b/h_r = {p['thickness_ratio']:g}, g = 10, "
            f"{b.constraint_name(p['axial_constraint'])}",
            ylim=(0, 1.02),
            xlim=(0, run.t_end),
        )
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, ncols=2)
    fig.suptitle("Fig. 19: energy histories (v0 = 0.82)")
    return [b.save(fig, figures_dir, "fig19.png")]


def table_fig19(numbers: dict) -> str:
    """The markdown table: restoring instant and energies per case."""
    return "\n".join(
        [
            f"Restoring instant t_R: first tau after which the stiffer structure (the one "
            f"dissipating less in the end) dissipates less than {RESTORE_TOLERANCE:g} K0 more. "
            "Fractions of K0. Alternations: changes of the structure dissipating faster "
            "(rates over 0.05 of tau, while the plastic rate exceeds 0.05 K0 per unit tau).",
            "",
            b.table(
                [
                    "case",
                    "stiffer",
                    "t_R",
                    "d_stiffer at t_R / final",
                    "softer at t_R / final",
                    "K_R",
                    "elastic at t_R",
                    "d_local",
                    "alternations",
                    "t_end",
                    "status",
                ],
                [
                    (
                        f"h_b/h_r = {s['thickness_ratio']:g}, "
                        f"{b.constraint_name(s['axial_constraint'])}",
                        s["stiffer"],
                        f"{s['t_restore']:.3f}",
                        f"{s['d_stiffer']:.3f} / {s['d_stiffer_final']:.3f}",
                        f"{s['d_softer_at_restore']:.3f} / {s['d_softer_final']:.3f}",
                        s["kinetic_at_restore"],
                        s["elastic_at_restore"],
                        f"{s['d_local']:.4f}",
                        s["alternations"],
                        f"{s['t_end']:.2f}",
                        s["status"],
                    )
                    for s in numbers["cases"]
                ],
            ),
        ]
    )


def judge_fig19(numbers: dict) -> list[Finding]:
    """The verdicts on Fig. 19a (restoring instant, what follows) and Fig. 19b (steps)."""
    a, c = numbers["cases"]
    c_shares = numbers["shares"][1]
    after = a["d_softer_final"] - a["d_softer_at_restore"]
    left = a["kinetic_at_restore"] + a["elastic_at_restore"] - a["kinetic_final"]
    return [
        Finding(
            "Fig. 19a",
            "h_b/h_r = 3, free: the ring (the stiffer structure) stops dissipating at the "
            "restoring instant tau ~ 0.75",
            f"stiffer: {a['stiffer']}; t_R = {a['t_restore']:.3f} (1 % K0 rule); ring "
            f"{a['d_stiffer']:.3f} K0 at t_R, {a['d_stiffer_final']:.3f} in the end",
            bool(a["stiffer"] == "ring" and abs(a["t_restore"] - 0.75) <= 0.25),
            "the ring's hinges stop once its velocity field is nearly uniform (rigid-body "
            "motion plus elastic vibration); tolerance 0.25 on tau set before the run "
            "(the paper's value is read from a curve and depends on the definition)",
        ),
        Finding(
            "Fig. 19a",
            "after the restoring instant the remaining kinetic energy is dissipated by the "
            "beam (the less stiff one)",
            f"K_R = {a['kinetic_at_restore']:.3f} K0 and elastic {a['elastic_at_restore']:.3f}"
            f" at t_R; the beam dissipates {after:.3f} K0 afterwards "
            f"({100 * after / left:.0f} % of what was left)",
            bool(after >= 0.8 * left),
            "Eq. (26c): d_softer = 1 - d_local - d_stiffer when the softer structure does "
            "not harden",
        ),
        Finding(
            "Fig. 19a",
            "the local contact dissipation is accomplished almost immediately",
            f"d_local = {a['d_local']:.4f} K0, 90 % of it reached at tau = "
            f"{a['t_local_90']:.3f} (t_R = {a['t_restore']:.3f})",
            bool(a["t_local_90"] <= 0.1 * a["t_restore"]),
            "the contact yields in the collision stage, while the apex and the beam's "
            "mid-point reach a common velocity; 'almost immediately' read as within a tenth "
            "of the restoring instant (set before the run)",
        ),
        Finding(
            "Fig. 19b",
            "h_b/h_r = 1.2, constrained: several steps, the ring and the beam dissipating "
            "alternately (over-hardening)",
            f"{c['alternations']} changes of the faster-dissipating structure; ring "
            f"{c_shares['ring']:.3f}, beam {c_shares['beam']:.3f} K0",
            bool(c["alternations"] >= 2),
            "the constrained beam hardens by stretching while the ring hardens as it "
            "flattens, so each in turn becomes the weaker",
        ),
    ]


def reproduce_fig19(quick: bool, figures_dir: Path) -> Reproduction:
    return compose(
        "fig19",
        "Fig. 19: energy histories and the restoring instant (g = 10, v0 = 0.82)",
        quick,
        figures_dir,
        compute=compute_fig19,
        draw=draw_fig19,
        table=table_fig19,
        judge=judge_fig19,
        publish=lambda n: b.jsonable({"cases": n["cases"]}),
    )


def run_share(run: b.Run, name: str) -> float:
    return float(run.energy(name)[-1])
