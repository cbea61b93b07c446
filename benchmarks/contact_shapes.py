"""The pruned contact's block shape at 4x the paper's mesh (issue 11, goal 6).

B = 32 showcase-like collisions advanced to half of the showcase's steps on the mesh x4; the
substep timed (best of 5 interleaved rounds, one core) with the engine's block shape replaced
by each of a few shapes, with the number of blocks near in this state and the pairs they
hold (the pairs a substep evaluates).

    python benchmarks/contact_shapes.py     # writes benchmarks/results/contact_shapes.md
"""

from __future__ import annotations

import datetime
import os

import _bench

B = 32
STEPS = 300
SHAPES = ((16, 17), (8, 17), (4, 17), (8, 9), (4, 9), (16, 9))


def main() -> None:
    _bench.pin()
    import jax

    jax.config.update("jax_enable_x64", True)
    from msfd_jax import _engine, _pruning

    mesh = _bench.scaled_mesh(4)
    flat, clock, y, h = _bench.half_way(mesh, B, *_bench.showcase_steps(mesh))
    pair = flat.pairs[0]
    xa, xb = y.x[pair.a : pair.a + pair.n_a], y.x[pair.b : pair.b + pair.n_b]
    chosen, programs, rows = _engine.contact_blocks, {}, []
    for shape in SHAPES:
        near = [bool(n) for *_, n in _pruning.near_blocks(xa, xb, flat.gap[0], shape)]
        rows.append((shape, len(near), sum(near), sum(near) * shape[0] * shape[1]))
        _engine.contact_blocks = lambda n_a, n_b, batch, s=shape: s
        programs[shape] = (_bench.substep_loop(STEPS, h, clock.tolerance), flat, y)
        jax.block_until_ready(programs[shape][0](flat, y))  # traced with this shape
    _engine.contact_blocks = chosen
    best = _bench.interleaved_best(programs, 5)
    date = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")
    lines = [
        "# Block shape of the pruned contact at 4x the paper's mesh (issue 11, goal 6)",
        "",
        f"`python benchmarks/contact_shapes.py` · {date} · core(s) "
        f"{sorted(os.sched_getaffinity(0))} · jax {jax.__version__} · B = {B}, "
        f"{pair.n_a} x {pair.n_b} pairs, best of 5 interleaved rounds of {STEPS} substeps "
        f"from half-way through a showcase-like collision; the engine's shape is "
        f"{chosen(pair.n_a, pair.n_b, B)}",
        "",
        "| block | blocks | near | pairs evaluated | µs per collision-step |",
        "|---|---:|---:|---:|---:|",
    ]
    for shape, n, near, pairs in rows:
        us = 1e6 * best[shape] / STEPS / B
        lines.append(f"| {shape[0]} x {shape[1]} | {n} | {near} | {pairs} | {us:.3f} |")
    _bench.write_result("contact_shapes.md", lines)


if __name__ == "__main__":
    main()
