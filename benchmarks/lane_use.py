"""Lane utilisation of the sweep's slots (issue 11): the 64 collisions of sweep_throughput.py
through `sweep` with 16, 32 and 64 slots on one worker, printing the segments, the Verlet steps
of every attempt, the steps the slots ran busy or idle (`slot_steps`, `_queue.run_queue`), their
ratio (the lanes' utilisation) and the run time per collision-step and per lane-step.

    taskset -c 0 python benchmarks/lane_use.py      # prints only
"""

from __future__ import annotations

import dataclasses
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import jax  # noqa: E402

jax.config.update("jax_enable_x64", True)

from sweep_throughput import GRID  # noqa: E402

import msfd_jax as m  # noqa: E402
from msfd_jax import _sweep  # noqa: E402

settings = dataclasses.replace(_sweep.SWEEP_SETTINGS, t_max=10.0)
for slots in (16, 32, 64):
    m.sweep(GRID, m.Mesh(), settings, chunk_size=slots, workers=1)  # compile first
    tick = time.perf_counter()
    m.sweep(GRID, m.Mesh(), settings, chunk_size=slots, workers=1)
    t = dict(_sweep.LAST_TIMING)
    print(
        f"{slots} slots: {t['segments']} segments, {t['steps']} steps, {t['slot_steps']} "
        f"slot-steps, utilisation {t['steps'] / t['slot_steps']:.3f}, "
        f"{1e6 * t['run_s'] / t['steps']:.3f} us/collision-step, "
        f"{1e6 * t['run_s'] / t['slot_steps']:.3f} us/lane-step",
        flush=True,
    )
