"""A whole sweep with each contact loop, side by side on one core (issue 11, goal 2).

`contact_loop.py` times single segments; this runs the same collisions through
``msfd_jax.sweep`` (one worker, 32 slots, the queue with its refills, retries and tail) with
``Settings.contact_loop`` "blocks" and "listed" in turn, `--repeats` times each (the first of
each compiles; run times exclude compilation, `SweepTable.timing`), and compares the tables.
The collisions: `--count` drawn from goal 2's grid (`_bench.GRID`, seed 0), on the
paper's mesh times `--factor`.

    python benchmarks/sweep_loops.py --count 192 --factor 1   # each factor's section of
    python benchmarks/sweep_loops.py --count 64 --factor 2    # benchmarks/results/sweep_loops.md
    python benchmarks/sweep_loops.py --count 64 --factor 4    # (the section replaced, or added)
    python benchmarks/sweep_loops.py --quick                  # 8 collisions, one run each

Re-executes itself under ``taskset -c 0`` when available (MSFD_BENCH_CORE picks the core).
"""

from __future__ import annotations

import argparse
import datetime
import itertools
import os

import _bench
import numpy as np

COLUMNS = ("beam_bending", "beam_axial", "ring_bending", "ring_axial", "contact", "t_end")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, default=192)
    parser.add_argument("--factor", type=int, default=1)
    parser.add_argument("--repeats", type=int, default=2)
    _bench.add_quick(parser)
    args = parser.parse_args()
    if args.quick:
        args.count, args.factor, args.repeats = 8, 1, 1
    _bench.pin()
    import jax

    jax.config.update("jax_enable_x64", True)
    import msfd_jax as m

    grid = _bench.GRID
    rows = [dict(zip(grid, v, strict=True)) for v in itertools.product(*grid.values())]
    pick = np.random.default_rng(0).choice(len(rows), args.count, replace=False)
    collisions = [rows[i] for i in pick]
    mesh = _bench.scaled_mesh(args.factor)
    runs: dict[str, list[float]] = {"blocks": [], "listed": []}
    tables, steps = {}, {}
    for _ in range(args.repeats + 1):  # the first round compiles
        for loop in runs:
            settings = m.Settings(history_points=2, shape_times=(), contact_loop=loop)
            tables[loop] = m.sweep(collisions, mesh, settings, workers=1)
            timing = tables[loop].timing
            runs[loop].append(timing["run_s"])
            steps[loop] = timing["steps"]
            print(loop, timing, flush=True)
    best = {k: min(v[1:]) for k, v in runs.items()}
    diff = {c: float(np.max(np.abs(tables["blocks"][c] - tables["listed"][c]))) for c in COLUMNS}
    same_steps = bool(np.array_equal(tables["blocks"]["steps"], tables["listed"]["steps"]))
    date = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")
    per = {k: 1e6 * best[k] / steps[k] for k in best}
    lines = [
        f"## Paper mesh x{args.factor}",
        "",
        f"`python benchmarks/sweep_loops.py --count {args.count} --factor {args.factor}"
        f"{' --quick' if args.quick else ''}` · "
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
    _write_section(_bench.results_dir(args.quick) / "sweep_loops.md", args.factor, lines)


TITLE = "# A sweep with each contact loop, side by side (issue 11)"


def _write_section(path, factor: int, lines: list[str]) -> None:
    """Replace (or add) the section of mesh x`factor` in `path`, sections sorted by factor."""
    import re

    text = path.read_text() if path.exists() else TITLE + "\n"
    sections = dict(
        (int(m.group(1)), m.group(0).strip())
        for m in re.finditer(r"^## Paper mesh x(\d+)\n.*?(?=^## |\Z)", text, re.M | re.S)
    )
    sections[factor] = "\n".join(lines).strip()
    body = "\n\n".join(sections[k] for k in sorted(sections))
    path.write_text(f"{TITLE}\n\n{body}\n")
    print(sections[factor])


if __name__ == "__main__":
    main()
