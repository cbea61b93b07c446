"""The sweep's engine: B slots on the batched core, finished slots refilled from a queue.

No batch waits for its slowest collision: the slots advance together for a segment of
`segment` diffrax steps (one compiled program, `_segment`), then every slot whose collision
has stopped hands in its outputs and takes the next collision of the queue (`_refill`, also
compiled: the new collisions' scenes, clocks and initial states are built on the device and
merged into the freed slots; the first collisions start the same way, in blank slots, so a
sweep compiles no program of its own to start them). The host loop runs once per segment,
never per time step. A collision's steps, stopping rule and results do not depend on which
slot, batch or segment it ran in (tests/test_engine.py: a batch of N equals N single runs).
"""

from __future__ import annotations

import collections
import dataclasses
import os
import threading
import time
from collections.abc import Callable

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array

from .._batched import peaks as _peaks
from .._batched.engine import BatchState, batch_initial_state, kinetic, make_clock, pair_forces
from .._batched.flat import FlatScene, batch_scenes
from .._batched.simulate import Settings, Solution, platform
from .._batched.solver import solve
from .._collision.attempts import RETRY_FACTOR
from .._model.cap import time_cap
from .._model.params import CollisionParams, Mesh
from .._model.scene import _ring_on_beam, smoothed
from .._model.state import State
from .._runtime import export as _export

# the fastest of 16, 32, 64 per collision-step (benchmarks/slot_cost.py at ee23c14^, git show)
DEFAULT_SLOTS = 32
# On an accelerator: 0.0287 us per collision-step at 8192 slots against 0.0639 at 1024 and
# 0.0262 at 65536 on an H200 (benchmarks/results/gpu.md); 8192 keeps a tail of long
# collisions on fewer slots sooner and the memory small.
GPU_DEFAULT_SLOTS = 8192
MIN_SLOTS = 16
# A tail of at most TAIL_SLOTS running collisions moves to that many slots: below the vector
# width XLA:CPU runs scalar code whose cost grows with the slots (slot_cost.py at ee23c14^: a
# substep of 1, 2, 4, 8, 16 slots costs 6.7, 12.9, 25.0, 43.8, 44.4 us on the paper mesh),
# and a collision's arithmetic is the same bit for bit (tests/test_sweep.py).
TAIL_SLOTS = 4
DEFAULT_SEGMENT = 64  # diffrax steps (x substeps Verlet steps) between refills
# A tail moves to a program of fewer slots not compiled yet only once its worker has run its
# segments for TAIL_PAYBACK x the first programs' compilation: the tail lasts about one
# collision, so in a sweep that ran for less than a compilation a new program cannot pay for
# itself (a 6-collision sweep of a coarse mesh compiled three more sizes for a tail of
# 0.3 s). Programs already compiled (or loaded from the store) are always used. The cost
# compared is the first programs' making (tracing and compiling), also when they were loaded
# from the store: their load time (0.5 s) let a warm run compile new sizes for a tail that a
# cold run kept (a CLI sweep run again with `--parquet`: 16 s -> 21 s, three new programs).
TAIL_PAYBACK = 1.0
# The cost a size's programs took to make, by their arguments' signature (shapes and static
# values: mesh, settings, smoothing, slots), the most this process has measured. Made again,
# they come from jit's own cache in ~0 s, or from JAX's persistent compilation cache for the
# trace and the load, and a new size then looked free (a second sweep of one shape in a
# process compiled three tail sizes, 10 s, for a run of 2.5 s: notebooks/reproduce.py's
# Fig. 16 after Fig. 10). Keys are strings: the table holds no arrays.
_MAKE_S: dict[tuple, float] = {}
_SAVED = threading.local()  # compile seconds a persistent-cache hit saved, in this thread
_COMPILE_SAVED = "/jax/compilation_cache/compile_time_saved_sec"


def _count_saved(event: str, duration: float, **_) -> None:
    if event == _COMPILE_SAVED:
        _SAVED.s = getattr(_SAVED, "s", 0.0) + duration


