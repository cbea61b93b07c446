"""Small pieces the benchmarks share: where results go (``--quick`` apart), goal 2's grid,
the sweep's default settings and a grid's rows, pinning to one core, a batch of showcase-like
collisions, a loop of Verlet substeps, and interleaved timing."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

RESULTS = Path(__file__).resolve().parent / "results"
# Issue 11 goal 2's grid (the CLI's --thickness-ratio 0.25:5:64 --axial-constraint both
# --mass-ratio 5,10,20,40 --velocity 0.6,0.82): 1024 collisions.
GRID = dict(
    thickness_ratio=[float(v) for v in np.linspace(0.25, 5.0, 64)],
    axial_constraint=[0.0, 1.0],
    mass_ratio=[5.0, 10.0, 20.0, 40.0],
    velocity=[0.6, 0.82],
)


def results_dir(quick: bool = False) -> Path:
    """Where a benchmark writes its result: ``$MSFD_BENCH_RESULTS`` if set, else
    benchmarks/results/ for a full run and a scratch folder for ``--quick`` (so that a quick
    run never replaces the committed result that docs/performance.md is written from)."""
    import tempfile

    env = os.environ.get("MSFD_BENCH_RESULTS")
    if env:
        path = Path(env)
    elif quick:
        path = Path(tempfile.gettempdir()) / "msfd-bench-quick"
    else:
        path = RESULTS
    path.mkdir(parents=True, exist_ok=True)
    return path


def add_quick(parser) -> None:
    """The ``--quick`` flag every benchmark takes: a small form that finishes in about a
    minute and writes to `results_dir(quick=True)`."""
    parser.add_argument(
        "--quick",
        action="store_true",
        help="a small form (about a minute) that checks the benchmark runs; writes to "
        "$MSFD_BENCH_RESULTS or a scratch folder, never benchmarks/results/",
    )


def pin() -> None:
    """Re-execute this script under ``taskset -c CORE`` (MSFD_BENCH_CORE, default 0) once."""
    if os.environ.get("MSFD_BENCH_PINNED") or shutil.which("taskset") is None:
        return
    env = dict(os.environ, MSFD_BENCH_PINNED="1")
    core = os.environ.get("MSFD_BENCH_CORE", "0")
    raise SystemExit(subprocess.call(["taskset", "-c", core, sys.executable, *sys.argv], env=env))


def sweep_settings():
    """The settings `msfd_jax.sweep` runs with by default (two history samples, no shapes):
    its signature's default, so that a benchmark times what a plain sweep runs."""
    import inspect

    import msfd_jax as m

    return inspect.signature(m.sweep).parameters["settings"].default


def grid_rows(grid: dict) -> list[dict]:
    """The collisions of a sweep's grid (a dict of value lists) as one dict each, in the
    order `msfd_jax.sweep` runs them (the Cartesian product, the last key fastest)."""
    import itertools

    return [dict(zip(grid, point, strict=True)) for point in itertools.product(*grid.values())]


def batch_params(b: int, thickness=(0.5, 4.0)):
    """B collisions like the showcase (held, g = 10, v0 = 0.82), h_b/h_r spread over
    `thickness`, every field an array of shape (B,)."""
    import jax.numpy as jnp

    import msfd_jax as m

    return m.CollisionParams(**{
        "thickness_ratio": jnp.linspace(*thickness, b), "axial_constraint": jnp.ones(b),
        "mass_ratio": jnp.full(b, 10.0), "velocity": jnp.full(b, 0.82),
        "modulus_ratio": jnp.full(b, 500.0), "slenderness": jnp.full(b, 30.0),
        "span_ratio": jnp.full(b, 5.0), "width_ratio": jnp.ones(b),
    })  # fmt: skip


def scaled_mesh(factor: int):
    """The paper's mesh with every segment count times `factor`."""
    import msfd_jax as m

    base = m.Mesh()
    return m.Mesh(
        ring_segments=base.ring_segments * factor,
        beam_contact_segments=base.beam_contact_segments * factor,
        beam_outer_segments=base.beam_outer_segments * factor,
    )


def showcase_steps(mesh) -> tuple[float, int]:
    """The showcase collision's step and step count on `mesh` (t_max = 10)."""
    import msfd_jax as m

    show = m.run(m.CollisionParams(), mesh, m.Settings(t_max=10.0))
    return float(show.solution.dt), int(show.solution.steps)


def half_way(mesh, b: int, dt: float, steps: int):
    """B showcase-like collisions (`batch_params` with h_b/h_r 2-3) on `mesh` in the sweep's
    slots, advanced by `steps` // 2 substeps of `dt` (contact engaged): (flat, clock, y, h)."""
    import dataclasses

    import jax.numpy as jnp

    # the sweep queue's slots themselves (no public API: `sweep` runs them to the end), so
    # that the engine's substeps can be timed from a state half-way through the collisions
    from msfd_jax._sweeps import queue as _queue

    settings = dataclasses.replace(sweep_settings(), t_max=10.0)
    p = batch_params(b, (2.0, 3.0))
    smoothing = _queue.with_flags((0.0, 0.0))
    flat, clock, y = _queue._start(p, jnp.full(b, dt / 0.7), mesh, smoothing, settings, 1e7)
    h = jnp.full(b, dt)
    return flat, clock, substep_loop(steps // 2, h, clock.tolerance)(flat, y), h


def write_result(name: str, lines: list[str], quick: bool = False) -> str:
    """Print the report and write it to `results_dir(quick)` / `name`."""
    text = "\n".join(lines) + "\n"
    print(text)
    (results_dir(quick) / name).write_text(text)
    return text


def substep_loop(steps: int, h, tolerance, listed: bool = False):
    """A compiled ``fori_loop`` of `steps` Verlet substeps of length h (B,): f(flat, y);
    `listed`: the contact's listed loop (``Settings.contact_loop``), else one per block."""
    import equinox as eqx
    import jax

    # the batched engine's Verlet substep itself: what this loop times (no public API)
    from msfd_jax._batched import engine as _engine

    def loop(flat, y):
        loop_name = "listed" if listed else "blocks"
        body = lambda i, s: _engine.verlet_substep(flat, s, i * h, h, tolerance, loop_name)  # noqa: E731
        return jax.lax.fori_loop(0, steps, body, y)

    return eqx.filter_jit(loop)


def interleaved_times(programs: dict, rounds: int) -> tuple[dict, dict]:
    """Wall times of each ``(f, *args)`` in `programs`: its first call (compilation) and
    `rounds` more, timed in turn round after round (so a noisy neighbour weighs on all alike).

    Each round starts one program further along (round r times them from the r-th on). In a
    fixed order the program timed first in every round runs right after programs of another
    working set, and in ad hoc runs it came out slower than variants of equal cost timed
    after it, so a table's first column was penalised."""
    import jax

    def timed(f, *a):
        tick = time.perf_counter()
        jax.block_until_ready(f(*a))
        return time.perf_counter() - tick

    first = {key: timed(*program) for key, program in programs.items()}
    times: dict = {key: [] for key in programs}
    keys = list(programs)
    for r in range(rounds):
        shift = r % len(keys)
        for key in keys[shift:] + keys[:shift]:
            times[key].append(timed(*programs[key]))
    return first, times


def interleaved_best(programs: dict, rounds: int) -> dict:
    """Best wall time of each ``(f, *args)`` in `programs` over `rounds` interleaved rounds
    after a first call (`interleaved_times`)."""
    _, times = interleaved_times(programs, rounds)
    return {key: min(t) for key, t in times.items()}
