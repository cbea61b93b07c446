"""Pruned contact: the substep's cost against the contact's block shape (issue 11, goals 1, 3, 6).

For the paper mesh x1, x2, x4 and a few batch sizes: B showcase-like collisions (h_b/h_r 2-3,
held, g = 10) are advanced to half of the showcase's steps (contact engaged), then
`--steps` substeps from there are timed (interleaved rounds, best kept, one core) with

- the chosen blocks (`_pruning.contact_blocks`), far blocks skipped (the default);
- the same blocks, none skipped (`SKIP_FAR_BLOCKS` off: the cost of the blocking alone);
- the whole set as one block (the former dense evaluation's arithmetic, skipped only while
  ring and beam are apart in every collision);
- no contact at all (the floor the rest of the substep sets).

Each variant's end state is also compared with the chosen one's (max |x| difference).

    python benchmarks/contact_blocks.py   # writes benchmarks/results/contact_blocks.md
"""

from __future__ import annotations

import argparse
import datetime
import os
import sys
from pathlib import Path

import _bench

RESULTS = Path(__file__).resolve().parent / "results"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--factors", nargs="+", type=int, default=[1, 2, 4])
    parser.add_argument("--slots", nargs="+", type=int, default=[1, 32])
    parser.add_argument("--steps", type=int, default=400)
    parser.add_argument("--rounds", type=int, default=5)
    args = parser.parse_args()
    _bench.pin()
    import jax
    import jax.numpy as jnp

    from msfd_jax import _engine, _pruning

    chosen = _engine.contact_blocks
    variants = {
        "chosen blocks, far ones skipped": (chosen, True),
        "chosen blocks, none skipped": (chosen, False),
        "one block": (lambda n_a, n_b, batch: (n_a, n_b), True),
    }

    def no_contact(p, x, gap, k, fy, ps, blocks, width):
        z = jnp.zeros(x.shape[-1:])
        return jnp.zeros_like(x), ps, z, z

    programs, rows, checks = {}, [], []
    for f in args.factors:
        mesh = _bench.scaled_mesh(f)
        dt, steps = _bench.showcase_steps(mesh)
        for b in args.slots:
            flat, clock, y, h = _bench.half_way(mesh, b, dt, steps)  # contact engaged
            pair = flat.pairs[0]
            blocks = chosen(pair.n_a, pair.n_b, b)
            rows.append((f, b, flat.n_nodes, pair.n_a * pair.n_b, blocks))
            ends = {}
            for name, (rule, skip) in variants.items():
                _engine.contact_blocks, _pruning.SKIP_FAR_BLOCKS = rule, skip
                fn = _bench.substep_loop(args.steps, h, clock.tolerance)
                ends[name] = jax.block_until_ready(fn(flat, y)).x
                programs[(f, b, name)] = (fn, flat, y)
            _engine.contact_blocks, _pruning.SKIP_FAR_BLOCKS = chosen, True
            saved, _engine.blocked_pairs = _engine.blocked_pairs, no_contact
            programs[(f, b, "no contact")] = (
                _bench.substep_loop(args.steps, h, clock.tolerance),
                flat,
                y,
            )
            jax.block_until_ready(programs[(f, b, "no contact")][0](flat, y))
            _engine.blocked_pairs = saved
            first = ends["chosen blocks, far ones skipped"]
            checks.append((f, b, {k: float(jnp.max(jnp.abs(v - first))) for k, v in ends.items()}))
            print(f"x{f} B={b}: compiled; end-state differences {checks[-1][2]}", flush=True)
    best = _bench.interleaved_best(programs, args.rounds)
    names = [*variants, "no contact"]
    date = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")
    lines = [
        "# Pruned contact: substep cost against the block shape (issue 11)",
        "",
        f"`python benchmarks/contact_blocks.py {' '.join(sys.argv[1:])}`".replace(" `", "`")
        + f" · {date} · core(s) {sorted(os.sched_getaffinity(0))} · jax {jax.__version__} · "
        f"best of {args.rounds} interleaved rounds of {args.steps} substeps from half-way "
        "through a showcase-like collision (h_b/h_r 2-3, held, g = 10)",
        "",
        "µs per collision-step:",
        "",
        "| mesh | B | nodes | pairs | chosen blocks | " + " | ".join(names) + " |",
        "|---|---:|---:|---:|---|" + "---:|" * len(names),
    ]
    for f, b, nodes, pairs, blocks in rows:
        cells = [f"{best[(f, b, n)] / args.steps / b * 1e6:.3f}" for n in names]
        lines.append(
            f"| x{f} | {b} | {nodes} | {pairs} | {blocks[0]} x {blocks[1]} | "
            + " | ".join(cells)
            + " |"
        )
        print(lines[-1])
    lines += [
        "",
        "End state after the timed substeps, max |x| difference from the default (chosen "
        "blocks, far ones skipped): "
        + "; ".join(
            f"x{f} B={b}: " + ", ".join(f"{k} {v:.1e}" for k, v in d.items() if v or True)
            for f, b, d in checks
        ),
        "",
    ]
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "contact_blocks.md").write_text("\n".join(lines))


if __name__ == "__main__":
    main()
