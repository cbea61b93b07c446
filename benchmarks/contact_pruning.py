"""Does pruning the ring-beam contact pay on XLA:CPU with the batch last? (issue 11, goal 6)

Standalone contact forces of 16 ring x 21 beam nodes (float64, a fori_loop of 1000 force
evaluations, one core), the batch of B collisions on the last axis as in the core:
- dense: every pair (the core's formulation);
- gather W4: per ring node and collision a window of 4 beam nodes (start: the beam nodes left of
  x_i - gap, counted), gathered with ``take_along_axis``; beam forces and permanent sets
  scattered back with one-hot masks;
- onehot W4: the same window selected with one-hot masks instead of a gather.
Pruning is exact only while every pair within the gap lies in the window; this measures
the cost alone. Each variant timed in turn, round after round, best round kept.

    python benchmarks/contact_pruning.py     # writes benchmarks/results/contact_pruning.md
"""

import datetime
import os
from pathlib import Path

import _bench

_bench.pin()

import jax  # noqa: E402  (after the pin: the re-executed process imports it)
import jax.numpy as jnp  # noqa: E402

jax.config.update("jax_enable_x64", True)
K = 1000
NA, NB = 16, 21


def dense(xr, xb, dp, k=5e4, fy=20.0, gap=0.175):
    dx = xr[:, None, 0] - xb[None, :, 0]
    dy = xr[:, None, 1] - xb[None, :, 1]
    r = jnp.sqrt(jnp.maximum(dx * dx + dy * dy, 1e-30))
    delta = gap - r
    f = jnp.clip(k * (delta - dp), 0.0, fy)
    dp1 = jnp.maximum(dp, delta - fy / k)
    c = f / r
    fx, fyy = c * dx, c * dy
    return jnp.stack([fx.sum(1), fyy.sum(1)], 1), -jnp.stack([fx.sum(0), fyy.sum(0)], 1), dp1


def pruned(W, mode):
    def f(xr, xb, dp, k=5e4, fy=20.0, gap=0.175):
        # start index per ring node and lane: beam nodes left of x_i - gap
        cnt = jnp.sum((xb[None, :, 0] < xr[:, None, 0] - gap).astype(jnp.int32), axis=1)  # (NA,B)
        start = jnp.clip(cnt, 0, NB - W)
        idx = start[:, None] + jnp.arange(W)[None, :, None]  # (NA,W,B)
        if mode == "gather":
            xbx = jnp.take_along_axis(xb[None, :, 0], idx.reshape(1, NA * W, -1), axis=1).reshape(
                NA, W, -1
            )
            xby = jnp.take_along_axis(xb[None, :, 1], idx.reshape(1, NA * W, -1), axis=1).reshape(
                NA, W, -1
            )
            dps = jnp.take_along_axis(dp, idx, axis=1)
        else:
            oh = idx[:, :, None, :] == jnp.arange(NB)[None, None, :, None]  # (NA,W,NB,B)
            xbx = jnp.sum(jnp.where(oh, xb[None, None, :, 0], 0.0), 2)
            xby = jnp.sum(jnp.where(oh, xb[None, None, :, 1], 0.0), 2)
            dps = jnp.sum(jnp.where(oh, dp[:, None], 0.0), 2)
        dx = xr[:, None, 0] - xbx
        dy = xr[:, None, 1] - xby
        r = jnp.sqrt(jnp.maximum(dx * dx + dy * dy, 1e-30))
        delta = gap - r
        ff = jnp.clip(k * (delta - dps), 0.0, fy)
        dp1s = jnp.maximum(dps, delta - fy / k)
        c = ff / r
        fx, fyy = c * dx, c * dy
        fr = jnp.stack([fx.sum(1), fyy.sum(1)], 1)
        oh = idx[:, :, None, :] == jnp.arange(NB)[None, None, :, None]
        fbx = -jnp.sum(jnp.where(oh, fx[:, :, None], 0.0), (0, 1))
        fby = -jnp.sum(jnp.where(oh, fyy[:, :, None], 0.0), (0, 1))
        dp1 = jnp.where(jnp.any(oh, 1), jnp.sum(jnp.where(oh, dp1s[:, :, None], 0.0), 1), dp)
        return fr, jnp.stack([fbx, fby], 1), dp1

    return f


def loop(fn):
    def run(xr, xb, dp):
        def body(i, c):
            xr, xb, dp = c
            fr, fb, dp = fn(xr, xb, dp)
            return xr + 1e-9 * fr, xb + 1e-9 * fb, dp

        return jax.lax.fori_loop(0, K, body, (xr, xb, dp))

    return jax.jit(run)


ROWS = []
for B in (16, 32, 64):
    xr = jnp.stack(
        [jnp.linspace(0, 1, NA)[:, None] + 0 * jnp.ones((NA, B)), 0.1 * jnp.ones((NA, B))], 1
    )
    xb = jnp.stack(
        [jnp.linspace(0, 2, NB)[:, None] + 0 * jnp.ones((NB, B)), 0.0 * jnp.ones((NB, B))], 1
    )
    dp = jnp.zeros((NA, NB, B))
    programs = {
        "dense": (loop(dense), xr, xb, dp),
        "gather W4": (loop(pruned(4, "gather")), xr, xb, dp),
        "onehot W4": (loop(pruned(4, "onehot")), xr, xb, dp),
    }
    best = _bench.interleaved_best(programs, 5)
    print(B, {k: f"{v / K / B * 1e6:.3f} us/coll" for k, v in best.items()}, flush=True)
    ROWS.append((B, best))
date = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")
lines = [
    "# Pruned contact on XLA:CPU, batch last (issue 11)",
    "",
    f"`python benchmarks/contact_pruning.py` · {date} · core(s) {sorted(os.sched_getaffinity(0))}"
    f" · jax {jax.__version__}",
    "",
    "| B | dense µs / collision | gather W4 | onehot W4 |",
    "|---:|---:|---:|---:|",
]
for B, best in ROWS:
    lines.append(
        f"| {B} | "
        + " | ".join(f"{best[k] / K / B * 1e6:.3f}" for k in ("dense", "gather W4", "onehot W4"))
        + " |"
    )
lines += [
    "",
    "A window of 4 instead of 21 beam nodes evaluates 64 pairs instead of 336, yet costs as",
    "much or more: the per-lane gather and the one-hot scatter back cost more than the pairs",
    "saved.",
    "",
]
(Path(__file__).resolve().parent / "results" / "contact_pruning.md").write_text("\n".join(lines))
