"""Bias of yield and contact smoothing on the energy partition (issue 4), base case.

Runs the paper's mesh and settings (until settled) at a few beam thickness ratios, sharp and
with the smoothing levels of `optimise.DEFAULT_STAGES` (and each switch alone), and writes the
change of the beam, ring and contact shares (K0) to benchmarks/results/smoothing_bias.md.

    python benchmarks/smoothing_bias.py
    python benchmarks/smoothing_bias.py --quick   # h_b/h_r = 2.5, two levels, coarse mesh
"""

from __future__ import annotations

import argparse
import platform
import time

import _bench
import jax

import msfd_jax as m
import optimise as o

THICKNESS = (1.0, 2.5, 4.0)
LEVELS = [(s.yield_smoothing, s.contact_smoothing) for s in o.DEFAULT_STAGES]
LEVELS += [(0.05, 0.0), (0.0, 0.01)]  # each switch alone
SHARES = ("beam", "ring", "contact")
APOSTROPHE = "'"
QUICK_MESH = m.Mesh(ring_segments=8, beam_contact_segments=10, beam_outer_segments=3)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    _bench.add_quick(parser)
    args = parser.parse_args()
    thickness, levels = ((2.5,), LEVELS[:2]) if args.quick else (THICKNESS, LEVELS)
    mesh = QUICK_MESH if args.quick else m.Mesh()
    base = m.CollisionParams()
    design = o.Design(thickness_ratio=2.5)
    box = o.default_box(design)
    problem = o.make_problem(base, mesh, m.Settings(), box)
    goal = o.objective(o.TargetShare("beam", 0.6))
    start = time.perf_counter()
    rows = []
    for h in thickness:
        point = o.Design(thickness_ratio=h)
        sharp = o.evaluate(point, problem, goal)
        ref = {s: float(o.share(sharp.fractions, s)) for s in SHARES}
        rows.append((h, 0.0, 0.0, ref, {s: 0.0 for s in SHARES}, int(sharp.result)))
        for ys, cs in levels:
            ev = o.evaluate(point, problem, goal, yield_smoothing=ys, contact_smoothing=cs)
            val = {s: float(o.share(ev.fractions, s)) for s in SHARES}
            rows.append((h, ys, cs, val, {s: val[s] - ref[s] for s in SHARES}, int(ev.result)))
    wall = time.perf_counter() - start
    lines = [
        "# Smoothing bias on the energy partition (base case, "
        f"{'a coarse' if args.quick else 'the paper' + APOSTROPHE + 's'} mesh, until settled)",
        "",
        f"Produced by `python benchmarks/smoothing_bias.py{' --quick' if args.quick else ''}`"
        f" ({wall:.0f} s; jax "
        f"{jax.__version__}, {platform.machine()}). Shares are fractions of K0; bias = smoothed"
        " minus sharp at the same design. `s`: yield smoothing (fraction of the yield value),"
        " `w`: contact smoothing (units of R).",
        "",
        "| h_b/h_r | s | w | beam | ring | contact | bias beam | bias ring | bias contact |"
        " result |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for h, ys, cs, val, bias, code in rows:
        lines.append(
            f"| {h:g} | {ys:g} | {cs:g} | {val['beam']:.4f} | {val['ring']:.4f} | "
            f"{val['contact']:.4f} | {bias['beam']:+.4f} | {bias['ring']:+.4f} | "
            f"{bias['contact']:+.4f} | {m.RESULT_NAMES[code]} |"
        )
    worst = {}
    for ys, cs in levels:
        worst[(ys, cs)] = max(
            abs(b[s]) for h, y, c, v, b, _ in rows if (y, c) == (ys, cs) for s in SHARES
        )
    lines += ["", "Largest |bias| over the thicknesses and shares, per level:", ""]
    lines += [f"- s = {ys:g}, w = {cs:g}: {w:.4f} K0" for (ys, cs), w in worst.items()]
    _bench.write_result("smoothing_bias.md", lines, args.quick)


if __name__ == "__main__":
    main()
