"""Compiled programs against the process's memory-map limit (Linux ``vm.max_map_count``).

XLA:CPU maps memory for every kernel of every compiled program and keeps it while the
program is cached: one collision program of the small mesh takes ~1300 mappings, a sweep's
three queue programs ~1400 (``python benchmarks/memory_maps.py``). Linux allows 65 530 per
process by default, and once they are used up the next compilation dies in XLA's code with a
segmentation fault, no Python error (it happened in CI: `tests/test_sweep.py` crashed with
65 304 mappings in use, after ~400 tests had compiled their programs in one process).

So a process that compiles many different scenes (meshes, static settings, slot counts) in
one session, a notebook or a long study, would crash after some dozens of them. The public
entry points (`run`, `sweep`) call `release_if_near_limit` first: above `RELEASE_AT` of the
limit, JAX's compiled programs are dropped (`jax.clear_caches`), so the next solve
recompiles instead of crashing, and a `CompiledProgramsReleased` warning says so and how to
raise the limit. Elsewhere than Linux (no ``/proc``) nothing is checked.
"""

from __future__ import annotations

import gc
import warnings

LIMIT_PATH = "/proc/sys/vm/max_map_count"
MAPS_PATH = "/proc/self/maps"
RELEASE_AT = 0.75  # of the limit: room for the ~1400 mappings of the next sweep, and more


class CompiledProgramsReleased(RuntimeWarning):
    """JAX's compiled programs were dropped to stay under the process's memory-map limit."""


def usage() -> tuple[int, int] | None:
    """(memory mappings of this process, the limit), or None where /proc does not say."""
    try:
        with open(LIMIT_PATH, "rb") as stream:
            limit = int(stream.read())
        with open(MAPS_PATH, "rb") as stream:
            count = stream.read().count(b"\n")
    except (OSError, ValueError):
        return None
    return count, limit


def release(fraction: float) -> tuple[int, int, int] | None:
    """Drop JAX's compiled programs if this process uses more than `fraction` of its
    memory-map limit. Returns (mappings before, after, limit) when it did, else None."""
    now = usage()
    if now is None or now[0] < fraction * now[1]:
        return None
    import jax

    jax.clear_caches()
    gc.collect()
    after = usage()
    return now[0], (now[0] if after is None else after[0]), now[1]


def release_if_near_limit() -> None:
    """`release` at `RELEASE_AT`, with a `CompiledProgramsReleased` warning when it did."""
    done = release(RELEASE_AT)
    if done is None:
        return
    before, after, limit = done
    warnings.warn(
        f"this process used {before} of its {limit} memory mappings (vm.max_map_count), "
        "most of them by compiled XLA programs; past the limit the next compilation would "
        f"crash the interpreter, so JAX's compiled programs were released ({after} mappings "
        "now) and the next solve of each scene compiles again. To keep them, raise the limit "
        "(sudo sysctl -w vm.max_map_count=262144) or use fewer distinct meshes and static "
        "settings per process",
        CompiledProgramsReleased,
        stacklevel=3,
    )
