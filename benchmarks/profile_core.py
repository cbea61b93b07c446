"""Where the batched core's time goes (issue 11): cost per collision-step of its parts.

Paper mesh, B collisions (h_b/h_r 0.5-4), one core: the whole Verlet substep, the forces
alone (`_engine.respond`), the dense contact alone, and the per-element cost of XLA's
``atan2`` against the core's vectorisable one and a few other operations.

    python benchmarks/profile_core.py [--batch 64]   # writes benchmarks/results/profile_core.md
"""

from __future__ import annotations

import argparse
import datetime
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

RESULTS = Path(__file__).resolve().parent / "results"
N = 2000


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--batch", type=int, default=64)
    args = parser.parse_args()
    if not os.environ.get("MSFD_BENCH_PINNED") and shutil.which("taskset"):
        env = dict(os.environ, MSFD_BENCH_PINNED="1")
        raise SystemExit(
            subprocess.call(["taskset", "-c", "0", sys.executable, *sys.argv], env=env)
        )
    import equinox as eqx
    import jax
    import jax.numpy as jnp

    import msfd_jax as m
    from msfd_jax import _engine
    from msfd_jax._flat import batch_scenes
    from msfd_jax._laws import contact_spring
    from msfd_jax._safe import atan2
    from msfd_jax._scene import _ring_on_beam

    b = args.batch
    p = m.CollisionParams(**{
        "thickness_ratio": jnp.linspace(0.5, 4.0, b), "axial_constraint": jnp.ones(b),
        "mass_ratio": jnp.full(b, 10.0), "velocity": jnp.full(b, 0.82),
        "modulus_ratio": jnp.full(b, 500.0), "slenderness": jnp.full(b, 30.0),
        "span_ratio": jnp.full(b, 5.0), "width_ratio": jnp.ones(b),
    })  # fmt: skip
    zero = jnp.zeros(())
    build = eqx.filter_jit(
        # zero smoothing known ahead, as sweeps pass it: the sharp laws alone (static flags)
        lambda p: batch_scenes(
            jax.vmap(lambda q: _ring_on_beam(q, m.Mesh(), zero, zero, (False, False)))(p)
        )
    )
    flat = build(p)
    y = _engine.initial_state(flat)
    h, tol = jnp.full(b, 5e-5), jnp.full(b, 1e-5)

    def substep(flat, y):
        return jax.lax.fori_loop(
            0, N, lambda i, s: _engine.verlet_substep(flat, s, i * h, h, tol), y
        )

    def forces(flat, y):
        def body(i, x):
            r = _engine.respond(flat, x, y.plastic_rotation, y.plastic_strain, y.permanent_set)
            return x + 1e-9 * r.forces

        return jax.lax.fori_loop(0, N, body, y.x)

    def contact(flat, y):
        q = flat.pairs[0]

        def body(i, x):
            xa, xb = x[q.a : q.a + q.n_a], x[q.b : q.b + q.n_b]
            d = xa[:, None] - xb[None]
            dist = jnp.sqrt(jnp.sum(d * d, axis=2))
            f, _, _ = contact_spring(
                flat.gap[0][None, None] - dist, y.permanent_set[0], flat.stiffness[0],
                flat.yield_force[0], flat.contact_smoothing[None, None],
            )  # fmt: skip
            fa = jnp.sum((f / dist)[:, :, None] * d, axis=1)
            return x.at[q.a : q.a + q.n_a].add(1e-9 * fa)

        return jax.lax.fori_loop(0, N, body, y.x)

    rows = []
    for name, fn in (("Verlet substep", substep), ("forces (respond)", forces),
                     ("dense contact alone", contact)):  # fmt: skip
        f = eqx.filter_jit(fn)
        jax.block_until_ready(f(flat, y))
        tick = time.perf_counter()
        jax.block_until_ready(f(flat, y))
        us = (time.perf_counter() - tick) / N / b * 1e6
        rows.append((name, f"{us:.3f} µs per collision-step"))
        print(name, rows[-1][1])
    a = jax.random.normal(jax.random.PRNGKey(0), (40, b))
    c = jax.random.normal(jax.random.PRNGKey(1), (40, b))
    for name, op in (("jnp.arctan2 (XLA)", jnp.arctan2), ("_safe.atan2", atan2),
                     ("multiply-add", lambda x, z: x * z + x),
                     ("sqrt", lambda x, z: jnp.sqrt(x * x + z * z)),
                     ("exp", lambda x, z: jnp.exp(x))):  # fmt: skip
        loop = jax.jit(lambda a, c, op=op: jax.lax.fori_loop(
            0, N, lambda i, s: (op(s[0], s[1]) * 1e-9 + s[0], s[1]), (a, c))[0])  # fmt: skip
        jax.block_until_ready(loop(a, c))
        tick = time.perf_counter()
        jax.block_until_ready(loop(a, c))
        ns = (time.perf_counter() - tick) / N / a.size * 1e9
        rows.append((name, f"{ns:.1f} ns per element"))
        print(name, rows[-1][1])
    date = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")
    lines = [
        "# Batched core: where the time goes (issue 11)",
        "",
        f"`python benchmarks/profile_core.py --batch {b}` · {date} · one core · paper mesh, "
        f"B = {b}",
        "",
        "| part | cost |",
        "|---|---:|",
        *[f"| {n} | {v} |" for n, v in rows],
        "",
    ]
    (RESULTS / "profile_core.md").write_text("\n".join(lines))


if __name__ == "__main__":
    main()
