"""Sweeps: many ring-on-beam collisions on the batched core, fed from one queue (`queue`).

A sweep is a grid (a dict of value lists) or a list of collisions (a list of dicts), in groups
or in SI (`_model.si.si_sweep`), every value validated before anything is traced. The result is a
`SweepTable`, one row per collision with its inputs and every output of ``msfd run --json``;
a failed run is a row with its status and `diagnose`'s message, never a silent NaN.

Graded beams: a collision of a list (or `base`) may give a ``thickness_profile``. Inside, the
profiles are one (n, segments) input column; the table has one column per segment,
``thickness_profile_0`` ... (`table.profile_names`; ``table["thickness_profile"]`` stacks them)
and ``beam_mass_ratio``. A sweep without profiles has neither, and runs as before.
"""

from __future__ import annotations

import dataclasses
import functools
import itertools
import math
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .._batched.peaks import PEAK_KEYS
from .._batched.results import RESULTS
from .._batched.simulate import (
    Settings,
    compiled_settings,
    require_float64,
    step_bound,
    undifferentiated,
)
from .._collision import attempts as _attempts
from .._collision.attempts import (
    RETRY_OUTPUTS,
    Attempts,
    assemble,
    smaller_step,
    solve_with_retries,
    with_retry_columns,
)
from .._collision.collapse import automatic, follow_collapse
from .._collision.provenance import mesh_json
from .._collision.run import FRACTION_KEYS, balance_warning, diagnose, fractions
from .._model.cap import T_MAX_CEILING
from .._model.params import PROFILE_FIELD, CollisionParams, Mesh, _check_count, validate
from .._model.scene import _ring_on_beam, beam_mass_ratio, smoothing_width
from .._model.si import si_columns, si_sweep
from .._runtime.mappings import release_if_near_limit
from .._runtime.progress import SweepProgress as _SweepProgress
from .cluster import solve_on_cluster
from .queue import DEFAULT_SLOTS, default_slots, default_workers, run_queue
from .shard import _critical_chunk, _run_chunk, _sharded_solver
from .store import match_rows, open_store
from .table import SweepTable, profile_names

# The one-number inputs, a column each; a graded beam's `PROFILE_FIELD` is a column of its own,
# (n, segments), present only in a sweep that has profiles (`input_columns` flattens it)
INPUTS = tuple(f.name for f in dataclasses.fields(CollisionParams) if f.name != PROFILE_FIELD)
KINETIC_KEYS = ("kinetic_ring", "kinetic_block", "kinetic_beam")
SOLVED_OUTPUTS = (
    *FRACTION_KEYS,
    *KINETIC_KEYS,
    "energy_balance_error",
    "t_end",
    "steps",
    "dt",
    "dt_critical",
    "k0",
    "result",
    "status",
    "balance_warning",
    "message",
    *PEAK_KEYS,
    "wall_time_s",
)
OUTPUTS = (*SOLVED_OUTPUTS, *RETRY_OUTPUTS)  # retries, safety: `_collision.attempts`
# Histories are (history_points, ...) per collision: a sweep keeps only the final partition,
# so by default it saves two history samples and no shapes (the outputs do not depend on them).
SWEEP_SETTINGS = Settings(history_points=2, shape_times=())
MAX_CHUNK = 65_536  # slots or vmapped rows per compiled call (chunks are padded to it)
DEFAULT_CHUNK = DEFAULT_SLOTS  # a CPU's slots per worker (None: `queue.default_slots`)


