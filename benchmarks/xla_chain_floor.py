"""The least an XLA:CPU substep can cost: a minimal chain, against issue 11's budget.

Goals 1 and 3 of issue 11 ask the pure-JAX core for a third of the numba reference's time per
collision-step. `xla_floor.py` measured the core's own parts; this script asks what *any*
pure-JAX formulation of the substep costs on XLA:CPU, by timing a deliberately minimal one:

- one free chain of 42 nodes (the paper mesh's ring and beam have 42 nodes together), 41 bars
  and 40 joints, float64, the batch on the last axis;
- the project's own laws (`_laws.elastic_plastic`, sharp) and vectorisable `_safe.atan2`,
  closed-form forces (Eq. 10), velocity Verlet; no contact, no second chain, no symmetric or
  clamped ends, no unwrapping, no energy bookkeeping, no stopping rule: strictly less work
  than the real substep, which has all of these;
- one compiled ``fori_loop`` of substeps, B = 1, 8, 32, 64 (and the same chain with the
  joint angle as a plain cross product, to show the atan2's share).

Side by side in the same process on one core: the numba reference on the showcase (the
budget is a third of its time per step), the same minimal chain as a plain numba loop, and
XLA:CPU's cost per element of a multiply-add, a division and `_safe.atan2` in a fused loop.

    python benchmarks/xla_chain_floor.py    # writes benchmarks/results/xla_chain_floor.md

Re-executes itself under ``taskset -c 0`` when available (MSFD_BENCH_CORE picks the core).
"""

from __future__ import annotations

import datetime
import os

import _bench

NODES = 42
STEPS = 1000
H = 2e-4
BATCHES = (1, 8, 32, 64)


def _constants(b: int):
    """A slightly bent chain at rest and its constants (unit masses), B copies."""
    import jax.numpy as jnp
    import numpy as np

    n = NODES
    s = np.linspace(0.0, 1.0, n)
    x = np.stack([s, 1e-3 * np.sin(3.0 * s)])  # (2, n)
    lane = 1.0 + 0.01 * np.arange(b) / max(b, 1)  # the lanes differ a little
    X = jnp.asarray(x[0][:, None] * lane)
    Y = jnp.asarray(x[1][:, None] * lane)
    VX = jnp.zeros((n, b))
    VY = jnp.asarray(np.full((n, b), -0.3) * np.sin(np.pi * s)[:, None])
    full = lambda m, v: jnp.full((m, b), v)  # noqa: E731
    consts = dict(
        l0=full(n - 1, 1.0 / (n - 1)), kap=full(n - 1, 4e3), npl=full(n - 1, 2.0),
        kj=full(n - 2, 0.5), mp=full(n - 2, 2e-3), w=full(n - 2, 1.0), ref=full(n - 2, 0.0),
        inv_m=full(n, float(n)),
    )  # fmt: skip
    state = (X, Y, VX, VY, jnp.zeros((n, b)), jnp.zeros((n, b)),
             jnp.zeros((n - 2, b)), jnp.zeros((n - 1, b)), jnp.zeros(b), jnp.zeros(b))  # fmt: skip
    return state, consts


def _jax_loop(atan: bool):
    import jax
    import jax.numpy as jnp

    from msfd_jax._laws import elastic_plastic
    from msfd_jax._safe import atan2

    def forces(X, Y, rp, sp, c):
        bx, by = X[1:] - X[:-1], Y[1:] - Y[:-1]
        length = jnp.sqrt(bx * bx + by * by)
        n, sp1, da = elastic_plastic((length - c["l0"]) / c["l0"], sp, c["kap"], c["npl"], None)
        gx, gy = n / length * bx, n / length * by
        ax, ay, cx, cy = bx[:-1], by[:-1], bx[1:], by[1:]
        cross, dot = ax * cy - ay * cx, ax * cx + ay * cy
        angle = (atan2(cross, dot) if atan else cross) - c["ref"]
        m, rp1, dr = elastic_plastic(angle, rp, c["kj"], c["mp"], None)
        g = c["w"] * m
        a2, b2 = ax * ax + ay * ay, cx * cx + cy * cy
        z = jnp.zeros_like(X[:1])
        gx = gx + jnp.concatenate([g * ay / a2, z]) + jnp.concatenate([z, -g * cy / b2])
        gy = gy + jnp.concatenate([-g * ax / a2, z]) + jnp.concatenate([z, g * cx / b2])
        fx = jnp.concatenate([gx, z]) - jnp.concatenate([z, gx])
        fy = jnp.concatenate([gy, z]) - jnp.concatenate([z, gy])
        return fx, fy, rp1, sp1, jnp.sum(c["l0"] * da, 0), jnp.sum(c["w"] * dr, 0)

    def run(state, c):
        def body(i, s):
            X, Y, VX, VY, AX, AY, rp, sp, axial, bending = s
            hx, hy = VX + 0.5 * H * AX, VY + 0.5 * H * AY
            X, Y = X + H * hx, Y + H * hy
            fx, fy, rp, sp, da, dr = forces(X, Y, rp, sp, c)
            AX, AY = fx * c["inv_m"], fy * c["inv_m"]
            VX, VY = hx + 0.5 * H * AX, hy + 0.5 * H * AY
            return X, Y, VX, VY, AX, AY, rp, sp, axial + da, bending + dr

        return jax.lax.fori_loop(0, STEPS, body, state)

    return jax.jit(run)


