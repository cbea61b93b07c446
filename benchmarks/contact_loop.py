"""The two contact loops side by side in a sweep's segments (issue 11, goals 2 and 6).

``Settings.contact_loop`` chooses how the ring-beam contact skips its blocks out of reach
(`msfd_jax._pruning`): ``"blocks"`` gives every block a conditional; ``"listed"`` lists the
near blocks and visits only them in a while loop. This script times one sweep segment
(``_queue._segment``: 64 diffrax steps of 8 Verlet steps, the stopping rule included) of B =
32 collisions drawn from goal 2's grid (`sweep_budget.GRID`: h_b/h_r 0.25-5, free/held,
g = 5-40, v0 = 0.6, 0.82), on the paper's mesh x1, x2, x4, after 2, 8 and 24 segments (early
contact, contact, late contact with some slots stopped), with each loop, in turn round after
round (best round kept), on one core. The end states of the two loops are compared.

    python benchmarks/contact_loop.py   # writes benchmarks/results/contact_loop.md

Re-executes itself under ``taskset -c 0`` when available (MSFD_BENCH_CORE picks the core).
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime
import itertools
import os

import _bench
import numpy as np
from sweep_budget import GRID

SLOTS = 32
SEGMENT = 64


def states(mesh, seed: int, marks: tuple[int, ...]):
    """Yield (segments done, flat, clock, y, settings) for SLOTS collisions of the grid."""
    import jax.numpy as jnp

    from msfd_jax import _queue, _sweep
    from msfd_jax._params import CollisionParams
    from msfd_jax._shard import _critical_chunk

    rows = list(itertools.product(*GRID.values()))
    pick = np.random.default_rng(seed).choice(len(rows), SLOTS, replace=False)
    chosen = np.array([rows[i] for i in pick])
    base = CollisionParams().as_arrays()
    fields = {
        f.name: jnp.full(SLOTS, float(getattr(base, f.name)))
        for f in dataclasses.fields(CollisionParams)
    }
    for i, k in enumerate(GRID):
        fields[k] = jnp.asarray(chosen[:, i])
    p = CollisionParams(**fields)
    settings = _sweep._sweep_settings(_sweep.SWEEP_SETTINGS, mesh)
    settings = dataclasses.replace(settings, max_steps=1 << 24)
    dt_crit, _, _ = _critical_chunk(p, mesh, (0.0, 0.0))
    smoothing = _queue.with_flags((0.0, 0.0))
    flat, clock, y = _queue._start(
        p, dt_crit, mesh, smoothing, settings, jnp.full(SLOTS, 1e9), jnp.ones(SLOTS)
    )
    done = 0
    for mark in marks:
        for _ in range(mark - done):
            y = _queue._segment(flat, clock, y, settings, SEGMENT)
        done = mark
        yield mark, flat, clock, y, settings


def near_counts(flat, y, blocks_shape, listed_shape):
    from msfd_jax import _pruning

    p = flat.pairs[0]
    xa, xb = y.x[p.a : p.a + p.n_a], y.x[p.b : p.b + p.n_b]
    gap = flat.gap[0]
    near_b = sum(bool(n) for *_, n in _pruning.near_blocks(xa, xb, gap, blocks_shape))
    count, order, rows, cols = _pruning.near_list(xa, xb, gap, listed_shape)
    n_b = -(-p.n_a // blocks_shape[0]) * -(-p.n_b // blocks_shape[1])
    return (near_b, n_b), (int(count), len(rows[0]) * len(cols[0]))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--factors", nargs="+", type=int, default=[1, 2, 4])
    parser.add_argument("--marks", nargs="+", type=int, default=[2, 8, 24])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--rounds", type=int, default=5)
    args = parser.parse_args()
    _bench.pin()
    import jax

    jax.config.update("jax_enable_x64", True)
    import jax.numpy as jnp

    from msfd_jax import _pruning, _queue

    rows = []
    for factor in args.factors:
        mesh = _bench.scaled_mesh(factor)
        for mark, flat, clock, y, settings in states(mesh, args.seed, tuple(args.marks)):
            loops = {}
            for loop in ("blocks", "listed"):
                s = dataclasses.replace(settings, contact_loop=loop)
                loops[loop] = (
                    lambda f, c, q, s=s: _queue._segment(f, c, q, s, SEGMENT),
                    flat,
                    clock,
                    y,
                )
            ends = {k: f(*a) for k, (f, *a) in loops.items()}
            diff = float(jnp.max(jnp.abs(ends["blocks"].x - ends["listed"].x)))
            best = _bench.interleaved_best(loops, args.rounds)
            p = flat.pairs[0]
            shapes = (
                _pruning.contact_blocks(p.n_a, p.n_b, SLOTS),
                _pruning.listed_blocks(p.n_a, p.n_b, SLOTS),
            )
            (nb, tb), (nl, tl) = near_counts(flat, y, *shapes)
            steps = SEGMENT * settings.substeps * SLOTS
            rows.append(
                dict(
                    factor=factor, mark=mark, running=int(SLOTS - np.sum(np.asarray(y.done))),
                    pairs=(p.n_a, p.n_b), shapes=shapes, near=((nb, tb), (nl, tl)),
                    blocks=1e6 * best["blocks"] / steps, listed=1e6 * best["listed"] / steps,
                    diff=diff,
                )
            )  # fmt: skip
            print(rows[-1], flush=True)
    date = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")
    lines = [
        "# The contact loops in a sweep's segments: conditional per block against listed "
        "near blocks (issue 11)",
        "",
        f"`python benchmarks/contact_loop.py` · {date} · core(s) "
        f"{sorted(os.sched_getaffinity(0))} · jax {jax.__version__} · B = {SLOTS} collisions "
        f"of goal 2's grid (seed {args.seed}), one segment ({SEGMENT} diffrax steps of 8 "
        f"Verlet steps) after the segments given, best of {args.rounds} interleaved rounds",
        "",
        "µs per collision-step; near: near blocks / blocks in that state (the union over the "
        "batch)",
        "",
        "| mesh | pairs | after segments (running) | blocks: shape, near | listed: shape, near "
        "| blocks µs | listed µs | blocks / listed | max |x| difference at the end |",
        "|---|---|---|---|---|---:|---:|---:|---:|",
    ]
    for r in rows:
        (nb, tb), (nl, tl) = r["near"]
        sb, sl = r["shapes"]
        lines.append(
            f"| x{r['factor']} | {r['pairs'][0]} x {r['pairs'][1]} | {r['mark']} "
            f"({r['running']}) | {sb[0]} x {sb[1]}, {nb}/{tb} | {sl[0]} x {sl[1]}, {nl}/{tl} "
            f"| {r['blocks']:.3f} | {r['listed']:.3f} | {r['blocks'] / r['listed']:.2f} "
            f"| {r['diff']:.1e} |"
        )
    lines += [
        "",
        "Reading: a far block costs the listed loop its box test alone but a conditional "
        "a branch and its part of the permanent set; a near block costs the listed loop "
        "a while-loop iteration (its nested executors, slices and in-place updates). The "
        "listed loop wins where most blocks are far (large meshes, early contact) and loses "
        "where many small blocks are near (the paper's mesh in wide contact).",
    ]
    _bench.write_result("contact_loop.md", lines)


if __name__ == "__main__":
    main()
