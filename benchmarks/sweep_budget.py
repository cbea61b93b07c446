"""Issue 11's goal 2 as a budget per collision-step, against what a sweep's segment costs.

1. The 1024 collisions of goal 2 (`sweep_1024.py`'s grid) through ``msfd_jax.sweep`` in this
   process (default workers and slots; the run time excludes the compilation): the Verlet
   steps of every attempt, the slots' steps (lane utilisation) and the run time. The goal's
   budget per collision-step is then cores x 30 s / steps (compilation from the cache, which
   the goal includes, not deducted).
2. On one core, 32 collisions drawn from that grid advanced 8 segments into their runs, then
   timed side by side (interleaved rounds, best kept): one segment of the sweep
   (``_queue._segment``: diffrax, the stopping rule once per diffrax step), the same number
   of bare Verlet substeps (``_engine.verlet_substep`` in a ``fori_loop``), and those
   substeps without the contact.

    python benchmarks/sweep_budget.py     # writes benchmarks/results/sweep_budget.md
"""

from __future__ import annotations

import dataclasses
import datetime
import itertools
import json
import os
import subprocess
import sys
import time

import _bench
import numpy as np

THICKNESS = [float(v) for v in np.linspace(0.25, 5.0, 64)]  # the CLI's 0.25:5:64
GRID = dict(
    thickness_ratio=THICKNESS, axial_constraint=[0.0, 1.0],
    mass_ratio=[5.0, 10.0, 20.0, 40.0], velocity=[0.6, 0.82],
)  # fmt: skip
GOAL_S = 30.0
SLOTS = 32
SEGMENTS_IN = 8


def whole_sweep() -> dict:
    import msfd_jax as m
    from msfd_jax import _sweep

    tick = time.perf_counter()
    m.sweep(GRID)
    wall = time.perf_counter() - tick
    return dict(_sweep.LAST_TIMING, wall=wall, cores=len(os.sched_getaffinity(0)))


def segment_costs(seed: int = 0) -> dict:
    import equinox as eqx
    import jax.numpy as jnp

    import msfd_jax as m
    from msfd_jax import _queue, _sweep
    from msfd_jax._params import CollisionParams
    from msfd_jax._shard import _critical_chunk

    rows = list(itertools.product(*GRID.values()))
    pick = np.random.default_rng(seed).choice(len(rows), SLOTS, replace=False)
    chosen = np.array([rows[i] for i in pick])
    base = CollisionParams().as_arrays()
    fields = {f.name: jnp.full(SLOTS, float(getattr(base, f.name))) for f in
              dataclasses.fields(CollisionParams)}  # fmt: skip
    for i, k in enumerate(GRID):
        fields[k] = jnp.asarray(chosen[:, i])
    p = CollisionParams(**fields)
    mesh = m.Mesh()
    settings = _sweep._sweep_settings(_sweep.SWEEP_SETTINGS, mesh)
    settings = dataclasses.replace(settings, max_steps=1 << 20)
    dt_crit, _, _ = _critical_chunk(p, mesh, (0.0, 0.0))
    smoothing = _queue.with_flags((0.0, 0.0))
    flat, clock, y = _queue._start(
        p, dt_crit, mesh, smoothing, settings, jnp.full(SLOTS, 1e9), jnp.ones(SLOTS)
    )
    segment = _queue.DEFAULT_SEGMENT
    for _ in range(SEGMENTS_IN):
        y = _queue._segment(flat, clock, y, settings, segment)
    running = int(SLOTS - np.sum(np.asarray(y.done)))
    steps = segment * settings.substeps
    loop = _bench.substep_loop(steps, clock.dt0 / settings.substeps, clock.tolerance)
    none = ()
    bare = dataclasses.replace(flat, pairs=none, gap=none, stiffness=none, yield_force=none)
    y_bare = eqx.tree_at(lambda s: s.permanent_set, y, none)
    programs = {
        "one segment of the sweep (diffrax, stopping rule)": (
            lambda f, c, s: _queue._segment(f, c, s, settings, segment), flat, clock, y),
        "the same Verlet substeps, bare loop": (loop, flat, y),
        "the same substeps without the contact": (loop, bare, y_bare),
    }  # fmt: skip
    best = _bench.interleaved_best(programs, 7)
    out = {k: 1e6 * v / (steps * SLOTS) for k, v in best.items()}
    return dict(costs=out, running=running, seed=seed)