def _numba_loop():
    """The same minimal chain as a plain numba loop over one collision's nodes."""
    import math

    import numpy as np
    from numba import njit

    @njit(cache=False, fastmath=False)
    def ret(trial, fy, k):
        excess = abs(trial) - fy
        if excess <= 0.0:
            return trial, 0.0, 0.0
        d = 1.0 if trial > 0 else -1.0
        inc = excess / k
        return trial - d * excess, d * inc, fy * inc

    @njit(cache=False, fastmath=False)
    def run(x, y, vx, vy, ax_, ay_, rp, sp, l0, kap, npl, kj, mp, w, inv_m, steps, h):
        n = x.shape[0]
        bx, by, gx, gy = np.empty(n - 1), np.empty(n - 1), np.empty(n - 1), np.empty(n - 1)
        diss = 0.0
        for _ in range(steps):
            for i in range(n):
                vx[i] += 0.5 * h * ax_[i]
                vy[i] += 0.5 * h * ay_[i]
                x[i] += h * vx[i]
                y[i] += h * vy[i]
            for i in range(n - 1):
                bx[i], by[i] = x[i + 1] - x[i], y[i + 1] - y[i]
                length = math.sqrt(bx[i] * bx[i] + by[i] * by[i])
                f, dp, d = ret(kap[i] * ((length - l0[i]) / l0[i] - sp[i]), npl[i], kap[i])
                sp[i] += dp
                diss += l0[i] * d
                gx[i], gy[i] = f / length * bx[i], f / length * by[i]
            for j in range(n - 2):
                a_x, a_y, c_x, c_y = bx[j], by[j], bx[j + 1], by[j + 1]
                angle = math.atan2(a_x * c_y - a_y * c_x, a_x * c_x + a_y * c_y)
                m, dp, d = ret(kj[j] * (angle - rp[j]), mp[j], kj[j])
                rp[j] += dp
                diss += w[j] * d
                g = w[j] * m
                a2, b2 = a_x * a_x + a_y * a_y, c_x * c_x + c_y * c_y
                gx[j] += g * a_y / a2
                gy[j] -= g * a_x / a2
                gx[j + 1] -= g * c_y / b2
                gy[j + 1] += g * c_x / b2
            for i in range(n):
                fx = (gx[i] if i < n - 1 else 0.0) - (gx[i - 1] if i > 0 else 0.0)
                fy = (gy[i] if i < n - 1 else 0.0) - (gy[i - 1] if i > 0 else 0.0)
                ax_[i], ay_[i] = fx * inv_m[i], fy * inv_m[i]
                vx[i] += 0.5 * h * ax_[i]
                vy[i] += 0.5 * h * ay_[i]
        return diss

    def call(state, c):
        import numpy as np

        X, Y, VX, VY, AX, AY, rp, sp, _, _ = (np.array(a[..., 0]) for a in state)
        one = {k: np.ascontiguousarray(np.asarray(v)[..., 0]) for k, v in c.items()}
        return run(X, Y, VX, VY, AX, AY, rp, sp, one["l0"], one["kap"], one["npl"], one["kj"],
                   one["mp"], one["w"], one["inv_m"], STEPS, H)  # fmt: skip

    return call


