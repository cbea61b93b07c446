"""A sweep's stability pass: every collision's stability limit before the queue starts.

Before its first segment, `sweep` computes each collision's stability limit (the largest
eigenvalue of the scene's stiffness, `critical_step`) in chunks of the sweep's slots, one
after another in the calling thread, so that one step bound serves every chunk. This times
the pass on the grid of goal 2 of issue 11 (1024 paper-mesh collisions, 32 chunks of 32;
best of 3), and the eigen-solve alone per matrix at B = 1 and B = 32 (`jnp.linalg.eigvalsh`
of 84 x 84 matrices, the paper mesh's size; XLA:CPU's LAPACK call, which computes the
eigenvectors too), to show where the pass's time goes.

    python benchmarks/stability_pass.py    # writes benchmarks/results/stability_pass.md
"""

from __future__ import annotations

import datetime
import os

import _bench
from sweep_budget import GRID  # goal 2's grid, as sweep_1024.py's CLI gives it

ROUNDS = 3


def main() -> None:
    import jax
    import jax.numpy as jnp
    import numpy as np

    import msfd_jax as m
    from msfd_jax._queue import DEFAULT_SLOTS
    from msfd_jax._shard import _critical_chunk, _run_chunk
    from msfd_jax._sweep import _smoothing_arrays, collisions

    columns, _ = collisions(GRID)
    n, b = len(columns["thickness_ratio"]), DEFAULT_SLOTS
    chunks = [range(s, min(s + b, n)) for s in range(0, n, b)]
    mesh, smoothing = m.Mesh(), _smoothing_arrays(0.0, 0.0)

    def stability_pass():
        return [_run_chunk(_critical_chunk, columns, c, b, mesh, smoothing) for c in chunks]

    _, times = _bench.interleaved_times({"pass": (stability_pass,)}, ROUNDS)  # after compiling
    passes = times["pass"]

    rng = np.random.default_rng(0)
    stiff = rng.standard_normal((b, 84, 84))
    stiff = jnp.asarray(stiff + stiff.transpose(0, 2, 1))
    eig = jax.jit(jax.vmap(lambda k: jnp.max(jnp.linalg.eigvalsh(k))))
    eig_best = _bench.interleaved_best({size: (eig, stiff[:size]) for size in (1, b)}, 7)
    per_matrix = {size: 1e3 * t / size for size, t in eig_best.items()}

    date = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")
    best = min(passes)
    lines = [
        "# A sweep's stability pass (issue 11, goal 2's grid)",
        "",
        f"`python benchmarks/stability_pass.py` · {date} · {os.cpu_count()} cores · jax "
        f"{jax.__version__}",
        "",
        f"{n} paper-mesh collisions in {len(chunks)} chunks of {b}, one after another: "
        f"**{best:.2f} s** (best of {ROUNDS}: " + ", ".join(f"{t:.2f}" for t in passes)
        + f" s), {1e3 * best / n:.2f} ms per collision, on one core before the queue starts.",
        "",
        f"The eigen-solve alone: {per_matrix[1]:.2f} ms per 84 x 84 matrix at B = 1, "
        f"{per_matrix[b]:.2f} ms at B = {b} (best of 7).",
        "",
        "Not spread over threads: two threads running the pass's program at once deadlocked "
        "(once, when tried) on jax 0.10.2's CPU client (`msfd_jax/_shard.py`, `_critical_chunk`).",
    ]  # fmt: skip
    _bench.write_result("stability_pass.md", lines)


if __name__ == "__main__":
    main()