def main() -> None:
    if os.environ.get("MSFD_SWEEP_BUDGET_PART") == "segments":
        _bench.pin()
        import jax

        jax.config.update("jax_enable_x64", True)
        print(json.dumps(segment_costs()))
        return
    import jax

    jax.config.update("jax_enable_x64", True)
    t = whole_sweep()
    print(f"whole sweep: {t}", flush=True)
    env = dict(os.environ, MSFD_SWEEP_BUDGET_PART="segments")
    out = subprocess.run(
        [sys.executable, __file__], env=env, capture_output=True, text=True, check=True
    )
    seg = json.loads(out.stdout.strip().splitlines()[-1])
    budget = t["cores"] * GOAL_S / t["steps"] * 1e6
    per_step = t["cores"] * t["run_s"] / t["steps"] * 1e6
    busy = t["workers"] * t["run_s"]
    hand = (busy - t["segment_s"]) / busy
    handover = (busy - t["segment_s"]) / t["steps"] * 1e6 * t["cores"] / t["workers"]
    in_segments = per_step - handover
    date = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")
    first = next(iter(seg["costs"].values()))
    lines = [
        "# Goal 2 of issue 11 as a budget per collision-step (1024 collisions in <= 30 s)",
        "",
        f"`python benchmarks/sweep_budget.py` · {date} · {t['cores']} cores · jax "
        f"{jax.__version__}",
        "",
        f"The grid of `sweep_1024.py` in process (`msfd_jax.sweep`, {t['workers']} workers of "
        f"{t['slots']} slots): {t['steps']:,} Verlet steps (every "
        f"attempt), lane utilisation {t['steps'] / t['slot_steps']:.3f}, run "
        f"{t['run_s']:.1f} s (compilation, {t['compile_s']:.1f} s here, apart; wall "
        f"{t['wall']:.1f} s), i.e. **{per_step:.2f} µs per "
        f"collision-step per core**. Goal 2's budget: {t['cores']} cores x {GOAL_S:.0f} s / "
        f"steps = **{budget:.2f} µs per collision-step per core**, compilation from the cache "
        "included.",
        "",
        f"Of the workers' run time ({t['workers']} x {t['run_s']:.1f} s), "
        f"{t['segment_s']:.1f} s went to the segment programs and the other {hand:.0%} "
        "outside them: the hand-over between segments (finished slots reported, rows built, "
        "refills), a worker standing idle at the end while the other finishes, and waits "
        f"for a tail program's compilation: **{handover:.2f} µs per collision-step per "
        "core**.",
        "",
        f"On one core, {SLOTS} collisions of the grid (seed {seg['seed']}) after "
        f"{SEGMENTS_IN} segments ({seg['running']} still running), µs per collision-step:",
        "",
        "| program | µs per collision-step | x goal 2's budget |",
        "|---|---:|---:|",
    ]
    lines += [f"| {k} | {v:.3f} | {v / budget:.2f} |" for k, v in seg["costs"].items()]
    lines += [
        "",
        f"Reading: the sweep pays {per_step / budget:.2f} x the budget: its segment programs "
        f"{in_segments:.2f} µs per collision-step per core ({in_segments / budget:.2f} x) and "
        f"the rest {handover:.2f} ({handover / budget:.2f} x). A segment of this sample "
        f"alone costs {first:.3f} µs ({first / budget:.2f} x); the sweep's segments cost more "
        "with phases dearer than this sample's, the tail's smaller batches and two workers "
        "sharing the machine.",
    ]
    _bench.write_result("sweep_budget.md", lines)


if __name__ == "__main__":
    main()