def collisions(
    grid_or_list: Mapping[str, Any] | Sequence[Mapping[str, Any]],
    base: CollisionParams = CollisionParams(),
) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray] | None]:
    """Expand a sweep into input columns (one float64 array per `INPUTS` name) and grid axes.

    A dict of value lists is a full grid (Cartesian product, last key fastest); a list of
    dicts is a list of collisions. Inputs not given take their value from `base`. Booleans
    (``axial_constraint``) become 1.0 / 0.0. Values are not range-checked here (`sweep` does).

    Graded beams: when a collision of the list (or `base`) has a ``thickness_profile``, the
    columns also hold it, (n, segments); a collision without one (or with None) is then given
    the equal profile of its ``thickness_ratio`` (the uniform beam, to rounding). Every
    profile of a sweep has the same length. A profile is no grid axis: give a list, or one
    profile for the whole grid in `base`.
    """
    if isinstance(grid_or_list, Mapping):
        _check_names(grid_or_list)
        if PROFILE_FIELD in grid_or_list:
            raise ValueError(
                f"{PROFILE_FIELD} cannot be a grid axis: give a list of collisions (one dict "
                f"each, with its {PROFILE_FIELD}), or one profile for the whole grid as "
                f"base=CollisionParams({PROFILE_FIELD}=[...])"
            )
        axes = {k: _values(k, v) for k, v in grid_or_list.items()}
        points = list(itertools.product(*axes.values()))
        given = {k: [p[i] for p in points] for i, k in enumerate(axes)}
        n, grid = len(points), axes
    else:
        rows = list(grid_or_list)
        for row in rows:
            if not isinstance(row, Mapping):
                raise TypeError(f"a sweep list holds dicts of inputs, got {row!r}")
            _check_names(row)
        names = {k for row in rows for k in row} - {PROFILE_FIELD}
        given = {k: [row.get(k, _base(base, k)) for row in rows] for k in names}
        n, grid = len(rows), None
    if n == 0:
        raise ValueError("a sweep needs at least one collision")
    columns = {k: np.full(n, _base(base, k)) for k in INPUTS}
    for k, v in given.items():
        columns[k] = np.asarray([_number(k, x) for x in v], dtype=np.float64)
    listed = [None] * n if grid is not None else [row.get(PROFILE_FIELD) for row in rows]
    profiles = _profiles(listed, base, columns["thickness_ratio"])
    if profiles is not None:
        columns[PROFILE_FIELD] = profiles
    return columns, grid


def _profiles(listed: list, base: CollisionParams, thickness: np.ndarray) -> np.ndarray | None:
    """The (n, segments) profile column: each collision's profile (None: `base`'s), the equal
    profile of its thickness_ratio for a uniform one; None when no collision is graded."""
    given = [base.thickness_profile if p is None else p for p in listed]
    if all(p is None for p in given):
        return None
    arrays = {i: _profile(i, p) for i, p in enumerate(given) if p is not None}
    lengths = sorted({len(a) for a in arrays.values()})
    if len(lengths) > 1:
        first = {size: next(i for i, a in arrays.items() if len(a) == size) for size in lengths}
        shown = ", ".join(f"collision {i} has {size}" for size, i in first.items())
        raise ValueError(
            f"{PROFILE_FIELD}: every profile of a sweep has one value per beam segment of its "
            f"mesh, the same count; {shown}"
        )
    out = np.repeat(thickness[:, None], lengths[0], axis=1)  # the uniform ones: equal values
    for i, a in arrays.items():
        out[i] = a
    return out


def _profile(i: int, value: Any) -> np.ndarray:
    """Collision `i`'s profile as a 1-D float64 array (its range is checked with the rest)."""
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        arr = None
    if arr is None or isinstance(value, str | bytes) or np.asarray(value).dtype.kind == "b":
        raise TypeError(
            f"{PROFILE_FIELD} of collision {i} must be a list of real numbers (h_k/h_r of "
            f"every beam segment, O to E), got {value!r}"[:300]
        )
    if arr.ndim != 1 or arr.size == 0:
        raise ValueError(
            f"{PROFILE_FIELD} of collision {i} must be one list of h_k/h_r (one value per beam "
            f"segment, O to E), got shape {arr.shape}"
        )
    return arr