def _element_loop(kind: str, b: int, ops: int = 20):
    """A fused loop of `ops` chained element operations on (42, B) arrays."""
    import jax
    import jax.numpy as jnp

    from msfd_jax._safe import atan2

    def body(i, y):
        for _ in range(ops):
            if kind == "multiply-add":
                y = y * 0.999 + 1e-3
            elif kind == "division":
                y = 1.0 / (y + 1.0) + 0.5
            else:
                y = atan2(y, 1.3) + 0.5
        return y

    f = jax.jit(lambda y: jax.lax.fori_loop(0, STEPS, body, y))
    return f, jnp.full((NODES, b), 0.7)


def main() -> None:
    _bench.pin()
    import jax

    jax.config.update("jax_enable_x64", True)
    from numba_reference import Reference

    import msfd_jax as m

    ref = Reference(m.ring_on_beam(), m.Settings(t_max=10.0))
    ref.compile()
    programs, per = {}, {}
    for b in BATCHES:
        state, consts = _constants(b)
        programs[("chain", b)] = (_jax_loop(True), state, consts)
        programs[("chain, no atan2", b)] = (_jax_loop(False), state, consts)
        per[("chain", b)] = per[("chain, no atan2", b)] = STEPS * b
    state1, consts1 = _constants(1)
    numba_chain = _numba_loop()
    programs[("numba chain", 1)] = (numba_chain, state1, consts1)
    per[("numba chain", 1)] = STEPS
    for kind in ("multiply-add", "division", "atan2"):
        f, y = _element_loop(kind, 32)
        programs[(kind, 32)] = (f, y)
        per[(kind, 32)] = STEPS * 20 * NODES * 32
    programs[("numba reference", 1)] = (ref,)
    times = _bench.interleaved_best(programs, 7)
    ref_steps = ref()["steps"]
    numba_us = 1e6 * times[("numba reference", 1)] / ref_steps
    budget = numba_us / 3.0

    def us(key):
        return 1e6 * times[key] / per[key]

    date = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")
    lines = [
        "# The least an XLA:CPU substep costs: a minimal chain (issue 11, goals 1 and 3)",
        "",
        f"`python benchmarks/xla_chain_floor.py` · {date} · core(s) "
        f"{sorted(os.sched_getaffinity(0))} · jax {jax.__version__} · float64, best of 7 "
        f"interleaved rounds of {STEPS} substeps",
        "",
        f"numba reference, showcase: **{numba_us:.3f} µs/step**; the budget of goals 1 and 3 "
        f"(a third): **{budget:.3f} µs per collision-step**.",
        "",
        f"Minimal chain ({NODES} nodes, {NODES - 1} bars, {NODES - 2} joints; no contact, no "
        "second chain, no bookkeeping), µs per collision-step:",
        "",
        "| B | XLA:CPU | x the budget | XLA:CPU, joint angle without atan2 |",
        "|---:|---:|---:|---:|",
    ]
    for b in BATCHES:
        c, n = us(("chain", b)), us(("chain, no atan2", b))
        lines.append(f"| {b} | {c:.3f} | {c / budget:.2f} | {n:.3f} |")
    nb = us(("numba chain", 1))
    best_b = min(BATCHES, key=lambda b: us(("chain", b)))
    best = us(("chain", best_b))
    lines += [
        "",
        f"The same minimal chain as a plain numba loop (one collision): **{nb:.3f} µs/step**.",
        "",
        f"XLA:CPU per element in a fused loop of 20 chained operations on ({NODES}, 32): "
        + ", ".join(
            f"{k} {1e3 * us((k, 32)):.2f} ns" for k in ("multiply-add", "division", "atan2")
        )
        + ".",
        "",
        f"Reading: the cheapest minimal chain (B = {best_b}) costs {best:.3f} µs per "
        f"collision-step, {best / budget:.2f} x the budget ({best / nb:.2f} x the plain numba "
        f"loop of the same chain; B = 1 costs {us(('chain', 1)) / best:.1f} x B = {best_b}). "
        "The real substep does strictly more: a second chain with symmetric and clamped "
        "ends, the contact, the unwrapping, the energy bookkeeping. To meet goals 1 and 3 "
        f"all of that would have to fit in the {max(budget - best, 0.0):.3f} µs left of the "
        "budget; in the core it costs about as much again as the chain itself "
        "(benchmarks/results/xla_floor.md, contact_blocks.md).",
    ]
    _bench.write_result("xla_chain_floor.md", lines)


if __name__ == "__main__":
    main()
