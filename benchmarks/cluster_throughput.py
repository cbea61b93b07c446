"""Cluster throughput: the same sweep in process and on Dask LocalClusters of 1 and 2 workers.

The 64-collision sweep of `sweep_throughput.py` (h_b/h_r 0.25..5 x free/held x g = 5, 10) on
the paper's mesh, chunks of 8 (tasks of 8 collisions on the clusters), side by side in one
run: in process (JAX's default threads), LocalCluster with 1 and 2 single-threaded workers
(`msfd_jax._sweeps.cluster.WORKER_ENV`), and 2 workers with XLA's default threading. Each
configuration first runs one task's worth of collisions (compiling it, or loading it from the
shared persistent compile cache: the first cluster compiles, the later ones load), then the
whole sweep is timed: collisions/s exclude start-up and compilation. Every table is compared
with the in-process one. Writes ``benchmarks/results/cluster.md`` (and ``cluster.json``).

    python benchmarks/cluster_throughput.py
    python benchmarks/cluster_throughput.py --quick   # 16 collisions, small mesh, 2 configs
"""

from __future__ import annotations

import argparse
import itertools
import json
import os
import platform
import sys
import tempfile
import time
from pathlib import Path

import _bench
import jax
import numpy as np

import msfd_jax as m

# the Dask client that `msfd sweep --cluster local:N` makes (`connect`, `close`) and its
# single-threaded workers' environment (`WORKER_ENV`): measured as the CLI sets them up
# (`sweep` takes a client, but no public msfd_jax function makes one)
from msfd_jax._sweeps import cluster as _cluster

MESH = m.Mesh()
GRID = {
    "thickness_ratio": np.linspace(0.25, 5.0, 16),
    "axial_constraint": [0.0, 1.0],
    "mass_ratio": [5.0, 10.0],
}
CHUNK = 8
CONFIGS = [  # name, workers (None: in process), worker environment
    ("in process", None, None),
    ("LocalCluster, 1 worker, 1 thread", 1, _cluster.WORKER_ENV),
    ("LocalCluster, 2 workers, 1 thread each", 2, _cluster.WORKER_ENV),
    ("LocalCluster, 2 workers, XLA default threads", 2, {}),
]


def first_rows() -> list[dict]:
    points = list(itertools.product(*GRID.values()))[:CHUNK]
    return [dict(zip(GRID, p, strict=True)) for p in points]


def measure(name, workers, env, cache: Path, reference) -> tuple[dict, object]:
    mesh = MESH
    tick = time.perf_counter()
    client = None if workers is None else _cluster.connect(f"local:{workers}", worker_env=env)
    started = time.perf_counter() - tick
    options = dict(chunk_size=CHUNK, client=client, compile_cache=cache)
    try:
        tick = time.perf_counter()
        m.sweep(first_rows(), mesh, **options)
        first = time.perf_counter() - tick
        if client is not None and workers > 1:  # every worker meets the program once
            tick = time.perf_counter()
            m.sweep(first_rows() * workers, mesh, **options, task_size=CHUNK)
            first = max(first, time.perf_counter() - tick)
        table = m.sweep(GRID, mesh, **options)
    finally:
        if client is not None:
            _cluster.close(client)
    reference = table if reference is None else reference
    gap = max(
        float(np.max(np.abs(table[k] - reference[k])))
        for k in table.keys()
        if table[k].dtype.kind == "f" and k != "wall_time_s"
    )
    record = dict(
        config=name,
        workers=workers,
        start_s=started,
        first_task_s=first,
        wall_s=table.wall_time_s,
        collisions=len(table),
        collisions_per_s=len(table) / table.wall_time_s,
        max_abs_difference_from_in_process=gap,
        load_average_1min=os.getloadavg()[0],
    )
    print(json.dumps(record), flush=True)
    return record, reference


def write(records: list[dict], quick: bool = False) -> None:
    results = _bench.results_dir(quick)
    machine = dict(platform=platform.platform(), cpus=os.cpu_count(), jax=jax.__version__)
    command = " ".join(["python benchmarks/cluster_throughput.py", *sys.argv[1:]])
    (results / "cluster.json").write_text(
        json.dumps(dict(command=command, machine=machine, runs=records), indent=1) + "\n"
    )
    base = records[0]["collisions_per_s"]
    mesh_name = "a small" if quick else "the paper's"
    lines = [
        "# Cluster throughput (Dask LocalCluster)",
        "",
        f"Written by `{command}` on {machine['platform']}, {machine['cpus']} CPUs, "
        f"jax {machine['jax']} (cpu), {time.strftime('%Y-%m-%d')}.",
        f"Sweep: {len(list(itertools.product(*GRID.values())))} collisions (h_b/h_r = 0.25..5 x "
        f"free/held x g = 5, 10; v0 = 0.82), {mesh_name}"
        f" mesh, default sweep settings, chunks (and Dask tasks) of {CHUNK} collisions.",
        "Collisions/s exclude start-up and compilation (each configuration first runs one task "
        "per worker); `first task` includes compiling or loading the shared compile cache "
        "(the first cluster compiles, the later ones load). The CPUs are shared with other "
        "work: see the load average.",
        "",
        "| configuration | start [s] | first task [s] | wall [s] | collisions/s | vs in process "
        "| max diff from in process | load (1 min) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in records:
        lines.append(
            f"| {r['config']} | {r['start_s']:.2g} | {r['first_task_s']:.3g} | "
            f"{r['wall_s']:.3g} | {r['collisions_per_s']:.3g} | "
            f"{r['collisions_per_s'] / base:.2f}x | {r['max_abs_difference_from_in_process']:.1e} "
            f"| {r['load_average_1min']:.2f} |"
        )
    (results / "cluster.md").write_text("\n".join(lines) + "\n")


def main() -> None:
    global MESH, GRID
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    _bench.add_quick(parser)
    args = parser.parse_args()
    configs = CONFIGS
    if args.quick:
        MESH = m.Mesh(ring_segments=6, beam_contact_segments=8, beam_outer_segments=2)
        GRID = dict(GRID, thickness_ratio=np.linspace(0.25, 5.0, 4))
        configs = [CONFIGS[0], CONFIGS[2]]
    records, reference = [], None
    with tempfile.TemporaryDirectory() as cache:
        for name, workers, env in configs:
            record, reference = measure(name, workers, env, Path(cache), reference)
            records.append(record)
    write(records, args.quick)


if __name__ == "__main__":
    main()
