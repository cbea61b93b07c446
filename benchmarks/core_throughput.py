"""The batched core against the numba reference, side by side in one process on one core.

Issue 11's goals 1 and 3:
- **sweep**: the 64 collisions of `sweep_throughput.py` (h_b/h_r 0.25-5 x 16, free/held,
  g = 5, 10; paper mesh, default sweep settings). numba loops over them one by one; msfd_jax
  runs them through `sweep` with 8 ... 64 slots (refilled as collisions stop). The figure is
  the marginal cost per collision-step: run time (compilation excluded: `SweepTable.timing`) over
  the Verlet steps of every attempt (the rows issue 12 reruns at a smaller step run in the
  same queue; numba runs each collision once); goal: <= 1/3 of numba's per-step cost.
- **showcase**: one collision in process, jax (a batch of one, default `Settings` with
  histories, and the lean sweep settings) against numba at the same step; goal: <= 1/3 of
  numba's time.

    python benchmarks/core_throughput.py            # writes benchmarks/results/core.{json,md}
    python benchmarks/core_throughput.py --slots 16 64 --repeats 1
    python benchmarks/core_throughput.py --quick    # 2 collisions, 16 slots, one repeat

Re-executes itself under ``taskset -c 0`` (one core for both) when available.
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime
import json
import os
import platform
import shutil
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import _bench  # noqa: E402


def _pin():
    if os.environ.get("MSFD_BENCH_PINNED") or shutil.which("taskset") is None:
        return
    env = dict(os.environ, MSFD_BENCH_PINNED="1")
    raise SystemExit(subprocess.call(["taskset", "-c", "0", sys.executable, *sys.argv], env=env))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--slots", nargs="+", type=int, default=[8, 16, 32, 64])
    parser.add_argument("--repeats", type=int, default=2)
    _bench.add_quick(parser)
    args = parser.parse_args()
    _pin()
    import jax
    import numpy as np
    from _numba_reference import Reference
    from sweep_throughput import GRID

    if args.quick:
        GRID = dict(thickness_ratio=[1.0, 2.5], axial_constraint=[1.0], mass_ratio=[10.0])
        args.slots, args.repeats = [16], 1

    import msfd_jax as m

    record: dict = dict(
        command="python benchmarks/core_throughput.py " + " ".join(sys.argv[1:]),
        date=datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC"),
        machine=f"{platform.processor() or platform.machine()}, pinned to core(s) "
        f"{sorted(os.sched_getaffinity(0))}",
        jax=jax.__version__,
    )
    # --- the sweep: numba loop over the 64 collisions --------------------------------------
    designs = _bench.grid_rows(GRID)
    n = len(designs)
    # the former fixed cap tau = 10 for both (issue 12 derives a cap per design; the numba
    # reference and the engine then still share a grid, but a fixed cap keeps the records of
    # earlier runs comparable)
    settings = dataclasses.replace(_bench.sweep_settings(), t_max=10.0)
    refs = [Reference(m.ring_on_beam(m.CollisionParams(**row)), settings) for row in designs]
    refs[0].compile()
    best, best_cpu, steps_numba = float("inf"), float("inf"), 0
    for _ in range(args.repeats):
        tick, cpu = time.perf_counter(), time.process_time()
        outs = [r() for r in refs]
        best = min(best, time.perf_counter() - tick)
        best_cpu = min(best_cpu, time.process_time() - cpu)
        steps_numba = sum(o["steps"] for o in outs)
    numba_step_us = 1e6 * best / steps_numba
    numba_cpu_us = 1e6 * best_cpu / steps_numba
    record["numba_sweep"] = dict(
        seconds=best, cpu_seconds=best_cpu, steps=steps_numba, us_per_step=numba_step_us,
        cpu_us_per_step=numba_cpu_us,
    )  # fmt: skip
    print(f"numba: 64 collisions {best:.2f} s, {steps_numba} steps, {numba_step_us:.3f} us/step")
    rows = []
    for slots in args.slots:
        m.sweep(GRID, m.Mesh(), settings, chunk_size=slots)  # compile (and cache) first
        runs = []
        for _ in range(args.repeats):
            tick, cpu = time.perf_counter(), time.process_time()
            table = m.sweep(GRID, m.Mesh(), settings, chunk_size=slots)
            wall, cpu = time.perf_counter() - tick, time.process_time() - cpu
            runs.append((dict(table.timing), wall, table, cpu))
        timing, wall, table, cpu = min(runs, key=lambda r: r[0]["run_s"])
        # every attempt's steps: a row rerun at a smaller step (issue 12) runs in the same
        # queue, and its first attempt's steps are work done too
        steps = int(timing["steps"])
        reported = int(np.sum(table["steps"]))
        us = 1e6 * timing["run_s"] / steps
        cpu_us = 1e6 * cpu / steps
        rows.append(
            dict(
                slots=slots,
                run_s=timing["run_s"],
                wall_s=wall,
                compile_s=timing["compile_s"],
                segments=timing["segments"],
                steps=steps,
                reported_steps=reported,
                retried=int(np.sum(table["retries"] > 0)),
                us_per_collision_step=us,
                numba_over_jax=numba_step_us / us,
                collisions_per_s=n / timing["run_s"],
                cpu_s=cpu,
                cpu_us_per_collision_step=cpu_us,
                cpu_numba_over_jax=numba_cpu_us / cpu_us,
            )
        )
        print(
            f"jax slots {slots}: run {timing['run_s']:.2f} s (wall {wall:.2f} s), {steps} steps"
            f", {us:.3f} us/collision-step, numba/jax {numba_step_us / us:.2f}"
            f"; CPU time: {cpu_us:.3f} us/collision-step, numba/jax {numba_cpu_us / cpu_us:.2f}"
        )
    record["jax_sweep"] = rows
    # --- the showcase ----------------------------------------------------------------------
    scene = m.ring_on_beam()
    ref = Reference(scene, m.Settings(t_max=10.0))
    ref.compile()
    t_numba = min(_timed(ref) for _ in range(5))
    c_numba = min(_timed(ref, time.process_time) for _ in range(5))
    show = {}
    variants = (("default settings", m.Settings(t_max=10.0)), ("lean settings", settings))
    for name, st in variants[: 1 if args.quick else 2]:
        jax.block_until_ready(m.simulate(scene, st))

        def one(st=st):
            return jax.block_until_ready(m.simulate(scene, st))

        t = min(_timed(one) for _ in range(5))
        c = min(_timed(one, time.process_time) for _ in range(5))
        show[name] = dict(
            seconds=t, numba_over_jax=t_numba / t, cpu_seconds=c, cpu_numba_over_jax=c_numba / c
        )
        print(f"showcase jax ({name}) {t * 1e3:.1f} ms, numba {t_numba * 1e3:.1f} ms, "
              f"numba/jax {t_numba / t:.2f}; CPU time numba/jax {c_numba / c:.2f}")  # fmt: skip
    record["showcase"] = dict(numba_s=t_numba, numba_cpu_s=c_numba, steps=ref()["steps"], jax=show)
    results = _bench.results_dir(args.quick)
    (results / "core.json").write_text(json.dumps(record, indent=1) + "\n")
    (results / "core.md").write_text(_markdown(record))


def _timed(fn, clock=time.perf_counter) -> float:
    tick = clock()
    fn()
    return clock() - tick


def _markdown(r: dict) -> str:
    ns = r["numba_sweep"]
    lines = [
        "# Batched core against the numba reference (issue 11)",
        "",
        f"`{r['command'].strip()}` · {r['date']} · {r['machine']} · jax {r['jax']}",
        "",
        "## Sweep: the 64 collisions of sweep_throughput.py, paper mesh",
        "",
        f"numba, one collision after another: {ns['seconds']:.2f} s for {ns['steps']} steps, "
        f"**{ns['us_per_step']:.3f} µs/step** "
        f"(CPU time {ns.get('cpu_us_per_step', float('nan')):.3f}).",
        "",
        "Wall time is the sweep's own run time (compile excluded); CPU time is the process's over",
        "the whole `sweep` call (scene builds and refills included), the fairer figure on a",
        "shared machine (both programs pinned to one core).",
        "",
        "| slots | run s (no compile) | compile s | segments | rows rerun | steps run "
        "| µs / collision-step "
        "| numba / jax | collisions/s | CPU µs / collision-step | numba / jax (CPU) |",
        "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for row in r["jax_sweep"]:
        lines.append(
            f"| {row['slots']} | {row['run_s']:.2f} | {row['compile_s']:.1f} | "
            f"{row['segments']} | {row.get('retried', '')} | {row['steps']} | "
            f"{row['us_per_collision_step']:.3f} | "
            f"{row['numba_over_jax']:.2f} | {row['collisions_per_s']:.1f} | "
            f"{row.get('cpu_us_per_collision_step', float('nan')):.3f} | "
            f"{row.get('cpu_numba_over_jax', float('nan')):.2f} |"
        )
    s = r["showcase"]
    lines += [
        "",
        "Goal 1: numba / jax >= 3 (jax's marginal cost per collision-step at most a third).",
        "",
        "## One showcase collision in process",
        "",
        f"numba {s['numba_s'] * 1e3:.1f} ms ({s['steps']} steps).",
        "",
        "| jax | ms | numba / jax | CPU ms | numba / jax (CPU) |",
        "|---|---:|---:|---:|---:|",
    ]
    for name, row in s["jax"].items():
        lines.append(
            f"| {name} | {row['seconds'] * 1e3:.1f} | {row['numba_over_jax']:.2f} | "
            f"{row.get('cpu_seconds', float('nan')) * 1e3:.1f} | "
            f"{row.get('cpu_numba_over_jax', float('nan')):.2f} |"
        )
    lines += ["", "Goal 3: numba / jax >= 3.", ""]
    return "\n".join(lines)


if __name__ == "__main__":
    main()
