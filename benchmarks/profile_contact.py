"""Where the pruned contact's time goes, per XLA:CPU thunk (issue 11, goal 6).

B = 32 showcase-like collisions (h_b/h_r 2-3, held, g = 10) on the paper mesh x1 and x4 are
advanced to half of the showcase's steps (contact engaged); then a compiled loop of substeps
runs once under ``jax.profiler.trace`` and the trace's complete events are summed per thunk
(XLA:CPU names each: ``cond.N`` a contact block's ``lax.cond``, fusions by their ops). Each
block's ``cond`` is classed near or skipped by this state's `_pruning.near_blocks`, matched to
the thunks by duration rank (the near ones are the longest; the script checks that the count
matches). The profiler inflates every thunk; the unprofiled cost is printed beside it.

    python benchmarks/profile_contact.py     # writes benchmarks/results/profile_contact.md
"""

from __future__ import annotations

import collections
import datetime
import glob
import gzip
import json
import os
import tempfile
import time

import _bench

B = 32
STEPS = 50


def profile(factor: int) -> dict:
    import jax

    from msfd_jax import _pruning

    mesh = _bench.scaled_mesh(factor)
    flat, clock, y, h = _bench.half_way(mesh, B, *_bench.showcase_steps(mesh))
    pair = flat.pairs[0]
    blocks = _pruning.contact_blocks(pair.n_a, pair.n_b, B)
    xa, xb = y.x[pair.a : pair.a + pair.n_a], y.x[pair.b : pair.b + pair.n_b]
    near = sum(bool(n) for *_, n in _pruning.near_blocks(xa, xb, flat.gap[0], blocks))
    loop = _bench.substep_loop(STEPS, h, clock.tolerance)
    jax.block_until_ready(loop(flat, y))
    best = float("inf")
    for _ in range(5):
        tick = time.perf_counter()
        jax.block_until_ready(loop(flat, y))
        best = min(best, time.perf_counter() - tick)
    with tempfile.TemporaryDirectory() as where:
        with jax.profiler.trace(where):
            jax.block_until_ready(loop(flat, y))
        (trace,) = glob.glob(f"{where}/**/*.trace.json.gz", recursive=True)
        events = json.load(gzip.open(trace))["traceEvents"]
    per = collections.Counter()
    for e in events:
        if e.get("ph") == "X" and "dur" in e:
            per[e["name"]] += e["dur"] / STEPS
    conds = sorted(((v, k) for k, v in per.items() if k.startswith("cond.")), reverse=True)
    n_blocks = -(-pair.n_a // blocks[0]) * -(-pair.n_b // blocks[1])
    thunks = {k: v for k, v in per.items() if not k.startswith(("$", "ThunkExecutor", "Pjit"))}
    thunks = {k: v for k, v in thunks.items() if "Execut" not in k}
    return dict(
        factor=factor, pairs=(pair.n_a, pair.n_b), blocks=blocks, n_blocks=n_blocks,
        near=near, conds=len(conds), near_us=sum(v for v, _ in conds[:near]),
        skipped_us=sum(v for v, _ in conds[near:]),
        unprofiled_us=1e6 * best / STEPS,
        top=sorted(((v, k) for k, v in thunks.items() if not k.startswith("cond.")),
                   reverse=True)[:4],
    )  # fmt: skip


def main() -> None:
    _bench.pin()
    import jax

    jax.config.update("jax_enable_x64", True)
    rows = [profile(f) for f in (1, 4)]
    date = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")
    lines = [
        "# The pruned contact per XLA:CPU thunk (issue 11, goal 6)",
        "",
        f"`python benchmarks/profile_contact.py` · {date} · core(s) "
        f"{sorted(os.sched_getaffinity(0))} · jax {jax.__version__} · B = {B}, {STEPS} "
        "substeps from half-way through a showcase-like collision, summed per thunk of "
        "`jax.profiler.trace` (µs per substep of all B collisions; the profiler inflates them: "
        "compare within a row)",
        "",
        "| mesh | pairs | block | blocks (near) | near blocks' conds | skipped blocks' conds "
        "| unprofiled substep | largest other thunks (some inside the conds) |",
        "|---|---|---|---|---:|---:|---:|---|",
    ]
    for r in rows:
        top = ", ".join(f"{k} {v:.0f}" for v, k in r["top"])
        lines.append(
            f"| x{r['factor']} | {r['pairs'][0]} x {r['pairs'][1]} | {r['blocks'][0]} x "
            f"{r['blocks'][1]} | {r['n_blocks']} ({r['near']}) | {r['near_us']:.0f} | "
            f"{r['skipped_us']:.0f} | {r['unprofiled_us']:.0f} | {top} |"
        )
        if r["conds"] != r["n_blocks"]:
            lines.append(f"| | (found {r['conds']} conds for {r['n_blocks']} blocks) ||||||")
    lines += [
        "",
        "Reading: a skipped block is not free: at x4 the skipped blocks' conditionals cost "
        "about what the near ones do. Its branch returns zeros and its part of the permanent "
        "set (both branches return the same shapes), but that traffic is not the cost: "
        "carrying the set as one array per block, with nothing sliced or reassembled, saves "
        "4-6 % at x4 (benchmarks/results/contact_list.md). What remains is the conditionals' "
        "own cost on XLA:CPU.",
    ]
    _bench.write_result("profile_contact.md", lines)


if __name__ == "__main__":
    main()
