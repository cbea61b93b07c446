"""Small pieces the core benchmarks share: pinning to one core, a batch of showcase-like
collisions, a loop of Verlet substeps, and interleaved timing."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import time


def pin() -> None:
    """Re-execute this script under ``taskset -c CORE`` (MSFD_BENCH_CORE, default 0) once."""
    if os.environ.get("MSFD_BENCH_PINNED") or shutil.which("taskset") is None:
        return
    env = dict(os.environ, MSFD_BENCH_PINNED="1")
    core = os.environ.get("MSFD_BENCH_CORE", "0")
    raise SystemExit(subprocess.call(["taskset", "-c", core, sys.executable, *sys.argv], env=env))


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

    from msfd_jax import _queue, _sweep

    settings = dataclasses.replace(_sweep.SWEEP_SETTINGS, t_max=10.0)
    p = batch_params(b, (2.0, 3.0))
    smoothing = _queue.with_flags((0.0, 0.0))
    flat, clock, y = _queue._start(p, jnp.full(b, dt / 0.7), mesh, smoothing, settings, 1e7)
    h = jnp.full(b, dt)
    return flat, clock, substep_loop(steps // 2, h, clock.tolerance)(flat, y), h


def write_result(name: str, lines: list[str]) -> str:
    """Print the report and write it to benchmarks/results/`name`."""
    from pathlib import Path

    text = "\n".join(lines) + "\n"
    print(text)
    results = Path(__file__).resolve().parent / "results"
    results.mkdir(exist_ok=True)
    (results / name).write_text(text)
    return text


def substep_loop(steps: int, h, tolerance, listed: bool = False):
    """A compiled ``fori_loop`` of `steps` Verlet substeps of length h (B,): f(flat, y);
    `listed`: the contact's listed loop (``Settings.contact_loop``), else one per block."""
    import equinox as eqx
    import jax

    from msfd_jax import _engine

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


def loop_body_fusions(jitted, *args) -> int:
    """Fusions (XLA:CPU kernels) in the body of the compiled program's first while loop: at
    a batch of one a substep costs about a fixed time per kernel, so this counts its work."""
    import re

    text = jitted.lower(*args).compile().as_text()
    body = re.search(r" while\(.*?body=(%?[\w.\-]+)", text).group(1).lstrip("%")
    block = re.search(rf"^%?{re.escape(body)} .*?\{{\n(.*?)^\}}", text, re.M | re.S).group(1)
    return len(re.findall(r"= \S+ fusion\(", block))