def input_columns(columns: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The input columns as a table has them: `INPUTS`, then a profile's segments one column
    each (``thickness_profile_0`` ...: CSV, Parquet and xarray take 1-D columns only)."""
    out = {k: columns[k] for k in INPUTS}
    if PROFILE_FIELD in columns:
        profile = np.asarray(columns[PROFILE_FIELD])
        out.update(zip(profile_names(profile.shape[1]), profile.T, strict=True))
    return out


def mass_ratios(columns: Mapping[str, np.ndarray], mesh: Mesh) -> np.ndarray:
    """Each collision's `beam_mass_ratio` (beam mass over its uniform thickness_ratio beam's)."""
    names = [*INPUTS, *([PROFILE_FIELD] if PROFILE_FIELD in columns else [])]
    params = CollisionParams(**{k: np.asarray(columns[k], np.float64) for k in names})
    validate(params, mesh)
    return np.asarray(_mass_ratio_program(params, mesh), dtype=np.float64)


@eqx.filter_jit
def _mass_ratio_program(params: CollisionParams, mesh: Mesh):
    return jax.vmap(lambda p: beam_mass_ratio(p, mesh))(params)


def _check_names(mapping: Mapping[str, Any]) -> None:
    allowed = (*INPUTS, PROFILE_FIELD)
    unknown = sorted(set(mapping) - set(allowed))
    if unknown:
        raise ValueError(f"unknown sweep inputs {unknown}; allowed: {', '.join(allowed)}")


def _values(name: str, values: Any) -> np.ndarray:
    out = np.asarray([_number(name, v) for v in np.atleast_1d(np.asarray(values, dtype=object))])
    if out.size == 0:
        raise ValueError(f"{name}: a grid axis needs at least one value")
    return out.astype(np.float64)


def _number(name: str, value: Any) -> float:
    if isinstance(value, bool | np.bool_):
        return 1.0 if value else 0.0
    try:
        return float(value)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be a real number, got {value!r}") from None


def _base(base: CollisionParams, name: str) -> float:
    return _number(name, np.asarray(getattr(base, name)).item())


def sweep(
    grid_or_list: Mapping[str, Any] | Sequence[Mapping[str, Any]],
    mesh: Mesh = Mesh(),
    settings: Settings = SWEEP_SETTINGS,
    chunk_size: int | None = None,
    progress: bool = False,
    *,
    base: CollisionParams = CollisionParams(),
    contact_smoothing: float = 0.0,
    yield_smoothing: float = 0.0,
    shard: bool = False,
    output: str | Path | None = None,
    resume: bool = False,
    client: Any = None,
    task_size: int | None = None,
    compile_cache: str | Path | None = None,
    workers: int | None = None,
    on_rows: Callable[[np.ndarray, dict[str, np.ndarray]], None] | None = None,
) -> SweepTable:
    """Run a grid or list of collisions on `chunk_size` slots per worker, refilled as they stop.

    **Arguments:**
    - `grid_or_list`: ``{"thickness_ratio": [1, 2.5], "axial_constraint": [0, 1]}`` (a full
      grid) or ``[{"thickness_ratio": 1.0}, {"mass_ratio": 5.0}, ...]`` (a list); the keys are
      `INPUTS` (the fields of `CollisionParams`), anything not given is taken from `base`;
      or SI inputs (`run_si`'s keywords, missing ones `PAPER_SI`'s): the table then also has
      the SI inputs, scales, energies in J and the peaks in SI (`msfd_jax._model.si.si_columns`).
    - `mesh`, `settings`: as for `run`. The default settings keep two history samples and no
      shapes (a sweep keeps only final values). `Settings.max_steps`, when None, is the bound
      `simulate` would take for the smallest step of the sweep (of the task, on a cluster):
      every collision's computed stability limit is evaluated first (a small vmapped
      program), so that one bound, and so one compiled program, serves all chunks.
    - `chunk_size`: slots of the batched core (rounded up to a power of two, at least 16):
      collisions that run together, each stopped slot refilled from the queue (memory is one
      batch of slots; None: 32 on a CPU, 8192 on a GPU). With `shard`, per sharded chunk.
    - `progress`: a progress bar on stderr (tqdm; off by default, on in the CLI).
    - `shard`: split each chunk across all JAX devices with `jax.shard_map` (each device runs
      its own stopping loop); `chunk_size` must then be a multiple of the device count.
      On CPU, start with ``XLA_FLAGS=--xla_force_host_platform_device_count=<cores>`` (the
      CLI's ``--host-devices``) for one device per core. The stability limits are computed
      before, outside the sharded program (jaxlib's batched LAPACK eigensolver hung inside it).
    - `output`: a ``.csv`` file or a ``.parquet`` directory that receives the rows as they
      finish (see `msfd_jax._sweeps.store`), and the whole table, in the sweep's order, at the end.
      An existing `output` is refused unless `resume`.
    - `resume`: read the finished rows in `output` (matched to the sweep's collisions by the
      exact values of all their inputs) and compute only the others; refused if `output`
      holds rows of other collisions or was computed with another mesh, settings or smoothing.
    - `client`: a ``distributed.Client`` (`msfd_jax._sweeps.cluster.connect` makes one): the
      collisions run as Dask tasks of `task_size` (default `chunk_size`) collisions each, in
      the cluster's workers; `compile_cache`: the directory of JAX's persistent compile cache
      that the workers use (None: as their JAX is configured).
    - `workers`: threads of an in-process sweep, each with its own `chunk_size` slots, all
      fed from one queue (None: one per core this process may use, `queue.default_workers`;
      1 on an accelerator). The rows do not depend on it (a collision's result does not
      depend on its slot). A cluster's tasks run one thread each (its workers are the cores):
      with a `client`, `workers` must stay None.
    - `on_rows(rows, outputs)`: called as each group of collisions finishes (after it is
      written), with their row positions in the table and their output columns.

    Raises ValueError/TypeError, before anything is compiled or written, for a bad value.
    """
    si = si_sweep(grid_or_list)  # given in SI: groups per row, SI columns added at the end
    columns, grid = collisions(grid_or_list if si is None else si[0], base)
    n = len(columns["thickness_ratio"])
    chunk_size = default_slots() if chunk_size is None else chunk_size
    task_size = chunk_size if task_size is None else task_size
    _check_sweep(columns, mesh, chunk_size, shard, contact_smoothing, yield_smoothing, task_size)
    _check_workers(workers)
    if client is not None and workers is not None:
        raise ValueError(
            f"workers={workers!r} sets this process's threads; with a Dask client each task runs "
            "one thread (the cluster's workers are the cores): leave workers=None and size the "
            "cluster instead"
        )
    release_if_near_limit()  # before compiling: XLA would crash past vm.max_map_count
    start = time.perf_counter()
    store = None if output is None else open_store(output)
    kept = np.zeros(n, dtype=bool)
    parts: list[tuple[np.ndarray, dict[str, np.ndarray]]] = []
    flat = input_columns(columns)  # the table's input columns (a profile: one per segment)
    names = list(flat)
    if store is not None:
        meta = _numerics(mesh, settings, contact_smoothing, yield_smoothing)
        if store.exists() and not resume:
            raise ValueError(f"output {str(output)!r} exists; resume it or remove it")
        if store.exists():
            store.check_meta(meta)
            finished = with_retry_columns(store.finished())  # a store from before retries
            found = match_rows(flat, finished, names, output)
            kept = found >= 0
            parts.append((np.flatnonzero(kept), {k: finished[k][found[kept]] for k in OUTPUTS}))
        store.write_meta(meta)
        old = {**{k: flat[k][kept] for k in names}, **parts[0][1]} if parts else None
        store.start([*names, *OUTPUTS], old)
    todo = np.flatnonzero(~kept)
    bar = _SweepProgress(n, done=int(kept.sum()), enabled=progress)

    def take(rows: np.ndarray, outputs: dict[str, np.ndarray]) -> None:
        rows = todo[np.asarray(rows)]
        parts.append((rows, outputs))
        if store is not None:
            store.append({**{k: flat[k][rows] for k in names}, **outputs})
        bar.update(len(rows))
        if on_rows is not None:
            on_rows(rows, outputs)

    kwargs = dict(mesh=mesh, settings=settings, chunk_size=chunk_size, shard=shard)
    kwargs.update(contact_smoothing=contact_smoothing, yield_smoothing=yield_smoothing)
    kwargs.update(workers=1 if client is not None else workers)
    todo_columns = {k: v[todo] for k, v in columns.items()}
    timing: dict = {}
    try:
        if len(todo) and client is None:
            solve_collisions(
                todo_columns, **kwargs, on_rows=take, on_stage=bar.note, on_timing=timing.update
            )
        elif len(todo):
            bar.note(f"{math.ceil(len(todo) / task_size)} tasks of <= {task_size} on Dask")
            rows = np.arange(len(todo))
            solve_on_cluster(
                client, solve_collisions, todo_columns, rows, task_size, kwargs, take, compile_cache
            )
    finally:
        bar.close()
        if store is not None:
            store.close()
    if PROFILE_FIELD in columns:  # a graded sweep: each beam's mass against its uniform one
        flat["beam_mass_ratio"] = mass_ratios(columns, mesh)
    table = SweepTable({**flat, **_assemble(parts, n)}, grid, time.perf_counter() - start)
    table.timing = timing or None
    if si is not None:
        table.columns.update(si_columns(table.columns, si[1]))
        table.grid = si[2]
    if store is not None:
        store.finish(table.columns)
        table.computed = ~kept
    return table


def _check_sweep(columns, mesh, chunk_size, shard, contact_smoothing, yield_smoothing, tasks):
    """What `solve_collisions` refuses, refused before a file is written or a task is sent."""
    validate(CollisionParams(**columns), mesh)
    _smoothing_arrays(contact_smoothing, yield_smoothing)
    _chunking(chunk_size, shard)
    if isinstance(tasks, bool) or not isinstance(tasks, int) or tasks < 1:
        raise ValueError(f"task_size must be an integer >= 1, got {tasks!r}")


MAX_WORKERS = 1024


def _check_workers(workers) -> int | None:
    if workers is not None:  # None: one per core
        _check_count("workers (None: one per core)", workers, 1, MAX_WORKERS, "too few")
    return workers


def _numerics(mesh: Mesh, settings: Settings, contact: float, yield_: float) -> dict:
    """What a resumed sweep must share with the rows it keeps (`store` checks it)."""
    return {
        "mesh": {k: repr(getattr(mesh, k)) for k in mesh_json(mesh)},
        "settings": {f.name: repr(getattr(settings, f.name)) for f in dataclasses.fields(settings)},
        "contact_smoothing": repr(float(contact)),
        "yield_smoothing": repr(float(yield_)),
    }


def _assemble(parts, n: int) -> dict[str, np.ndarray]:
    """The output columns in the table's order, from groups of rows in any order."""
    return assemble(parts, n, OUTPUTS)


def solve_collisions(columns, mesh: Mesh = Mesh(), settings=SWEEP_SETTINGS, **kw):
    """`_solve_collisions` with the rows `_collision.attempts.needs_retry` names solved again
    at a smaller step: in the queue engine's own queue, or with `shard` round by round; and,
    with `Mesh.collapse_contacts` None, the rows still failed then solved again with the
    collapse contacts (`_collision.collapse.follow_collapse`)."""
    if not automatic(mesh):
        return _solve_retrying(columns, mesh, settings, **kw)
    given, parts = kw.pop("on_rows", None), []

    def on_rows(rows, out):
        parts.append((np.asarray(rows), out))
        if given is not None:
            given(rows, out)

    follow_collapse(_solve_retrying, columns, mesh, settings, on_rows=on_rows, **kw)
    return assemble(parts, len(next(iter(columns.values()))))


def _solve_retrying(columns, mesh: Mesh, settings, **kw):
    if kw.get("shard"):
        return solve_with_retries(_solve_collisions, columns, mesh, settings, **kw)
    return _solve_collisions(columns, mesh, settings, **kw)


def _solve_collisions(
    columns: Mapping[str, np.ndarray],
    mesh: Mesh = Mesh(),
    settings: Settings = SWEEP_SETTINGS,
    *,
    chunk_size: int | None = None,
    contact_smoothing: float = 0.0,
    yield_smoothing: float = 0.0,
    shard: bool = False,
    workers: int | None = None,
    on_rows: Callable[[np.ndarray, dict[str, np.ndarray]], None] | None = None,
    on_stage: Callable[[str], None] | None = None,
    on_timing: Callable[[dict], None] | None = None,
) -> dict[str, np.ndarray]:
    """The output columns (`OUTPUTS`) of the collisions in `columns`, in their order.

    The unit of work of every sweep (in process, or one task of a cluster sweep): `columns`
    maps every `INPUTS` name to a float64 array (one entry per collision, as `collisions`
    makes them), and for graded beams ``thickness_profile`` to an (n, segments) array. They
    are validated first (ValueError/TypeError before anything compiles).
    `on_rows(rows, outputs)`, when given, is called as soon as a group of collisions has
    finished, with their positions in `columns` and their output columns (for writing rows
    as they finish, and for progress); `on_stage(text)` names the stage that starts;
    `on_timing(timing)` receives the queue engine's timing (`SweepTable.timing`).
    """
    require_float64()
    missing = sorted(set(INPUTS) - set(columns))
    if missing:
        raise ValueError(f"solve_collisions needs every input column; missing {missing}")
    # a graded sweep's profiles: one (n, segments) column; without it, as before
    names = [*INPUTS, *([PROFILE_FIELD] if PROFILE_FIELD in columns else [])]
    columns = {k: np.asarray(columns[k], dtype=np.float64) for k in names}
    # CollisionParams validates arrays elementwise; `validate` adds what needs the mesh.
    params = CollisionParams(**columns)
    validate(params, mesh)
    smoothing = _smoothing_arrays(contact_smoothing, yield_smoothing)
    chunk_size, devices = _chunking(default_slots() if chunk_size is None else chunk_size, shard)
    workers = _check_workers(workers) or default_workers()
    settings = _sweep_settings(settings, mesh)
    n = len(columns["thickness_ratio"])
    chunks = [range(s, min(s + chunk_size, n)) for s in range(0, n, chunk_size)]
    note = on_stage or (lambda text: None)
    # every stability limit first (a small vmapped program): one step bound for all chunks,
    # and the sharded solver then needs no eigen-solve inside its devices' programs
    note("stability limits")
    limits = [_run_chunk(_critical_chunk, columns, c, chunk_size, mesh, smoothing) for c in chunks]
    columns["_dt_critical"] = np.concatenate([d for d, _, _ in limits])
    caps = np.concatenate([c for _, c, _ in limits])  # the derived caps (Settings.t_max None)
    # the queue's order: the longest runs first (a guess from the collapse loads, `_model.cap`), so
    # that the tail is short; a row's result does not depend on when it runs
    t_end = np.concatenate([e for _, _, e in limits])
    t_end = np.minimum(t_end, caps if settings.t_max is None else float(settings.t_max))
    dt = columns["_dt_critical"] if settings.dt is None else np.full(n, float(settings.dt))
    order = np.argsort(-(t_end / dt), kind="stable")
    retries = max(_attempts.MAX_RETRIES, _attempts.BALANCE_RETRIES)
    bounds = (settings.max_steps,) * (retries + 1)
    if settings.max_steps is None:  # one per attempt (attempt a: the step halved a times)
        bounds, smaller = [], settings
        for _ in range(retries + 1):
            bounds.append(sweep_step_bound(columns["_dt_critical"], smaller, caps))
            smaller = smaller_step(smaller)
        bounds = tuple(bounds)
        settings = dataclasses.replace(settings, max_steps=bounds[0])
    note("collisions")
    if devices:  # the chunked, sharded path: each device runs its part of a chunk
        solve = _sharded_solver(devices)
        parts = []
        for c in chunks:
            tick = time.perf_counter()
            outputs, solution = _run_chunk(solve, columns, c, chunk_size, mesh, smoothing, settings)
            parts.append(_rows(outputs, solution, mesh, time.perf_counter() - tick))
            if on_rows is not None:
                on_rows(np.asarray(c), parts[-1])
        return {k: np.concatenate([p[k] for p in parts]) for k in SOLVED_OUTPUTS}
    # the batched core: `chunk_size` slots refilled from the queue as collisions stop, and
    # a row to be solved again at a smaller step handed back to the queue
    # (`_collision.attempts.Attempts`)
    parts = []
    scene = _layout_scene(mesh)

    def emit(rows, part):
        parts.append((rows, part))
        if on_rows is not None:
            on_rows(rows, part)

    attempts = Attempts(emit)

    def done(rows, solution, wall, attempt):
        outputs = fractions(solution, scene)
        outputs["energy_balance_error"] = solution.energy_balance_error
        part = _rows(outputs, solution, mesh, float(np.sum(wall)))
        part["wall_time_s"] = np.asarray(wall, np.float64)  # each one's share, no compile
        return attempts.take(rows, part, attempt)

    timing = run_queue(
        {k: columns[k] for k in names},
        columns["_dt_critical"],
        mesh,
        settings,
        smoothing,
        bounds,
        slots=chunk_size,
        workers=workers,
        on_done=done,
        order=order,
    )
    timing["steps"] = attempts.steps  # Verlet steps of every attempt (retries included)
    if on_timing is not None:
        on_timing(timing)
    return assemble(parts, n)


@functools.lru_cache(maxsize=8)
def _layout_scene(mesh: Mesh):
    # any scene of this mesh gives the chain names and contact kinds `diagnose` reads; unchecked,
    # since the defaults need not be valid with every mesh (collapse contacts' check). Built
    # once per mesh: building it is eager dispatch, which every group of rows a sweep
    # reported paid again (under the queue's lock)
    return _ring_on_beam(CollisionParams().as_arrays(), mesh, jnp.zeros(()), jnp.zeros(()))


def sweep_step_bound(dt_critical: np.ndarray, settings: Settings, caps=None) -> int:
    """`max_steps` for the smallest step of a sweep (`_batched.simulate.step_bound`, the rule of
    single runs): dt = safety x dt_crit (or `Settings.dt`); with ``Settings(t_max=None)``
    t_max is each collision's derived cap `caps` (without them, the largest, `T_MAX_CEILING`).
    """
    dt = np.asarray(dt_critical) * float(settings.safety) if settings.dt is None else settings.dt
    t_max = settings.t_max
    if t_max is None:
        t_max = T_MAX_CEILING if caps is None else caps
    return step_bound(t_max, dt, settings.substeps)


def _sweep_settings(settings: Settings, mesh: Mesh) -> Settings:
    # a sweep is never differentiated: the contact loop of the default is chosen by the mesh;
    # shape times past an explicit cap dropped as in a single run (each row's derived cap
    # is only known in its program)
    return compiled_settings(undifferentiated(settings, mesh), settings.t_max)


def _smoothing_arrays(contact_smoothing, yield_smoothing):
    # checked on the concrete values, before anything is traced (the scenes' own check)
    return (
        smoothing_width(contact_smoothing, "contact_smoothing"),
        smoothing_width(yield_smoothing, "yield_smoothing"),
    )


def _chunking(chunk_size: int, shard: bool):
    _check_count("chunk_size", chunk_size, 1, MAX_CHUNK, "too small")  # chunks are padded to it
    if not shard:
        return chunk_size, None
    devices = jax.devices()
    if chunk_size % len(devices):
        raise ValueError(
            f"chunk_size = {chunk_size} must be a multiple of the {len(devices)} devices"
        )
    return chunk_size, devices


def _rows(outputs: dict, solution, mesh: Mesh, wall: float) -> dict[str, np.ndarray]:
    """Output columns of one chunk; `diagnose` gives each row its message."""
    n = len(solution.result)
    # `diagnose` reads only the chain names from the scene: any scene of this mesh will do
    scene = _layout_scene(mesh)
    out = {k: np.asarray(outputs[k], dtype=np.float64) for k in (*FRACTION_KEYS, *KINETIC_KEYS)}
    out["energy_balance_error"] = np.asarray(outputs["energy_balance_error"], np.float64)
    for k in ("t_end", "dt", "dt_critical", "k0"):
        out[k] = np.asarray(getattr(solution, k), np.float64)
    out["steps"] = np.asarray(solution.steps, np.int64)
    out["result"] = np.asarray(solution.result, np.int64)
    out["status"] = np.asarray([RESULTS(c).status for c in out["result"]], dtype=str)
    out["balance_warning"] = np.asarray(balance_warning(solution), np.int64)
    out["message"] = np.asarray([diagnose(solution, scene, i) for i in range(n)], dtype=str)
    # a chunk runs as one batch: each collision is given an equal share of its wall time
    out["wall_time_s"] = np.full(n, wall / n)
    out.update({k: np.asarray(v, np.float64) for k, v in solution.peaks.items()})
    return out
