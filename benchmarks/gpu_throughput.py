"""Sweep throughput on a GPU (issue 11, goal 7): collisions/s against the slot count.

With a GPU (``pip install ".[cuda]"``): paper-mesh sweeps of `--n` collisions (h_b/h_r
0.25-5 in n // 16 values x free/held x g = 5, 10, 20, 40 x v0 = 0.6, 0.82: sweep_1024.py's
grid, finer) through the batched core with B = `--slots` slots (one worker: the GPU is one
device), each compiled first and then timed (run time without compilation, `LAST_TIMING`);
the table gives collisions/s, µs per collision-step and the best B. Without a GPU it says
so, measures nothing and writes that to the results file. ``--platform cpu`` runs the same
code on the CPU (small sizes) to check the script where no GPU is.

    python benchmarks/gpu_throughput.py                    # writes benchmarks/results/gpu.md
    python benchmarks/gpu_throughput.py --platform cpu --n 64 --slots 16 32 --out /tmp/gpu.md
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime
import sys
from pathlib import Path

RESULTS = Path(__file__).resolve().parent / "results"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--platform", default="gpu", choices=["gpu", "cpu"])
    parser.add_argument("--n", type=int, default=8192, help="collisions per sweep")
    parser.add_argument("--slots", nargs="+", type=int, default=[256, 1024, 4096, 8192])
    parser.add_argument("--out", type=Path, default=RESULTS / "gpu.md")
    args = parser.parse_args()
    import jax
    import numpy as np

    import msfd_jax as m
    from msfd_jax import _sweep

    date = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")
    head = [
        "# Sweep throughput on a GPU (issue 11, goal 7)",
        "",
        f"`python benchmarks/gpu_throughput.py {' '.join(sys.argv[1:])}`".replace(" `", "`")
        + f" · {date} · jax {jax.__version__}",
        "",
    ]
    try:
        devices = jax.devices(args.platform)
    except RuntimeError:
        devices = []
    if not devices:
        text = (
            f"No {args.platform.upper()} here (jax's devices: {jax.devices()}): nothing "
            'measured. Install the CUDA extra (`pip install ".[cuda]"`) on a machine with an '
            "NVIDIA GPU and rerun."
        )
        print(text)
        args.out.write_text("\n".join([*head, text, ""]))
        return
    grid = {
        "thickness_ratio": np.linspace(0.25, 5.0, max(1, args.n // 16)),
        "axial_constraint": [0.0, 1.0],
        "mass_ratio": [5.0, 10.0, 20.0, 40.0],
        "velocity": [0.6, 0.82],
    }
    settings = dataclasses.replace(_sweep.SWEEP_SETTINGS, t_max=10.0)
    rows = []
    with jax.default_device(devices[0]):
        for b in args.slots:
            kw = dict(chunk_size=b, workers=1)
            m.sweep(grid, m.Mesh(), settings, **kw)  # compile first
            table = m.sweep(grid, m.Mesh(), settings, **kw)
            t = dict(_sweep.LAST_TIMING)
            steps = int(np.sum(table["steps"]))
            rows.append((b, len(table), t["run_s"], steps))
            print(f"B = {b}: {len(table)} collisions in {t['run_s']:.2f} s "
                  f"({len(table) / t['run_s']:.1f}/s)", flush=True)  # fmt: skip
    best = max(rows, key=lambda r: r[1] / r[2])
    lines = [
        *head,
        f"Device: {devices[0].device_kind} ({devices[0].platform}); paper mesh, sharp laws, "
        "fixed cap tau = 10.",
        "",
        "| slots B | collisions | run s (no compile) | collisions/s | µs / collision-step |",
        "|---:|---:|---:|---:|---:|",
        *[f"| {b} | {n} | {s:.2f} | {n / s:.1f} | {s / k * 1e6:.4f} |" for b, n, s, k in rows],
        "",
        f"Best batch: B = {best[0]} ({best[1] / best[2]:.1f} collisions/s).",
        "",
    ]
    args.out.write_text("\n".join(lines))


if __name__ == "__main__":
    main()