jax.monitoring.register_event_duration_secs_listener(_count_saved)


def _scenes(params: CollisionParams, mesh: Mesh, smoothing) -> tuple[FlatScene, Array | None]:
    """The batch's flat scene, and each collision's derived cap (None: no cap derived).

    `smoothing`: (contact width, yield width, (smooth contact?, smooth yield?) static)."""
    contact, yield_, smooth = smoothing
    scenes = jax.vmap(lambda p: _ring_on_beam(p, mesh, contact, yield_, smooth))(params)
    return batch_scenes(scenes), jax.vmap(time_cap)(scenes)


def with_flags(smoothing) -> tuple:
    """(contact width, yield width) as the queue's smoothing, with the static flags that let
    the core compile the sharp laws alone where a width is known to be zero."""
    contact, yield_ = smoothing
    flags = (smoothed(contact), smoothed(yield_))
    return (jnp.asarray(contact, float), jnp.asarray(yield_, float), flags)


def _dt(dt_crit, settings: Settings):
    return dt_crit * settings.safety if settings.dt is None else jnp.full_like(dt_crit, settings.dt)


@eqx.filter_jit
def _start(params, dt_crit, mesh, smoothing, settings, max_steps, step_factor=None):
    """The slots' scenes, clocks and initial states. `step_factor` (B,), when given, scales
    each collision's step (0.5 ** attempt for a retry: exact, so a collision solved again in
    the queue takes the steps it would take alone with the step halved); `max_steps` is a
    number or one per collision."""
    flat, cap = _scenes(params, mesh, smoothing)
    cap = cap if settings.t_max is None else None
    dt = _dt(dt_crit, settings)
    if step_factor is not None:
        dt = dt * step_factor
    clock = make_clock(flat, dt, settings, max_steps, cap)
    return flat, clock, batch_initial_state(flat)


@eqx.filter_jit
def _segment(flat, clock, y, settings, segment: int):
    sol = solve(flat, clock, y, settings, max_steps=segment, t1=float(segment), dt0=1.0)
    return jax.tree_util.tree_map(lambda a: a[-1], sol.ys)


@eqx.filter_jit
def _refill(flat, clock, y, take, params, dt_crit, mesh, smoothing, settings, max_steps, factor):
    """Slots with `take` (B,) true get the new collisions `params` (B rows; others unused)."""
    new = _start(params, dt_crit, mesh, smoothing, settings, max_steps, factor)

    def merge(old, fresh):
        mask = jnp.reshape(take, (1,) * (old.ndim - 1) + take.shape)
        return jnp.where(mask, fresh, old)

    return jax.tree_util.tree_map(merge, (flat, clock, y), new)


@eqx.filter_jit
def _report(flat: FlatScene, clock, y: BatchState):
    """Per slot: the numbers a sweep row needs and the chain-wise final state (batch first)."""
    kin = kinetic(flat, y.v)
    block = jnp.zeros_like(y.t)
    for i, c in enumerate(flat.chains):
        last = c.node + c.n_nodes - 1
        block = block + 0.5 * flat.attached_mass[i] * jnp.sum(y.v[last] ** 2, axis=0)
    forces = pair_forces(flat, y.x, y.permanent_set)
    return jax.tree_util.tree_map(lambda a: jnp.moveaxis(a, -1, 0), (y, kin, block, forces))


