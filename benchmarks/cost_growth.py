"""How the cost of a collision grows with the mesh (issue 11, goal 6).

The paper mesh refined x1, x2, x4 (every segment count times f): for each, the showcase
collision's Verlet steps (`run`, default settings: the step follows the stability limit, so
it shrinks as the mesh is refined) and the batched core's cost per collision-step at B = 32
slots (a `fori_loop` of substeps of 32 showcase-like collisions, sharp laws, as sweeps compile
it; the meshes timed in turn, round after round, best round kept). Cost per collision = steps x
cost per collision-step. Goal 6: it grows no faster than nodes x steps (contact work
proportional to nodes). The contact is pruned (`_batched.pruning.contact_blocks`: blocks out
of reach skipped), so the substeps are timed from half-way through the collision, where the
contact is engaged; before the pruning they were timed from the first touch and the dense contact
(ring nodes x beam contact nodes pairs) grew as nodes^2. Both contact loops
(``Settings.contact_loop``) are timed: "blocks" (a conditional per block, `simulate`'s
default) and "listed" (the near blocks only, the sweeps' default).

    python benchmarks/cost_growth.py           # writes benchmarks/results/cost_growth.md

Re-executes itself under ``taskset -c 0`` when available (MSFD_BENCH_CORE picks the core).
"""

from __future__ import annotations

import argparse
import datetime
import os
import sys

import _bench


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--factors", nargs="+", type=int, default=[1, 2, 4])
    parser.add_argument("--slots", type=int, default=32)
    parser.add_argument("--steps", type=int, default=300)
    parser.add_argument("--rounds", type=int, default=5)
    _bench.add_quick(parser)
    args = parser.parse_args()
    if args.quick:
        args.factors, args.steps, args.rounds = [1, 2], 50, 1
    _bench.pin()
    import jax

    b = args.slots
    rows, programs = [], {}
    for f in args.factors:
        mesh = _bench.scaled_mesh(f)
        dt, steps = _bench.showcase_steps(mesh)
        # timed from half-way through the collision: the pruned contact's cost depends on
        # the state (at the start the ring touches the beam at one node)
        flat, clock, y, h = _bench.half_way(mesh, b, dt, steps)
        for listed in (False, True):
            loop = _bench.substep_loop(args.steps, h, clock.tolerance, listed=listed)
            programs[f, listed] = (loop, flat, y)
        pairs = sum(q.n_a * q.n_b for q in flat.pairs if hasattr(q, "n_b"))
        rows.append(dict(f=f, nodes=flat.n_nodes, pairs=pairs, steps=steps))
        print(f"mesh x{f}: {flat.n_nodes} nodes, {pairs} contact pairs, showcase {steps} steps")
    best = _bench.interleaved_best(programs, args.rounds)
    first = rows[0]
    for row in rows:
        for listed in (False, True):
            us = best[row["f"], listed] / args.steps / b * 1e6
            row[listed] = (us, us * row["steps"] * 1e-3)
    date = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")
    lines = [
        "# Cost growth with the mesh (issue 11, goal 6)",
        "",
        f"`python benchmarks/cost_growth.py {' '.join(sys.argv[1:])}`".replace(" `", "`")
        + f" · {date} · core(s) {sorted(os.sched_getaffinity(0))} · jax {jax.__version__} · "
        f"B = {b} slots, best of {args.rounds} interleaved rounds of {args.steps} substeps "
        "from half-way through the collision; "
        "steps: the showcase collision's at the default step",
        "",
        "| mesh | nodes | contact pairs | showcase steps | contact loop | µs / collision-step "
        "| ms / collision | cost growth | nodes x steps growth | cost / (nodes x steps) |",
        "|---|---:|---:|---:|---|---:|---:|---:|---:|---:|",
    ]
    for listed in (False, True):
        for row in rows:
            us, ms = row[listed]
            growth = ms / first[listed][1]
            work = row["nodes"] * row["steps"] / (first["nodes"] * first["steps"])
            lines.append(
                f"| x{row['f']} | {row['nodes']} | {row['pairs']} | {row['steps']} | "
                f"{'listed' if listed else 'blocks'} | {us:.3f} | {ms:.1f} | "
                f"{growth:.2f} | {work:.2f} | {growth / work:.2f} |"
            )
            print(lines[-1])
    lines += [
        "",
        "Goal 6: the last column stays at about 1 (cost proportional to nodes x steps).",
        "",
    ]
    (_bench.results_dir(args.quick) / "cost_growth.md").write_text("\n".join(lines))


if __name__ == "__main__":
    main()
