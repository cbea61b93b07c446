"""Cost of one Verlet substep of the batched core against the slot count (issue 11).

Paper mesh, sharp laws (as sweeps compile them), B = 8, 16, 32, 64 collisions (h_b/h_r
0.5-4, held, g = 10, v0 = 0.82), one core: each B's compiled ``fori_loop`` of `--steps`
substeps is timed in turn, round after round (interleaved, so a noisy neighbour weighs on all
alike), and the best round is kept. This is what `_queue.MIN_SLOTS` and
`_queue.DEFAULT_SLOTS` are chosen from.

    python benchmarks/slot_cost.py            # writes benchmarks/results/slot_cost.md

Re-executes itself under ``taskset -c 0`` when available (MSFD_BENCH_CORE picks the core).
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

RESULTS = Path(__file__).resolve().parent / "results"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--slots", nargs="+", type=int, default=[8, 16, 32, 64])
    parser.add_argument("--steps", type=int, default=500)
    parser.add_argument("--rounds", type=int, default=9)
    args = parser.parse_args()
    if not os.environ.get("MSFD_BENCH_PINNED") and shutil.which("taskset"):
        env = dict(os.environ, MSFD_BENCH_PINNED="1")
        core = os.environ.get("MSFD_BENCH_CORE", "0")
        command = ["taskset", "-c", core, sys.executable, *sys.argv]
        raise SystemExit(subprocess.call(command, env=env))
    import equinox as eqx
    import jax
    import jax.numpy as jnp

    import msfd_jax as m
    from msfd_jax import _engine, _queue, _sweep

    settings = dataclasses.replace(_sweep.SWEEP_SETTINGS, t_max=10.0)
    programs = {}
    for b in args.slots:
        p = m.CollisionParams(**{
            "thickness_ratio": jnp.linspace(0.5, 4.0, b), "axial_constraint": jnp.ones(b),
            "mass_ratio": jnp.full(b, 10.0), "velocity": jnp.full(b, 0.82),
            "modulus_ratio": jnp.full(b, 500.0), "slenderness": jnp.full(b, 30.0),
            "span_ratio": jnp.full(b, 5.0), "width_ratio": jnp.ones(b),
        })  # fmt: skip
        smoothing = _queue.with_flags((0.0, 0.0))
        flat, clock, y = _queue._start(p, jnp.full(b, 3e-4), m.Mesh(), smoothing, settings, 10**6)
        h = jnp.full(b, 2e-4)

        def loop(flat, y, h=h, tol=clock.tolerance):
            body = lambda i, s: _engine.verlet_substep(flat, s, i * h, h, tol)  # noqa: E731
            return jax.lax.fori_loop(0, args.steps, body, y)

        f = eqx.filter_jit(loop)
        jax.block_until_ready(f(flat, y))
        programs[b] = (f, flat, y)
    best = dict.fromkeys(programs, float("inf"))
    for _ in range(args.rounds):
        for b, (f, flat, y) in programs.items():
            tick = time.perf_counter()
            jax.block_until_ready(f(flat, y))
            best[b] = min(best[b], time.perf_counter() - tick)
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