def _solution(flat, y, kin, block, forces, dt, dt_crit, k0, substeps) -> Solution:
    """A batch-first `Solution` without histories (what `fractions` and `diagnose` read)."""

    def nodes(a):
        return tuple(a[:, c.node : c.node + c.n_nodes] for c in flat.chains)

    final = State(
        nodes(y.x), nodes(y.v), nodes(y.a),
        tuple(y.plastic_rotation[:, c.joint : c.joint + c.n_joints] for c in flat.chains),
        tuple(y.plastic_strain[:, c.bar : c.bar + c.n_nodes - 1] for c in flat.chains),
        y.permanent_set, forces, y.bending, y.axial, y.contact, y.elastic,
        y.reaction, y.drive_work, y.last_dissipation, y.dissipation_mark, y.last_contact,
    )  # fmt: skip
    return Solution(
        result=np.round(y.code).astype(np.int64),
        t_end=y.t,
        steps=np.round(y.k * substeps).astype(np.int64),
        dt=dt,
        dt_critical=dt_crit,
        k0=k0,
        bending=y.bending,
        axial=y.axial,
        contact=y.contact,
        kinetic=kin,
        kinetic_block=block,
        elastic=y.elastic,
        drive_work=y.drive_work,
        final=final,
        ts=np.zeros((len(k0), 1)),  # every leaf batch-first (diagnose indexes them)
        history={},
        shape_ts=np.zeros((len(k0), 0)),
        shapes=(),
        peaks=_peaks.as_dict(y.peaks),
    )


def default_slots() -> int:
    """Slots per worker when a sweep is not told: `DEFAULT_SLOTS` on a CPU,
    `GPU_DEFAULT_SLOTS` on an accelerator (the default device's platform)."""
    return DEFAULT_SLOTS if platform() == "cpu" else GPU_DEFAULT_SLOTS


def default_workers() -> int:
    """Worker threads of an in-process sweep: the cores this process may run on (its CPU
    affinity: ``taskset -c 1`` gives 1), one on an accelerator (one device serves them all)."""
    if platform() != "cpu":
        return 1
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # no affinity on this platform
        return max(1, os.cpu_count() or 1)


