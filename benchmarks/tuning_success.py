"""Success rate of `optimise.tune` from several starts to targets across the achievable range.

For the free and the axially constrained beam (otherwise the paper's showcase: E/Y = 500,
R/h_r = 10, g = 10, v0 = 0.82, L_b = 3R, until settled), on a coarse mesh (`MESH`, the
quickstart notebook's: the paper's mesh costs 25-60 s per tuning on this shared 2-core machine):

1. the sharp beam share on a grid of h_b/h_r in [0.5, 5] (its achievable range, and where it
   jumps);
2. tuning (forward mode, default annealing, tolerance 0.01 K0) from each start in `STARTS` to
   each target at `FRACTIONS` of the way from the smallest to the largest share of the grid;
   whether the gradient steps alone met it or the bracketing safeguard was needed;
3. two unreachable targets per beam (0.05 K0 beyond each end of the range) and the message.

Writes benchmarks/results/tuning_success.md.

    python benchmarks/tuning_success.py
    python benchmarks/tuning_success.py --quick   # held beam, 5-point grid, one target, one start
"""

from __future__ import annotations

import argparse
import platform
import time

import _bench
import jax
import numpy as np

import msfd_jax as m
import optimise as o

MESH = m.Mesh(ring_segments=8, beam_contact_segments=10, beam_outer_segments=3)
STARTS = (0.5, 1.5, 3.0, 5.0)
FRACTIONS = (0.1, 0.3, 0.5, 0.7, 0.9)
GRID = np.linspace(0.5, 5.0, 19)
TOLERANCE = 0.01


def _beam(fractions) -> float:
    return float(fractions["beam_bending"]) + float(fractions["beam_axial"])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    _bench.add_quick(parser)
    args = parser.parse_args()
    beams = ((0.0, "free beam"), (1.0, "axially constrained beam"))
    grid, fractions, starts = GRID, FRACTIONS, STARTS
    if args.quick:
        beams, grid, fractions, starts = beams[1:], np.linspace(0.5, 5.0, 5), (0.5,), (2.5,)
    start_all = time.perf_counter()
    box = o.default_box(o.Design(thickness_ratio=2.5))
    lines = [
        "# optimise: tuning success from several starts (coarse mesh, until settled)",
        "",
        f"Produced by `python benchmarks/tuning_success.py{' --quick' * args.quick}`; "
        f"jax {jax.__version__}, "
        f"{platform.machine()}; mesh {MESH.ring_segments} ring segments, "
        f"{MESH.beam_contact_segments} + {MESH.beam_outer_segments} beam segments (the paper's: "
        "15, 20 + 5); the showcase otherwise (g = 10, v0 = 0.82), default `Settings`; forward "
        f"mode, default annealing stages, tolerance {TOLERANCE} K0 on the sharp model; h_b/h_r "
        "in [0.5, 5].",
        "",
        "Columns: `gradient` = met by the annealed gradient steps alone; `bracketing` = the "
        "gradient steps stalled and the sharp-model regula falsi (`tune(..., bracket=12)`) met "
        "it; evaluations = sharp evaluations (each gradient step adds one jvp).",
    ]
    summary = []
    for constraint, label in beams:
        params = m.CollisionParams(axial_constraint=constraint)
        problem = o.make_problem(params, MESH, m.Settings(), box)
        goal0 = o.objective(o.TargetShare("beam", 0.5))
        shares = [
            _beam(o.evaluate(o.Design(thickness_ratio=h), problem, goal0).fractions) for h in grid
        ]
        lo, hi = min(shares), max(shares)
        lines += [
            "",
            f"## {label}",
            "",
            "Sharp beam share over h_b/h_r: "
            + ", ".join(f"{h:.2f}: {s:.3f}" for h, s in zip(grid, shares, strict=True))
            + f". Range [{lo:.4f}, {hi:.4f}].",
            "",
            "| start h_b/h_r | target | status | by | evaluations | found h_b/h_r | sharp beam "
            "share | miss [K0] | wall [s] |",
            "|---|---|---|---|---|---|---|---|---|",
        ]
        counts = {"converged": 0, "gradient": 0, "runs": 0}
        for fraction in fractions:
            target = round(lo + fraction * (hi - lo), 4)
            goal = o.objective(o.TargetShare("beam", target))
            for start in starts:
                r = o.tune(o.Design(thickness_ratio=start), problem, goal, box=box, progress=None)
                by = "-" if r.status != "converged" else (
                    "bracketing" if r.bracketing_steps else "gradient"
                )  # fmt: skip
                counts["runs"] += 1
                counts["converged"] += r.status == "converged"
                counts["gradient"] += by == "gradient"
                lines.append(
                    f"| {start:g} | {target:.4f} | {r.status} | {by} | {r.iterations} | "
                    f"{r.design.as_floats()['thickness_ratio']:.4f} | {_beam(r.fractions):.4f} | "
                    f"{r.violation:.4f} | {r.wall_time_s:.1f} |"
                )
        summary.append((label, counts))
        lines += [
            "",
            f"Converged {counts['converged']} of {counts['runs']} ({counts['gradient']} by the "
            "gradient steps alone).",
            "",
            "Targets 0.05 K0 beyond the range of the grid (start 2.5; the sharp share is jagged, "
            "so the grid may miss a design that reaches one):",
            "",
        ]
        for target in (round(hi + 0.05, 4), round(lo - 0.05, 4)):
            if target < 0 or args.quick:
                continue
            goal = o.objective(o.TargetShare("beam", target))
            r = o.tune(o.Design(thickness_ratio=2.5), problem, goal, box=box, progress=None)
            lines.append(
                f"- target {target:.4f}: status `{r.status}` after {r.iterations} evaluations "
                f'({r.wall_time_s:.1f} s): "{r.message}"'
            )
    lines += ["", "## Summary", ""]
    for label, c in summary:
        lines.append(
            f"- {label}: {c['converged']}/{c['runs']} converged, {c['gradient']}/{c['runs']} by "
            "the gradient steps alone."
        )
    lines += ["", f"Total wall time {time.perf_counter() - start_all:.0f} s."]
    _bench.write_result("tuning_success.md", lines, args.quick)


if __name__ == "__main__":
    main()
