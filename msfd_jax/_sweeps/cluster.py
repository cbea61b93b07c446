"""Sweeps on a Dask cluster: each task runs one batch of collisions in a worker process.

`connect` makes a ``distributed.Client``: ``local:N`` starts a ``LocalCluster`` of N
single-threaded worker processes on this machine (one intra-op thread each, see
`WORKER_ENV`); ``tcp://HOST:PORT`` joins a running scheduler (a dask-jobqueue cluster on
SLURM or PBS, for example; see docs/scaling.md). `solve_on_cluster` splits the collisions
into tasks of `task_size`, submits them, and hands each task's rows to `on_rows` as it
finishes. A task is ``solve_collisions`` on its rows, the same unit of work as an in-process
sweep, so the rows are the in-process ones. Dask reruns the tasks of a lost worker (up to
``distributed.scheduler.allowed-failures`` times). Workers enable JAX's persistent compile
cache in the directory given, so only the first worker to meet a program compiles it: with a
cache, the first task runs alone and the others are submitted when it has finished, since
workers that meet a program at the same moment all miss the cache and all compile it (seen
in the suite: two workers compiling one exported program at once, 16.7 CPU-s).

dask.distributed is an optional extra (``pip install 'msfd-jax[cluster]'``), imported here
only when a cluster is used.
"""

from __future__ import annotations

import os
import re
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from .._runtime import export as _export

# One intra-op thread per worker process: N processes then share N cores without
# oversubscription (XLA's CPU client otherwise sizes its pools to every core of the machine).
WORKER_ENV = {"XLA_FLAGS": "--xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1"}
_SPEC = re.compile(r"local:(\d+)|tcp://[^\s:/]+:\d+|tls://[^\s:/]+:\d+")
CLUSTER_SYNTAX = "local:N (N >= 1 worker processes on this machine) or tcp://HOST:PORT"


def parse(spec: str) -> tuple[str, Any]:
    """``("local", N)`` or ``("address", "tcp://HOST:PORT")``; ValueError for anything else."""
    match = _SPEC.fullmatch(spec.strip())
    if match is None or (match.group(1) is not None and int(match.group(1)) < 1):
        raise ValueError(f"cluster must be {CLUSTER_SYNTAX}, got {spec!r}")
    if match.group(1) is not None:
        return "local", int(match.group(1))
    return "address", spec.strip()


def import_distributed():
    """The ``distributed`` module, or ImportError naming the extra that provides it."""
    try:
        import distributed
    except ImportError:
        raise ImportError(
            "a cluster sweep needs dask.distributed: pip install 'msfd-jax[cluster]'"
        ) from None
    return distributed


def connect(spec: str, timeout: float = 30.0, worker_env: Mapping[str, str] | None = None):
    """A ``distributed.Client`` for `spec` (see `parse`); close it (and its cluster) after.

    ``local:N``: a LocalCluster of N worker processes, one thread each, with `worker_env`
    (default `WORKER_ENV`) added to their environment (they inherit this process's, so
    ``PYTHONPATH`` and ``MSFD_CACHE_DIR`` reach them; its ``XLA_FLAGS`` come first in theirs,
    so a flag set here reaches them too) and no dashboard.
    """
    kind, value = parse(spec)
    distributed = import_distributed()
    if kind == "address":
        return distributed.Client(value, timeout=timeout)
    cluster = distributed.LocalCluster(
        n_workers=value,
        threads_per_worker=1,
        processes=True,
        # no dashboard; the scheduler's HTTP endpoints on a free port (its default, 8787, is
        # taken by the first cluster on the machine, and a second would warn)
        dashboard_address=":0",
        scheduler_kwargs={"dashboard": False},
        env=_with_own_flags(WORKER_ENV if worker_env is None else worker_env),
    )
    client = distributed.Client(cluster, timeout=timeout)
    client.msfd_owns_cluster = cluster  # closed by `close`
    return client


def _with_own_flags(env: Mapping[str, str]) -> dict[str, str]:
    """`env` with this process's XLA_FLAGS before its own (the workers' env replaces a
    variable it names: without this, a user's flags would not reach the workers)."""
    out = dict(env)
    own = os.environ.get("XLA_FLAGS", "").strip()
    if own and "XLA_FLAGS" in out:
        out["XLA_FLAGS"] = f"{own} {out['XLA_FLAGS']}"
    return out


def close(client) -> None:
    """Close a client made by `connect` and, for ``local:N``, its cluster."""
    cluster = getattr(client, "msfd_owns_cluster", None)
    client.close()
    if cluster is not None:
        cluster.close()


def solve_on_cluster(
    client,
    solve: Callable[..., dict[str, np.ndarray]],
    columns: Mapping[str, np.ndarray],
    rows: np.ndarray,
    task_size: int,
    kwargs: dict[str, Any],
    on_rows: Callable[[np.ndarray, dict[str, np.ndarray]], None],
    compile_cache: str | Path | None = None,
) -> None:
    """Run the collisions `rows` of `columns` as tasks of `task_size` rows on `client`.

    Each task calls ``solve(batch_columns, **kwargs)`` in a worker; `on_rows(rows, outputs)`
    gets each task's positions (in `columns`) and output columns as the task finishes, in
    the order tasks finish. An exception in a task or in `on_rows` cancels the tasks left.
    With a `compile_cache`, the first task runs alone and primes the cache: the other tasks
    are submitted when it has finished, so their workers load its programs (the module's
    docstring).
    """
    distributed = import_distributed()
    batches = [rows[s : s + task_size] for s in range(0, len(rows), task_size)]
    cache = None if compile_cache is None else str(compile_cache)
    futures = {}

    def submit(batch):
        part = {k: np.asarray(v)[batch] for k, v in columns.items()}
        future = client.submit(_task, solve, part, kwargs, cache, pure=False)
        futures[future] = batch
        return future

    prime = cache is not None and len(batches) > 1
    first, rest = (batches[:1], batches[1:]) if prime else (batches, [])
    try:
        finished = distributed.as_completed([submit(b) for b in first], with_results=True)
        for future, outputs in finished:
            if rest:  # the first task has primed the cache: the others now
                finished.update([submit(b) for b in rest])
                rest = []
            on_rows(futures[future], outputs)
            future.release()
    finally:
        client.cancel([f for f in futures if not f.done()])


def _task(solve, columns, kwargs, compile_cache):
    """One task, in a worker: set the worker up once, then solve its collisions."""
    if compile_cache is not None:
        use_compile_cache(compile_cache)
    return solve(columns, **kwargs)


_CACHE: list[str] = []


def use_compile_cache(path: str | Path) -> None:
    """JAX's persistent compile cache in `path` for this process (once per process), with
    the store of traced programs in it: what ``msfd_jax.cli.common.enable_compilation_cache``
    does for the CLI, for a worker (`_runtime.export.use_with_compile_cache`: equinox's
    runtime checks as ``nan`` unless ``EQX_ON_ERROR`` is set, every program cached, and a new
    worker loads the queue's programs instead of tracing them).
    """
    path = str(Path(path).expanduser())
    if path in _CACHE:
        return
    _export.use_with_compile_cache(path)
    _CACHE.append(path)
