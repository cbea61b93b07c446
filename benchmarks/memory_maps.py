"""Memory mappings that XLA:CPU keeps per compiled program (the stop-19 CI segfault).

Counts this process's mappings (/proc/self/maps) before and after one collision run and one
sweep on the small test mesh (each compiles its own programs), after `jax.clear_caches()`,
and prints how many distinct programs fit under vm.max_map_count. Linux only.

    python benchmarks/memory_maps.py            # writes benchmarks/results/memory_maps.md
    python benchmarks/memory_maps.py --quick    # the same (it is small), to a scratch folder
"""

from __future__ import annotations

import argparse
import datetime
import gc
import os

import _bench
import jax

import msfd_jax as m

# the package's own count of this process's mappings and its release threshold (`RELEASE_AT`),
# which the table reports against (no public API)
from msfd_jax._runtime import mappings as _mappings


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    _bench.add_quick(parser)
    args = parser.parse_args()
    mesh = m.Mesh(ring_segments=6, beam_contact_segments=8, beam_outer_segments=2)
    settings = m.Settings(t_max=0.2, history_points=3, shape_times=())
    count = lambda: _mappings.usage()[0]  # noqa: E731
    start = count()
    m.run(m.CollisionParams(), mesh, settings)
    after_run = count()
    m.sweep([{"thickness_ratio": t} for t in (1.0, 2.0)], mesh, settings, workers=1)
    after_sweep = count()
    jax.clear_caches()
    gc.collect()
    cleared = count()
    limit = _mappings.usage()[1]
    run_maps, sweep_maps = after_run - start, after_sweep - after_run
    stamp = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")
    lines = [
        "# Memory mappings per compiled program (XLA:CPU)",
        "",
        f"`python benchmarks/memory_maps.py` · {stamp} · jax {jax.__version__} · "
        f"XLA_FLAGS={os.environ.get('XLA_FLAGS', '')!r} · vm.max_map_count {limit}",
        "",
        "| what | mappings |",
        "|---|---:|",
        f"| process after import and one op | {start} |",
        f"| + one `run` (its programs compiled) | {run_maps} |",
        f"| + one `sweep` (the queue's programs) | {sweep_maps} |",
        f"| after `jax.clear_caches()` (above the start) | {cleared - start} |",
        "",
        f"Distinct collision programs that fit under the limit: about {limit // run_maps}. "
        "msfd_jax releases compiled programs above "
        f"{_mappings.RELEASE_AT:g} of the limit (`msfd_jax/_runtime/mappings.py`).",
    ]
    _bench.write_result("memory_maps.md", lines, args.quick)


if __name__ == "__main__":
    main()
