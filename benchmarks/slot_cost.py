"""Cost of one Verlet substep of the batched core against the slot count (issue 11).

Paper mesh, sharp laws (as sweeps compile them), B = 1, 2, 4, 8, 16, 32, 64 collisions (h_b/h_r
0.5-4, held, g = 10, v0 = 0.82), one core: each B's compiled ``fori_loop`` of `--steps`
substeps is timed in turn, round after round (interleaved, so a noisy neighbour weighs on all
alike), and the best round is kept. This is what `_queue.MIN_SLOTS`, `_queue.TAIL_SLOTS`
and `_queue.DEFAULT_SLOTS` are chosen from.

    python benchmarks/slot_cost.py            # writes benchmarks/results/slot_cost.md

Re-executes itself under ``taskset -c 0`` when available (MSFD_BENCH_CORE picks the core).
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime
import os
import sys
from pathlib import Path

import _bench

RESULTS = Path(__file__).resolve().parent / "results"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--slots", nargs="+", type=int, default=[1, 2, 4, 8, 16, 32, 64])
    parser.add_argument("--steps", type=int, default=500)
    parser.add_argument("--rounds", type=int, default=9)
    args = parser.parse_args()
    _bench.pin()
    import jax
    import jax.numpy as jnp

    import msfd_jax as m
    from msfd_jax import _queue, _sweep

    settings = dataclasses.replace(_sweep.SWEEP_SETTINGS, t_max=10.0)
    programs = {}
    for b in args.slots:
        smoothing = _queue.with_flags((0.0, 0.0))
        start = (_bench.batch_params(b), jnp.full(b, 3e-4), m.Mesh(), smoothing, settings, 10**6)
        flat, clock, y = _queue._start(*start)
        f = _bench.substep_loop(args.steps, jnp.full(b, 2e-4), clock.tolerance)
        programs[b] = (f, flat, y)
    best = _bench.interleaved_best(programs, args.rounds)
    date = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")
    lines = [
        "# Substep cost against the slot count (issue 11)",
        "",
        f"`python benchmarks/slot_cost.py {' '.join(sys.argv[1:])}`".replace(" `", "`")
        + f" · {date} · core(s) {sorted(os.sched_getaffinity(0))} · jax {jax.__version__} · "
        f"paper mesh, sharp laws, best of {args.rounds} interleaved rounds of {args.steps} "
        "substeps",
        "",
        "| slots B | µs / substep | µs / collision-step |",
        "|---:|---:|---:|",
    ]
    for b, t in best.items():
        lines.append(f"| {b} | {t / args.steps * 1e6:.1f} | {t / args.steps / b * 1e6:.3f} |")
        print(lines[-1])
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "slot_cost.md").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
