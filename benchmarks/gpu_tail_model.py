"""A model of a whole GPU sweep's time from measured parts (issue 11, goal 7): what the tail
rule of the queue (`_queue._tail_size_gpu`) should save. A model, not a measurement: the
device time to measure it was spent (benchmarks/results/gpu.md).

Inputs, all measured:
- each collision's Verlet steps on sweep_1024.py's grid, from a CPU sweep's table
  (`--csv`, `msfd sweep ... --csv`): a row rerun at half the step (`retries` 1) ran a first
  attempt of about half its steps, then went back to the front of the queue;
- the GPU's time per Verlet step of B slots, from gpu_throughput.py's scan on an H200
  (benchmarks/results/gpu_scan_check.md): 65.5, 235.5 and 1719 µs at B = 1024, 8192 and
  65536, interpolated in log-log, flat below 1024 (one collision took 73 µs a step).

The queue is replayed segment by segment (64 diffrax steps = 512 Verlet steps): longest
collisions first, finished slots refilled from the queue, and with the tail rule the batch
moved to fewer slots once at most a quarter run (compilation not counted: 6-14 s a size
there). The model is checked against the one whole sweep measured on the GPU (8192
collisions on 8192 slots, no tail rule: 72.1 s run, 62.9 s of it in segments, 523 segments).

    msfd sweep --thickness-ratio 0.25:5:64 --axial-constraint both --mass-ratio 5,10,20,40 \\
        --velocity 0.6,0.82 -q --csv /tmp/s1024.csv
    python benchmarks/gpu_tail_model.py --csv /tmp/s1024.csv   # writes results/gpu_tail_model.md
"""

from __future__ import annotations

import argparse
import collections
import csv
from pathlib import Path

import numpy as np

from msfd_jax._queue import GPU_TAIL_FLOOR as FLOOR
from msfd_jax._queue import _tail_size_gpu  # the queue's own rule

RESULTS = Path(__file__).resolve().parent / "results"
SEGMENT = 512  # Verlet steps a segment
SCAN = {1024: 65.5, 8192: 235.5, 65536: 1719.0}  # µs per Verlet step of B slots, H200


def step_us(b: int) -> float:
    x, y = np.log(list(SCAN)), np.log(list(SCAN.values()))
    return float(np.exp(np.interp(np.log(max(b, FLOOR)), x, y, right=None)))


def extrapolated(b: int) -> float:
    if b <= max(SCAN):
        return step_us(b)
    slope = np.log(SCAN[65536] / SCAN[8192]) / np.log(8)
    return SCAN[65536] * (b / 65536) ** slope


def replay(jobs: list[tuple[int, int]], slots: int, tail: bool) -> dict:
    """jobs: (first attempt's steps, retry's steps or 0), longest first."""
    queue = collections.deque((s, r) for s, r in jobs)
    running: list[list[int]] = []  # [segments left, retry steps]
    size, seconds, segments, sizes = slots, 0.0, 0, {slots}
    while queue or running:
        while queue and len(running) < size:
            s, r = queue.popleft()
            running.append([-(-s // SEGMENT), r])
        seconds += SEGMENT * extrapolated(size) * 1e-6
        segments += 1
        still = []
        for job in running:
            job[0] -= 1
            if job[0] > 0:
                still.append(job)
            elif job[1]:
                queue.appendleft((job[1], 0))  # the retry: front of the queue
        running = still
        if tail and not queue:
            size = _tail_size_gpu(len(running), size)
            sizes.add(size)
    return dict(seconds=seconds, segments=segments, sizes=sorted(sizes, reverse=True))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--csv", type=Path, required=True)
    parser.add_argument("--out", type=Path, default=RESULTS / "gpu_tail_model.md")
    args = parser.parse_args()
    rows = list(csv.DictReader(args.csv.open()))
    jobs = []
    for r in rows:
        steps, retries = int(float(r["steps"])), int(float(r["retries"] or 0))
        jobs.append((steps // 2, steps) if retries else (steps, 0))
    jobs.sort(key=lambda j: -(j[0] + j[1]))
    chain = max(a + b for a, b in jobs)
    lines = [
        "# A whole GPU sweep's time, modelled from measured parts (issue 11, goal 7)",
        "",
        f"`python benchmarks/gpu_tail_model.py --csv {args.csv}` · {len(rows)} collisions "
        f"of sweep_1024.py's grid (CPU table), repeated to n; mean "
        f"{np.mean([a + b for a, b in jobs]):.0f} Verlet steps a collision (every attempt), "
        f"longest chain {chain} (a first attempt and its rerun at half the step); GPU step "
        "times of the H200 scan (gpu_scan_check.md). **A model, not a measurement**; "
        "compilation not counted.",
        "",
        "| n | slots B | tail rule | modelled run s | collisions / s | segments | sizes |",
        "|---:|---:|---|---:|---:|---:|---|",
    ]
    for n, b in ((8192, 8192), (32768, 8192), (65536, 65536), (262144, 65536)):
        reps = -(-n // len(jobs))
        batch = sorted((jobs * reps)[:n], key=lambda j: -(j[0] + j[1]))
        for tail in (False, True):
            r = replay(batch, b, tail)
            lines.append(
                f"| {n} | {b} | {'on' if tail else 'off'} | {r['seconds']:.1f} "
                f"| {n / r['seconds']:.0f} | {r['segments']} | {r['sizes']} |"
            )
    lines += [
        "",
        "Measured on the H200 (gpu_sweep_8192.md), the first row's case: 8192 collisions on "
        "8192 slots without the tail rule, 72.1 s run (62.9 s of it in segments), 523 "
        "segments, 113.6 collisions/s.",
        "",
    ]
    args.out.write_text("\n".join(lines))
    print("\n".join(lines))


if __name__ == "__main__":
    main()