def run_queue(
    params: dict[str, np.ndarray],
    dt_critical: np.ndarray,
    mesh: Mesh,
    settings: Settings,
    smoothing,
    max_steps: int | tuple[int, ...],
    *,
    slots: int = DEFAULT_SLOTS,
    segment: int = DEFAULT_SEGMENT,
    workers: int = 1,
    on_done: Callable[..., np.ndarray | None],
    order: np.ndarray | None = None,
) -> dict:
    """Run every collision of `params` (columns of CollisionParams fields) through B slots.

    The queue starts in `order` (row positions; default: as given): a sweep puts its longest
    collisions first. `on_done(rows, solution, wall, attempts)` receives each group of
    collisions that stopped in the same segment of one worker: their positions in `params`,
    a batch-first `Solution` of them (no histories), each one's share of the run time
    (compile time excluded) and each one's attempt; calls are serialised. It may return a
    mask of the rows to solve again: each goes back to the front of the queue with its step
    halved (attempt a runs at 0.5 ** a times the step, with `max_steps[a]` diffrax steps
    allowed when `max_steps` is a tuple, one bound per attempt). A retry so runs in a free
    slot beside the rest of the sweep, not in a pass of its own after it.

    `workers` threads each run their own B slots, all taking collisions from one queue
    (XLA releases the GIL while a compiled program runs, so W threads use W cores; one
    compiled program serves them all). Returns the slot count, the worker count, the number
    of segments and of compactions (below), the Verlet steps the slots ran in all
    (`slot_steps`, busy or idle: the sweep's steps over it is the lanes' utilisation), the
    seconds the workers spent in segment programs in all (`segment_s`; the rest of workers x
    run time: the hand-over between segments, a worker idle at the end, waits for a tail
    program's compilation), the compile and run times (run time: wall time of the whole
    queue, compile excluded).

    The tail: once the queue is empty and at most half of a worker's slots still run (on a
    GPU: a quarter, `_tail_size_gpu`), their collisions move into a program of fewer slots
    (the next power of two, down to `TAIL_SLOTS`, on a GPU `GPU_TAIL_FLOOR`; compiled when
    first needed, its compilation counted as compile time; its refill program only when a
    collision handed back in the tail needs it): the tail of a sweep no longer
    pays for stopped slots. A collision's result does not depend on its slot or the slot
    count (tests/test_sweep.py).
    """
    n = len(dt_critical)
    workers = max(1, min(int(workers), -(-n // MIN_SLOTS)))  # >= MIN_SLOTS collisions each
    queue = _SweepQueue(
        params, dt_critical, mesh, settings, with_flags(smoothing), max_steps, segment, on_done,
        order=range(n) if order is None else np.asarray(order).tolist(),
    )  # fmt: skip
    return queue.run(workers, _slot_count(-(-n // workers), slots))


def _stopped(y: BatchState, mask) -> BatchState:
    """`y` with the slots where `mask` (B,) is true marked stopped: a segment keeps their
    state as it is."""
    return eqx.tree_at(lambda s: s.done, y, jnp.where(jnp.asarray(mask), 1.0, y.done))


@dataclasses.dataclass
class _Slots:
    """One worker's slots: its batch on the device and, per slot, what the host tracks.

    Once its worker runs, only that worker writes it. A slot with `row` -1 runs no collision
    (it stopped and the queue had nothing for it, or it pads the batch) and is marked stopped
    on the device.
    """

    state: tuple  # (flat, clock, y): the slots' scenes, clocks and states on the device
    row: np.ndarray  # each slot's position in `params`; -1: none
    attempt: np.ndarray  # each slot's attempt (attempt a: the step halved a times)
    busy: np.ndarray  # run time attributed so far to each slot's collision (s)
    programs: tuple = ()  # the (segment, report, refill) programs compiled for len(row) slots
    segments: int = 0  # segments run
    compactions: int = 0  # moves of the tail to fewer slots
    slot_steps: int = 0  # Verlet steps the slots ran, busy or idle (utilisation)
    segment_s: float = 0.0  # seconds in the segment programs


class _SweepQueue:
    """The collisions a sweep's workers take, what they share, and the loop each one runs.

    `pending` holds the (row, attempt) pairs not yet taken, in the order they are taken;
    `lock` guards it and serialises `on_done`, and a retry `on_done` asks for is in
    `pending` before the lock is released. `programs` holds the compiled programs per slot
    count, each compiled once under `compiling` (a worker that needs a size another is
    compiling waits for it); `compile_times` the seconds each took. Each worker writes only
    its own `_Slots`; `run` adds up their counters once the workers are done.
    """

    def __init__(
        self, params, dt_critical, mesh, settings, smoothing, max_steps, segment, on_done, order
    ):
        self.params, self.names = params, list(params)
        self.dt_critical = dt_critical
        self.mesh, self.settings, self.smoothing, self.segment = mesh, settings, smoothing, segment
        self.bounds = max_steps if isinstance(max_steps, tuple) else (max_steps,)  # per attempt
        self.on_done = on_done
        self.pending = collections.deque((row, 0) for row in order)
        self.lock = threading.Lock()
        self.on_cpu = platform() == "cpu"  # which tail rule (`_tail_size`, `_tail_size_gpu`)
        self.programs: dict[int, tuple] = {}
        self.blanks: dict[int, tuple] = {}  # `blank`'s zeros, one per slot count
        self.compiling = threading.Lock()
        self.compile_times: list[float] = []  # the first: the programs of the starting size
        self.make_times: list[float] = []  # the seconds each size's programs took to make
        self.errors: list[BaseException] = []  # a worker thread's exception, re-raised by `run`

    def run(self, workers: int, size: int) -> dict:
        """Every collision through up to `workers` workers of `size` slots (a worker the queue
        has no collisions for does not run): `run_queue`'s timing."""
        tick = time.perf_counter()
        started = [self.fill_slots(size) for _ in range(workers)]
        started = [s for s in started if s is not None]  # (64 collisions, 3 workers of 32)
        # compile the programs ahead of time (once, before the threads start), so that their
        # compilation is timed apart from the run
        programs = self.programs_for(size, started[0].state)
        for slots in started:
            slots.programs = programs
        compile_s = time.perf_counter() - tick
        tick = time.perf_counter()
        if len(started) == 1:
            self.work(started[0])
        else:
            self._run_threads(started)
        # the smaller programs' compilation (the threads wait for it) is compile time, not run time
        late = sum(self.compile_times[1:])
        return dict(
            slots=size,
            workers=len(started),
            segments=sum(s.segments for s in started),
            compactions=sum(s.compactions for s in started),
            slot_steps=sum(s.slot_steps for s in started),
            segment_s=sum(s.segment_s for s in started),
            compile_s=compile_s + late,
            run_s=time.perf_counter() - tick - late,
        )

    def _run_threads(self, started: list[_Slots]) -> None:
        """`work` on each worker's slots in a thread of its own; the first exception of a
        worker (or of the caller while it waits: Ctrl-C) stops every worker after its segment
        in flight and is raised here."""

        def guarded(slots):
            try:
                self.work(slots)
            except BaseException as e:  # re-raised in the caller's thread
                self.errors.append(e)

        threads = [
            threading.Thread(target=guarded, args=(s,), name=f"msfd-queue-{w}", daemon=True)
            for w, s in enumerate(started)
        ]
        for t in threads:
            t.start()
        try:
            for t in threads:
                t.join()
        except BaseException as e:  # Ctrl-C: the workers stop after their segment in flight
            self.errors.append(e)
            for t in threads:
                t.join()
            raise
        if self.errors:
            raise self.errors[0]

    def batch(self, rows, attempts, size: int) -> tuple:
        """`_start`'s per-collision inputs (params, dt_critical, max_steps, step factor) for
        `rows` at `attempts`, padded to `size` slots with the first row at attempt 0."""
        rows, attempts = np.asarray(rows), np.asarray(attempts)
        pad = size - len(rows)
        rows = np.concatenate([rows, np.full(pad, rows[0])])
        attempts = np.concatenate([attempts, np.zeros(pad, np.int64)])
        p = CollisionParams(**{k: jnp.asarray(self.params[k][rows]) for k in self.names})
        steps = np.asarray(self.bounds, np.float64)[np.minimum(attempts, len(self.bounds) - 1)]
        factor = jnp.asarray(RETRY_FACTOR**attempts)  # the step of attempt a: exact powers of 2
        return p, jnp.asarray(self.dt_critical[rows]), jnp.asarray(steps), factor

    def take(self, count: int) -> tuple[list[int], list[int]]:
        """Up to `count` collisions from the front of the queue: their rows and attempts."""
        with self.lock:
            got = [self.pending.popleft() for _ in range(min(count, len(self.pending)))]
        return [r for r, _ in got], [a for _, a in got]

    def _hand_back(self, rows: np.ndarray, attempts: np.ndarray) -> None:
        """`rows` (that ran `attempts`) to the front of the queue, in their order, for their
        next attempt: retries first, since they are the longest runs. The caller holds `lock`."""
        retried = zip(rows.tolist(), (attempts + 1).tolist(), strict=True)
        self.pending.extendleft(list(retried)[::-1])

    def programs_for(self, size: int, state, refill: bool = True) -> tuple:
        """The segment, report and refill programs for `size` slots, compiled ahead of time
        (once; a thread that needs a size another is compiling waits for it). `refill` False
        (a tail's smaller size: the queue is empty) leaves the refill program to its first use,
        a retry handed back in the tail (`refill`); None until then."""
        with self.compiling:
            have = self.programs.get(size)
            if have is None:
                self.programs[size] = self._make(size, state, refill)
            elif refill and have[2] is None:  # a tail size's refill program, at its first use
                tick = time.perf_counter()
                late = _export.compile_program(
                    _refill, *self._refill_args(size, state), name="queue_refill"
                )
                self.programs[size] = (*have[:2], late)
                self.compile_times.append(time.perf_counter() - tick)
            return self.programs[size]

    def _refill_args(self, size: int, state) -> tuple:
        """Arguments of the refill program's signature for `size` slots of `state`."""
        zeros = np.zeros(size, np.int64)
        p, d, steps, factor = self.batch(zeros, zeros, size)
        return (*state, jnp.zeros(size, bool), p, d, self.mesh, self.smoothing, self.settings,
                steps, factor)  # fmt: skip

    def _make(self, size: int, state, refill: bool) -> tuple:
        """`programs_for`'s programs for a new size (the refill program only if `refill`),
        with what making them cost recorded for the tail rule (`make_times`, `_MAKE_S`)."""
        tick = time.perf_counter()
        saved = getattr(_SAVED, "s", 0.0)
        flat, clock, y = state
        refill_args = self._refill_args(size, state)
        # through the store of serialized programs when it is on (the CLI's): a new process
        # then loads them instead of tracing diffrax's loop again (`_export`)
        programs = (
            _export.compile_program(
                _segment, flat, clock, y, self.settings, self.segment, name="queue_segment"
            ),
            _export.compile_program(_report, flat, clock, y, name="queue_report"),
            _export.compile_program(_refill, *refill_args, name="queue_refill") if refill else None,
        )
        self.compile_times.append(time.perf_counter() - tick)
        made = [program for program in programs if program is not None]
        # what a new size costs: the first size's making, recorded by the process that made it
        # when it was loaded here from the store (its load took milliseconds); else the time
        # taken with what a persistent-cache hit saved, never less than this process measured
        # for the same programs before (`_MAKE_S`)
        took = self.compile_times[-1] + getattr(_SAVED, "s", 0.0) - saved
        recorded = [program.make_s for program in made]
        stored = all(program.source == "loaded" for program in made)
        kind = _export.signature((self.segment, refill, *refill_args))  # shapes, statics
        known = _MAKE_S.get(kind, 0.0)
        cost = sum(recorded) if stored and None not in recorded else max(took, known)
        _MAKE_S[kind] = max(cost, known)
        self.make_times.append(cost)
        return programs

    def blank(self, size: int, p, d, steps, factor) -> tuple:
        """Zeros of the shapes and types of `size` started slots (flat scene, clock, state):
        what the refill program takes in when it starts every slot (`fill_slots`); numpy
        zeros, so that no program is made for them."""
        if size not in self.blanks:
            shapes = eqx.filter_eval_shape(
                _start, p, d, self.mesh, self.smoothing, self.settings, steps, factor
            )
            self.blanks[size] = jax.tree_util.tree_map(
                lambda x: np.zeros(x.shape, x.dtype) if isinstance(x, jax.ShapeDtypeStruct) else x,
                shapes,
            )
        return self.blanks[size]

    def fill_slots(self, size: int) -> _Slots | None:
        """A worker's `size` slots with the next collisions of the queue started in them (slots
        past the last: none, stopped from the start); None when the queue is empty."""
        rows, attempts = self.take(size)
        if not rows:
            return None
        p, d, steps, factor = self.batch(rows, attempts, size)
        # started by the refill program, every slot taken, from blank slots (zeros of the
        # state's shapes): a sweep compiles no program of its own to start its slots
        blank = self.blank(size, p, d, steps, factor)
        refill = self.programs_for(size, blank)[2]
        flat, clock, y = refill(*blank, jnp.ones(size, bool), p, d, self.mesh, self.smoothing,
                                self.settings, steps, factor)  # fmt: skip
        row, attempt = np.full(size, -1), np.zeros(size, np.int64)
        row[: len(rows)], attempt[: len(rows)] = rows, attempts
        if len(rows) < size:
            y = _stopped(y, row < 0)
        return _Slots((flat, clock, y), row, attempt, busy=np.zeros(size))

    def work(self, slots: _Slots) -> None:
        """One worker's loop: a segment of every slot, then the slots whose collision stopped
        report it and take the next collisions of the queue; once the queue has none for them,
        the tail moves to fewer slots. Ends when no slot runs or a worker has failed."""
        while (slots.row >= 0).any() and not self.errors:
            stopped = self.advance(slots)
            if not len(stopped):
                continue
            self.report(slots, stopped)
            if not self.refill(slots, stopped):  # the tail: the queue is empty
                self.compact(slots)

    def advance(self, slots: _Slots) -> np.ndarray:
        """One segment of every slot, its run time shared among the running collisions;
        returns the slots whose collision stopped in it."""
        flat, clock, y = slots.state
        tick = time.perf_counter()
        y = slots.programs[0](flat, clock, y, self.settings, self.segment)
        done = np.asarray(y.done) > 0
        wall = time.perf_counter() - tick
        slots.state = (flat, clock, y)
        slots.segment_s += wall
        slots.segments += 1
        slots.slot_steps += len(slots.row) * self.segment * self.settings.substeps
        active = slots.row >= 0
        slots.busy[active] += wall / max(int(active.sum()), 1)
        return np.flatnonzero(done & active)

    def report(self, slots: _Slots, idx: np.ndarray) -> None:
        """The collisions that stopped in slots `idx` handed to `on_done` (those it asks to
        solve again back to the front of the queue); the slots are then free."""
        flat, clock, y = slots.state
        pick = jax.tree_util.tree_map(
            lambda a: np.asarray(a)[idx], jax.device_get(slots.programs[1](flat, clock, y))
        )
        substeps = self.settings.substeps
        dt = np.asarray(clock.dt0)[idx] / substeps
        k0 = np.asarray(clock.k0)[idx]
        rows, attempts = slots.row[idx], slots.attempt[idx]
        solution = _solution(flat, *pick, dt, self.dt_critical[rows], k0, substeps)
        with self.lock:
            again = self.on_done(rows, solution, slots.busy[idx].copy(), attempts)
            if again is not None and np.any(again):
                again = np.asarray(again, bool)
                self._hand_back(rows[again], attempts[again])
        slots.busy[idx] = 0.0
        slots.row[idx] = -1

    def refill(self, slots: _Slots, idx: np.ndarray) -> bool:
        """The next collisions of the queue started in the free slots `idx`, in that order;
        False when the queue had none."""
        rows, attempts = self.take(len(idx))
        if not rows:
            return False
        size = len(slots.row)
        fill = idx[: len(rows)]
        take_mask = np.zeros(size, bool)
        take_mask[fill] = True
        new_rows = np.zeros(size, np.int64)
        new_rows[fill] = rows
        new_attempts = np.zeros(size, np.int64)
        new_attempts[fill] = attempts
        p, d, steps, factor = self.batch(new_rows, new_attempts, size)
        if slots.programs[2] is None:  # a tail size's: compiled at its first use
            slots.programs = self.programs_for(size, slots.state)
        slots.state = slots.programs[2](
            *slots.state, jnp.asarray(take_mask), p, d, self.mesh, self.smoothing, self.settings,
            steps, factor,
        )  # fmt: skip
        slots.row[fill] = rows
        slots.attempt[fill] = attempts
        return True

    def compact(self, slots: _Slots) -> None:
        """The tail: the running collisions moved into fewer slots when the tail rule
        (`_tail_size`, on a GPU `_tail_size_gpu`) gives fewer and the new program pays for
        itself (`TAIL_PAYBACK`), in their slot order, the new slots past them padding
        (stopped)."""
        running, size = int((slots.row >= 0).sum()), len(slots.row)
        smaller = _tail_size(running, size) if self.on_cpu else _tail_size_gpu(running, size)
        if smaller >= size:
            return
        if smaller not in self.programs and slots.segment_s < TAIL_PAYBACK * self.make_times[0]:
            return  # a new compilation would cost more than the tail can save
        keep = np.flatnonzero(slots.row >= 0)
        idx = np.concatenate([keep, np.full(smaller - len(keep), keep[0])])
        flat, clock, y = jax.tree_util.tree_map(lambda a: a[..., idx], slots.state)
        pad = np.arange(smaller) >= len(keep)
        slots.state = (flat, clock, _stopped(y, pad))
        slots.row = np.where(pad, -1, slots.row[idx])
        slots.busy = np.where(pad, 0.0, slots.busy[idx])
        slots.attempt = slots.attempt[idx]
        slots.compactions += 1
        slots.programs = self.programs_for(smaller, slots.state, refill=False)


def _tail_size(running: int, size: int) -> int:
    """The slots for `running` collisions of a tail now on `size` slots: halved while at most
    half run, down to `MIN_SLOTS`; then, with at most `TAIL_SLOTS` running, the smallest power
    of two that holds them (scalar code on XLA:CPU, whose cost grows with the slots)."""
    if running == 0:
        return size
    while size // 2 >= MIN_SLOTS and running <= size // 2:
        size //= 2
    if running <= TAIL_SLOTS:
        size = min(size, 1 << (running - 1).bit_length())
    return size


# On a GPU a substep's time grows with the slots down to about this many and no further:
# 65.5, 235.5 and 1719 us for 1024, 8192 and 65536 slots on an H200, and a single collision's
# substep took 73 us (benchmarks/results/gpu.md).
GPU_TAIL_FLOOR = 1024


def _tail_size_gpu(running: int, size: int) -> int:
    """The slots for `running` collisions of a tail on `size` slots on a GPU: once at most a
    quarter run, the smallest power of two that holds them, not below `GPU_TAIL_FLOOR`. Steps
    of four (not halvings) because each new size is a compilation (6-14 s on an H200); with
    them the busy slots never fall below a quarter until the floor."""
    if running == 0 or size <= GPU_TAIL_FLOOR or running > size // 4:
        return size
    return max(GPU_TAIL_FLOOR, 1 << (running - 1).bit_length())


def _slot_count(n: int, slots: int) -> int:
    """Slots for n collisions: min(n, `slots`) rounded up to a power of two, at least
    `MIN_SLOTS` (a 3-collision sweep runs 16 slots, not 32; extra slots idle).

    Powers of two: every slot is then a full lane of the vector units (8 float64 in AVX-512,
    4 in AVX2), so a collision's arithmetic is the same whatever the batch size; with batches
    of 2 or 3 the lanes past the vector width ran as scalar remainder code, whose rounding
    differed by ~1e-11 relative (and a cluster's task split changed results). At least 16:
    a substep of 8 slots costs as much as one of 16 on XLA:CPU (59.5 against 62.6 us on the
    paper mesh, `benchmarks/slot_cost.py` at ee23c14^), so 8 slots only halve the throughput.
    """
    return max(MIN_SLOTS, 1 << max(0, (min(n, slots) - 1).bit_length()))


def solve_batch(
    params: CollisionParams,
    mesh: Mesh,
    settings: Settings,
    dt_critical,
    *,
    max_steps: int,
    contact_smoothing=0.0,
    yield_smoothing=0.0,
    adjoint=None,
) -> dict:
    """B collisions (`params` fields of shape (B,)) as one batch, differentiably.

    Returns the energy partition per collision (fractions of K0, shape (B,)) with ``steps``
    and ``result``. jit/grad/jvp-compatible: with ``adjoint=diffrax.ForwardMode()`` one
    ``jax.jvp`` with a tangent per collision gives every collision's derivative along its own
    tangent in one batched pass (the collisions are independent). `dt_critical` (B,) is not
    differentiated (`critical_step`); `max_steps` bounds the diffrax steps (static).
    """
    smoothing = with_flags((contact_smoothing, yield_smoothing))
    flat, cap = _scenes(params, mesh, smoothing)
    dt = _dt(jax.lax.stop_gradient(jnp.asarray(dt_critical, float)), settings)
    cap = jax.lax.stop_gradient(cap) if settings.t_max is None else None
    clock = make_clock(flat, dt, settings, max_steps, cap)
    sol = solve(
        flat, clock, batch_initial_state(flat), settings, max_steps=max_steps, adjoint=adjoint
    )
    y = jax.tree_util.tree_map(lambda a: a[-1], sol.ys)
    k0 = clock.k0
    names = [c.name for c in flat.chains]
    ring, beam = names.index("ring"), names.index("beam")
    kin = kinetic(flat, y.v)
    return dict(
        beam_bending=y.bending[beam] / k0,
        beam_axial=y.axial[beam] / k0,
        ring_bending=y.bending[ring] / k0,
        ring_axial=y.axial[ring] / k0,
        contact=jnp.sum(y.contact, 0) / k0,
        kinetic=jnp.sum(kin, 0) / k0,
        elastic=y.elastic / k0,
        steps=y.k * settings.substeps,
        result=y.code,
    )
