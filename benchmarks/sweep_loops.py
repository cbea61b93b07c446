"""A whole sweep with each contact loop, side by side on one core (issue 11, goal 2).

`contact_loop.py` times single segments; this runs the same collisions through
``msfd_jax.sweep`` (one worker, 32 slots, the queue with its refills, retries and tail) with
``Settings.contact_loop`` "blocks" and "listed" in turn, `--repeats` times each (the first of
each compiles; run times exclude compilation, `_sweep.LAST_TIMING`), and compares the tables.
The collisions: `--count` drawn from goal 2's grid (`sweep_budget.GRID`, seed 0), on the
paper's mesh times `--factor`.

    python benchmarks/sweep_loops.py                 # writes benchmarks/results/sweep_loops.md
    python benchmarks/sweep_loops.py --count 64 --factor 2

Re-executes itself under ``taskset -c 0`` when available (MSFD_BENCH_CORE picks the core).
"""

from __future__ import annotations

import argparse
import datetime
import itertools
import os

import _bench
import numpy as np
from sweep_budget import GRID

COLUMNS = ("beam_bending", "beam_axial", "ring_bending", "ring_axial", "contact", "t_end")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, default=192)
    parser.add_argument("--factor", type=int, default=1)
    parser.add_argument("--repeats", type=int, default=2)
    args = parser.parse_args()
    _bench.pin()
    import jax

    jax.config.update("jax_enable_x64", True)
    import msfd_jax as m
    from msfd_jax import _sweep

    rows = [dict(zip(GRID, v, strict=True)) for v in itertools.product(*GRID.values())]
    pick = np.random.default_rng(0).choice(len(rows), args.count, replace=False)
    collisions = [rows[i] for i in pick]
    mesh = _bench.scaled_mesh(args.factor)
    runs: dict[str, list[float]] = {"blocks": [], "listed": []}
    tables, steps = {}, {}
    for _ in range(args.repeats + 1):  # the first round compiles
        for loop in runs:
            settings = m.Settings(history_points=2, shape_times=(), contact_loop=loop)
            tables[loop] = m.sweep(collisions, mesh, settings, workers=1)
            timing = _sweep.LAST_TIMING
            runs[loop].append(timing["run_s"])
            steps[loop] = timing["steps"]
            print(loop, timing, flush=True)
    best = {k: min(v[1:]) for k, v in runs.items()}
    diff = {c: float(np.max(np.abs(tables["blocks"][c] - tables["listed"][c]))) for c in COLUMNS}
    same_steps = bool(np.array_equal(tables["blocks"]["steps"], tables["listed"]["steps"]))
    date = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")
    per = {k: 1e6 * best[k] / steps[k] for k in best}
    lines = [
        "# A sweep with each contact loop, side by side (issue 11)",
        "",
        f"`python benchmarks/sweep_loops.py --count {args.count} --factor {args.factor}` · "
        f"{date} · core(s) {sorted(os.sched_getaffinity(0))} · jax {jax.__version__} · "
        f"{args.count} collisions of goal 2's grid (seed 0), paper mesh x{args.factor}, one "
        f"worker of 32 slots, best of {args.repeats} runs each (compilation apart)",
        "",
        "| contact loop | run s (each run) | Verlet steps | µs per collision-step |",
        "|---|---|---:|---:|",
    ]
    for k in runs:
        each = ", ".join(f"{v:.1f}" for v in runs[k][1:])
        lines.append(f"| {k} | {each} | {steps[k]:,} | {per[k]:.3f} |")
    lines += [
        "",
        f"blocks / listed: **{per['blocks'] / per['listed']:.2f}**. Same step counts row by "
        f"row: {same_steps}; largest difference of the tables: "
        + ", ".join(f"{c} {v:.1e}" for c, v in diff.items())
        + " (fractions of K0; t_end in tau).",
    ]
    suffix = "" if args.factor == 1 else f"_x{args.factor}"
    _bench.write_result(f"sweep_loops{suffix}.md", lines)


if __name__ == "__main__":
    main()
