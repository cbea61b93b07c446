"""What XLA:CPU costs for the parts of one Verlet substep, against issue 11's budgets.

Goals 1 and 3 of issue 11 ask the pure-JAX core for a third of the numba reference's time per
collision-step (goal 1: in a sweep; goal 3: one collision). This script measures, side by side
in one process on one core (interleaved rounds, the best kept), the numba reference's cost per
step on the showcase and the XLA:CPU cost of

- the whole substep of the batched core (`_engine.verlet_substep`), B = 1 and B = 32;
- the same substep with the contact left out (a scene with no contact set: chains, return
  mappings and Verlet alone);
- the dense ring-on-beam contact alone (16 x 21 pairs: approach, law, forces) as a standalone
  loop, B = 1 (with the trailing batch axis, and with no batch axis at all, so that XLA may
  vectorise over the pairs) and B = 32.

Each is compared with the budget numba / 3: a part that alone costs more than the budget
shows that the goal cannot be met by rearranging the rest.

    python benchmarks/xla_floor.py            # writes benchmarks/results/xla_floor.md

Re-executes itself under ``taskset -c 0`` when available (MSFD_BENCH_CORE picks the core).
"""

from __future__ import annotations

import dataclasses
import datetime
import os
import time
from pathlib import Path

import _bench

RESULTS = Path(__file__).resolve().parent / "results"
STEPS = 1000


def _contact_loop(steps: int):
    """A compiled loop of the dense contact: one collision's pairs (n_a, n_b) with no batch
    axis, or B collisions' (n_a, n_b, B) with the batch last."""
    import jax
    import jax.numpy as jnp

    from msfd_jax._laws import contact_spring

    def forces(xa, xb, ps, gap, k, fy):
        dx = xa[:, None, 0] - xb[None, :, 0]
        dy = xa[:, None, 1] - xb[None, :, 1]
        sq = dx * dx + dy * dy
        apart = sq > 0
        dist = jnp.where(apart, jnp.sqrt(jnp.where(apart, sq, 1.0)), 0.0)
        f, ps1, dc = contact_spring(gap - dist, ps, k, fy, None)
        c = jnp.where(apart, f / jnp.where(apart, dist, 1.0), 0.0)
        fx, fy_ = c * dx, c * dy
        fa = jnp.stack([jnp.sum(fx, axis=1), jnp.sum(fy_, axis=1)], axis=1)
        fb = -jnp.stack([jnp.sum(fx, axis=0), jnp.sum(fy_, axis=0)], axis=1)
        return fa, fb, ps1, jnp.sum(dc, axis=(0, 1))

    @jax.jit
    def run(xa, xb, ps, gap, k, fy):
        def body(i, carry):
            xa, xb, ps, d = carry
            fa, fb, ps1, dc = forces(xa, xb, ps, gap, k, fy)
            return xa + 1e-9 * fa, xb + 1e-9 * fb, ps1, d + dc

        d = jnp.zeros(xa.shape[2:])
        return jax.lax.fori_loop(0, steps, body, (xa, xb, ps, d))

    return run


def _without_contact(flat, y):
    """The scene and state with the contact sets left out (no pair arrays, no pair code)."""
    import equinox as eqx

    none = ()
    flat = dataclasses.replace(flat, pairs=none, gap=none, stiffness=none, yield_force=none)
    return flat, eqx.tree_at(lambda s: s.permanent_set, y, none)


def main() -> None:
    _bench.pin()
    import equinox as eqx
    import jax
    import jax.numpy as jnp
    from numba_reference import Reference

    import msfd_jax as m
    from msfd_jax import _engine
    from msfd_jax._flat import batch_scenes
    from msfd_jax._scene import _ring_on_beam

    jax.config.update("jax_enable_x64", True)
    ref = Reference(m.ring_on_beam(), m.Settings(t_max=10.0))
    ref.compile()
    best = float("inf")
    for _ in range(5):
        tick = time.perf_counter()
        out = ref()
        best = min(best, time.perf_counter() - tick)
    numba_us = 1e6 * best / out["steps"]
    budget = numba_us / 3.0
    zero = jnp.zeros(())
    build = eqx.filter_jit(
        lambda p: batch_scenes(
            jax.vmap(lambda q: _ring_on_beam(q, m.Mesh(), zero, zero, (False, False)))(p)
        )
    )
    programs, per = {}, {}
    for b in (1, 32):
        flat = build(_bench.batch_params(b))
        y = _engine.initial_state(flat)
        h, tol = jnp.full((b,), 2e-4), jnp.full((b,), 1e-9)
        warm = _bench.substep_loop(3000, h, tol)(flat, y)  # into the impact: pairs in contact
        loop = _bench.substep_loop(STEPS, h, tol)
        programs[f"substep, B = {b}"] = (loop, flat, warm)
        per[f"substep, B = {b}"] = b
        bare = _without_contact(flat, warm)
        programs[f"substep without contact, B = {b}"] = (loop, *bare)
        per[f"substep without contact, B = {b}"] = b
        p = flat.pairs[0]
        xa, xb = warm.x[p.a : p.a + p.n_a], warm.x[p.b : p.b + p.n_b]
        args = (warm.permanent_set[0], flat.gap[0], flat.stiffness[0], flat.yield_force[0])
        programs[f"dense contact alone, B = {b}"] = (_contact_loop(STEPS), xa, xb, *args)
        per[f"dense contact alone, B = {b}"] = b
        if b == 1:
            squeezed = [a[..., 0] for a in (xa, xb, *args)]
            name = "dense contact alone, no batch axis"
            programs[name] = (_contact_loop(STEPS), *squeezed)
            per[name] = 1
    times = _bench.interleaved_best(programs, 7)
    rows = []
    for name, t in times.items():
        us = 1e6 * t / STEPS / per[name]
        rows.append((name, us, us / budget))
        print(f"{name}: {us:.3f} us per collision-step, {us / budget:.2f} x the budget")
    date = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")
    lines = [
        "# XLA:CPU's cost of the substep's parts against issue 11's budgets",
        "",
        f"`python benchmarks/xla_floor.py` · {date} · core(s) {sorted(os.sched_getaffinity(0))}"
        f" · jax {jax.__version__} · paper mesh, sharp laws, best of 7 interleaved rounds",
        "",
        f"numba reference, showcase: **{numba_us:.3f} µs/step**; budget of goals 1 and 3 "
        f"(a third): **{budget:.3f} µs per collision-step**.",
        "",
        "| part | µs per collision-step | x the budget |",
        "|---|---:|---:|",
    ]
    lines += [f"| {n} | {us:.3f} | {r:.2f} |" for n, us, r in rows]
    lines += [
        "",
        "A part that alone costs more than the budget cannot be brought under it by",
        "rearranging the others: the dense contact alone, at B = 1 even without the batch axis",
        "(XLA's vector code then may run over the pairs), is the floor of goal 3; at B = 32 the",
        "contact alone and the substep without contact each sit at or above the budget of",
        "goal 1.",
    ]
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "xla_floor.md").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
