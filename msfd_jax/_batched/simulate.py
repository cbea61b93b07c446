"""Integrate a scene with diffrax until plastic dissipation has stopped (or a cap).

Stopping rule (docs/model.md): a collision ends at the first tau >= `t_min` at which the total
dissipated energy has not grown by more than `settle_tolerance` K0 for `settle_window`; it is
capped at `t_max`. Guards: a non-finite state, or an energy balance error above
`energy_guard` K0, stops the run with a result code (never a silent NaN).
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from .._model.cap import concrete_time_cap, time_cap
from .._model.params import _check_count, _check_scalar, _check_static_number, _check_value, _show
from .._model.scene import Scene
from .._model.state import State, critical_step
from .._runtime import export as _export
from . import peaks as _peaks
from .engine import BatchState, batch_initial_state, make_clock
from .flat import flatten
from .results import (  # noqa: F401  (the former constants, re-exported)
    ENERGY_BALANCE,
    MAX_STEPS,
    NON_FINITE,
    RESULT_NAMES,
    RESULTS,
    SETTLED,
    TIME_LIMIT,
)
from .solver import chain_state, history_of, solve

if TYPE_CHECKING:  # diffrax is imported where a solve is traced (`_simulate`, `solver.solve`)
    import diffrax

_critical_step = eqx.filter_jit(critical_step)
CONTACT_LOOPS = ("blocks", "listed", "dense")  # Settings.contact_loop (msfd_jax._batched.pruning)


# Contact pairs (ring nodes x beam contact nodes) from which a sweep lists the near blocks
# (`Settings.contact_loop` None). Whole sweeps side by side (benchmarks/sweep_loops.py):
# 0.87x as fast listed on the paper's 16 x 21 (sweep_loops.md), 0.91x at twice the mesh,
# 31 x 41 (benchmarks/results/sweep_loops.md, x2: the tail's small batches favour the
# conditionals), 1.56x at
# four times, 61 x 81 (x4); single segments: results/contact_loop.md at ee23c14^ (git show).
LISTED_FROM_PAIRS = 4000


def platform() -> str:
    """The platform programs run on now: the default device's (``jax.default_device`` when
    set, as benchmarks/gpu_throughput.py does), else the default backend's."""
    device = jax.config.jax_default_device
    if device is None:
        return jax.default_backend()
    return device if isinstance(device, str) else device.platform


def undifferentiated(settings: "Settings", mesh) -> "Settings":
    """`settings` for a sweep of `mesh` (its results are never differentiated): the default
    contact loop (None) becomes, on a CPU, the listed one where the contact set has at least
    `LISTED_FROM_PAIRS` pairs and the conditional per block below; on an accelerator the
    dense one (every pair, no conditional: 1.64x as fast as the blocks on an H200 at 8192
    slots, benchmarks/results/gpu.md)."""
    if settings.contact_loop is not None:
        return settings
    if platform() != "cpu":
        return dataclasses.replace(settings, contact_loop="dense")
    pairs = (mesh.ring_segments + 1) * (mesh.beam_contact_segments + 1)
    loop = "listed" if pairs >= LISTED_FROM_PAIRS else "blocks"
    return dataclasses.replace(settings, contact_loop=loop)


class Settings(eqx.Module):
    """How to integrate (numerics), apart from what is integrated (the scene).

    **Arguments:**
    - `safety`: dt = safety * dt_crit, dt_crit = 2/omega_max the computed stability limit.
      0.7 is the largest step that keeps the partition within 1e-3 K0 of a step-converged
      reference with a 30 % margin on the collisions of docs/accuracy.md (re-chosen once the
      contact springs had their Eq. 18 stiffness, R/h_r times stiffer; it was 0.6).
    - `dt`: a fixed step that overrides `safety` (non-dimensional time).
    - `t_max`: cap on the run length; None (the default) derives each collision's cap from
      its inputs (`msfd_jax._model.cap.time_cap`: 3 x the time the structures' collapse loads take
      to stop the block, + 2, within [10, 100]; 10 for every design that stopped before the
      former fixed cap of 10). A number is an explicit cap. `t_min`: never stop before this.
    - `settle_window`, `settle_tolerance`, `settle_residual`: the stopping rule. A run ends
      when the dissipation has grown by less than `settle_tolerance` K0 for `settle_window`
      and, besides, the contact has been open for `settle_window` or the kinetic plus elastic
      energy left is below `settle_residual` K0.
    - `stop_when_settled`: False runs to `t_max` (driven, quasi-static scenes).
    - `history_points`: samples of the energy/contact histories over [0, t_max].
    - `shape_times`: times at which node positions are saved.
    - `energy_guard`: stop when |energy balance error| exceeds this fraction of K0 (0.05:
      kept after the reliability benchmark over random designs, docs/stability.md: once
      joint folds past pi no longer book spurious dissipation, what a successful run leaves
      open above 1e-4 K0 is the sharp contact at the default step in slow, light impacts, up
      to ~4e-2 K0 of a small K0, which a smaller step closes; `run` and `sweep` rerun such
      runs at half the step, at most three times (`_collision.attempts.BALANCE_RETRIES`), and
      report the best attempt;
      one still open keeps its status with `balance_warning` and a message saying how far,
      while an unstable step or a collapse the model cannot follow still trips the guard).
    - `max_steps`: static bound on the number of diffrax steps (None: from t_max / dt).
    - `substeps`: Verlet steps per diffrax step (histories are interpolated linearly between
      diffrax steps, and the stopping rule is checked once per diffrax step).
    - `contact_loop`: how the ring-beam contact skips its blocks out of reach (static;
      `msfd_jax._batched.pruning`): ``"blocks"`` a conditional per block, differentiable in forward
      and reverse mode; ``"listed"`` a loop over the near blocks only, faster on batches
      (results/contact_loop.md at ee23c14^) but differentiable in forward mode (``jax.jvp``)
      only; ``"dense"`` every pair in one block with no conditional (nothing skipped; for a
      GPU, benchmarks/results/gpu.md). ``None`` (the default): ``"blocks"``, except in a
      sweep (never differentiated): on a CPU ``"listed"`` for a mesh whose contact set has
      at least `LISTED_FROM_PAIRS` (4000) pairs, four times the paper's mesh and finer, where
      it is the faster; on a GPU ``"dense"``. All give the same partition to rounding (they
      group the contact's sums in blocks of different shapes).
    """

    safety: float = 0.7
    dt: float | None = None
    t_max: float | None = None
    t_min: float = 0.2
    settle_window: float = 0.5
    settle_tolerance: float = 1e-5
    settle_residual: float = 0.05
    stop_when_settled: bool = eqx.field(static=True, default=True)
    history_points: int = eqx.field(static=True, default=1001)
    shape_times: tuple[float, ...] = eqx.field(static=True, default=(0.15, 0.49, 0.75, 1.5))
    energy_guard: float = 0.05
    max_steps: int | None = eqx.field(static=True, default=None)
    substeps: int = eqx.field(static=True, default=8)
    contact_loop: str | None = eqx.field(static=True, default=None)

    def __check_init__(self):
        ranges = dict(
            safety=(0.0, 10.0, False, True),
            t_min=(0.0, 1.0e4, True, True),
            settle_window=(0.0, 1.0e4, False, True),
            settle_tolerance=(0.0, 1.0, True, True),
            settle_residual=(0.0, 1.0, True, True),
            energy_guard=(0.0, 1.0e3, False, True),
        )
        for name, bounds in ranges.items():
            _check_value(name, getattr(self, name), *bounds)
            _check_scalar(name, getattr(self, name))
        if self.t_max is not None:  # beyond 1e4, float64 time loses the step's digits
            _check_value("t_max", self.t_max, 0.0, 1.0e4, False, True)
            _check_scalar("t_max", self.t_max)
        if self.dt is not None:
            _check_value("dt", self.dt, 0.0, 1.0e3, False, True)
            _check_scalar("dt", self.dt)
        if not isinstance(self.stop_when_settled, bool):
            raise TypeError(
                f"stop_when_settled must be True or False, got {_show(self.stop_when_settled)}"
            )
        if not isinstance(self.shape_times, tuple):
            raise TypeError(f"shape_times must be a tuple of times, got {_show(self.shape_times)}")
        for t in self.shape_times:
            _check_value("shape_times", t, 0.0, 1.0e4, True, True)
            _check_static_number("shape_times", t)
        loop = self.contact_loop
        if loop is not None and not (isinstance(loop, str) and loop in CONTACT_LOOPS):
            raise ValueError(
                f"contact_loop must be None or one of {', '.join(map(repr, CONTACT_LOOPS))}, "
                f"got {_show(self.contact_loop)}"
            )
        # upper bounds: beyond them a run allocates or loops for ever (they are static)
        _check_count("substeps", self.substeps, 1, 10_000)
        _check_count("history_points", self.history_points, 2, 1_000_000)
        if self.max_steps is not None:
            _check_count("max_steps", self.max_steps, 1, 2**40)


class Solution(eqx.Module):
    """Everything a run produces (arrays; vmapped runs give a leading batch axis).

    Energies are in units of M_pr (divide by `k0` for fractions of the initial kinetic energy).
    Per-chain arrays follow the scene's chain order; per-contact arrays its contact order.
    """

    result: Array
    t_end: Array
    steps: Array
    dt: Array
    dt_critical: Array
    k0: Array
    bending: Array
    axial: Array
    contact: Array
    kinetic: Array
    kinetic_block: Array
    elastic: Array
    drive_work: Array
    final: State
    ts: Float[Array, " history"]
    history: dict
    shape_ts: Array
    shapes: tuple
    peaks: dict  # `peaks.PEAK_KEYS`, kept at every step (ring on beam only; else {})

    @property
    def energy_balance_error(self):
        """(K + U + D - K0 - W_drive) / K0 at the end of the run."""
        xp = array_module(self.k0)
        total = (
            xp.sum(self.kinetic, -1)
            + self.elastic
            + xp.sum(self.bending, -1)
            + xp.sum(self.axial, -1)
            + xp.sum(self.contact, -1)
        )
        k0 = xp.where(self.k0 > 0, self.k0, 1.0)
        return (total - self.k0 - self.drive_work) / k0


def array_module(x):
    """numpy for host arrays (a finished run's read-out: no per-op dispatch), else jax.numpy."""
    return np if isinstance(x, np.ndarray | np.generic) else jnp


def step_bound(t_max, dt, substeps: int) -> int:
    """The static bound on diffrax steps of runs to `t_max` at step `dt` (arrays: the largest).

    t_max / (dt x substeps) diffrax steps with 2 % and 16 steps of margin, rounded up to a
    power of two (>= 256), so that runs and sweeps of similar designs share one compiled
    program. The one rule of single runs (`prepare`), sweeps and the optimiser.
    """
    ratio = np.asarray(t_max, np.float64) / (np.asarray(dt, np.float64) * substeps)
    steps = float(np.max(ratio))
    if not math.isfinite(steps):
        raise ValueError(f"the step bound is not finite: t_max {t_max}, dt {dt}")
    return 2 ** max(8, math.ceil(math.log2(1.02 * steps + 16)))


def compiled_settings(settings: Settings, cap=None) -> Settings:
    """`settings` as a compiled run takes them: shape times past the cap dropped (a short run
    keeps the default times it reaches; with no concrete cap all are kept), and numbers as
    float64 arrays, so that a new t_max, dt or safety compiles no new program."""
    if cap is not None and not isinstance(cap, jax.core.Tracer):
        kept = tuple(t for t in settings.shape_times if t <= float(np.max(cap)))
        settings = dataclasses.replace(settings, shape_times=kept)
    return jax.tree_util.tree_map(_as_float64, settings)


def _traced(tree) -> bool:
    return any(isinstance(x, jax.core.Tracer) for x in jax.tree_util.tree_leaves(tree))


def stability_limit(scene: Scene):
    """The scene's stability limit `critical_step` (a stored program when the CLI has switched
    the store on), not differentiated: a step, not a design output."""
    dt_critical = _export.call(_critical_step, scene, name="critical_step")
    return jax.lax.stop_gradient(jnp.asarray(dt_critical, float))


def derived_cap(scene: Scene):
    """The scene's derived time cap (``Settings(t_max=None)``, `time_cap`): a Python float for
    a concrete scene (computed mostly on the host), a traced, undifferentiated cap under
    jit/vmap."""
    if _traced(scene):
        return jax.lax.stop_gradient(time_cap(scene))
    return concrete_time_cap(scene)


def run_cap(scene: Scene, settings: Settings):
    """The cap of `scene`'s run: `Settings.t_max`, else the scene's derived cap."""
    return settings.t_max if settings.t_max is not None else derived_cap(scene)


def max_steps_for(scene: Scene, settings: Settings, dt_critical=None, cap=None) -> int:
    """`Settings.max_steps`, else the step bound (`step_bound`) of `scene`'s run: its cap and
    stability limit computed here unless given. Needs concrete values (not under jit/vmap)."""
    if settings.max_steps is not None:
        return settings.max_steps
    if cap is None:
        cap = run_cap(scene, settings)
    if settings.dt is None and dt_critical is None:
        dt_critical = stability_limit(scene)
    if _traced((cap, dt_critical, settings.dt, settings.safety)):
        raise ValueError("under jit/vmap give Settings(max_steps=...) explicitly")
    dt = settings.dt if settings.dt is not None else np.asarray(dt_critical) * settings.safety
    return step_bound(cap, dt, settings.substeps)


@eqx.filter_jit
def _simulate(
    scene: Scene, settings: Settings, max_steps: int, adjoint, dt_critical, cap, step_limit
) -> Solution:
    # The batched core with a batch of one: the diffrax clock is then the collision's own
    # physical time, so histories and shapes are saved at physical times. Every setting
    # arrives resolved (`prepare`): the stability limit, the cap and the step bound
    # (`step_limit`, the clock's; `max_steps`, diffrax's static loop bound, may exceed it so
    # that a rerun at a smaller step reuses this program).
    import diffrax  # at trace time: a stored program (`_runtime.export`) runs without diffrax

    flat = flatten(scene)
    dt = dt_critical * settings.safety if settings.dt is None else settings.dt
    # t_max=None: this collision's derived cap, on its floor's grid (`make_clock`)
    derived = None if settings.t_max is not None else cap[None]
    clock = make_clock(flat, dt[None], settings, step_limit, derived)
    y0 = batch_initial_state(flat)
    k0 = clock.k0[0]
    ts = jnp.linspace(0.0, cap, settings.history_points)
    shape_ts = jnp.asarray(sorted({0.0, *settings.shape_times}), float)
    saveat = diffrax.SaveAt(
        subs=[
            diffrax.SubSaveAt(ts=ts, fn=lambda t, y, args: history_of(flat, y)),
            diffrax.SubSaveAt(ts=shape_ts, fn=lambda t, y, args: chain_state(flat, y).x),
            # diffrax's output buffers cannot hold empty tuples (a scene without contacts)
            diffrax.SubSaveAt(t1=True, fn=lambda t, y, args: _without_empty(y)),
        ]
    )
    sol = solve(
        flat, clock, y0, settings, max_steps=max_steps, dt0=clock.dt0[0], saveat=saveat,
        adjoint=adjoint,
    )  # fmt: skip
    hist, shapes, last = sol.ys
    last = _with_empty(jax.tree_util.tree_map(lambda a: a[-1], last))
    final = chain_state(flat, last)
    t_end = last.t[0]
    code = jnp.where(
        last.done[0] > 0,
        last.code[0].astype(int),
        jnp.where(  # diffrax stopped first (its max_steps): never with the clock's own bound
            sol.result == diffrax.RESULTS.max_steps_reached,
            RESULTS.max_steps,
            RESULTS.time_limit,
        ),
    )
    kinetic = final.kinetic(scene)
    block = sum(
        0.5 * c.attached_mass * jnp.sum(v[-1] ** 2)
        for c, v in zip(scene.chains, final.v, strict=True)
    )
    return Solution(
        result=code,
        t_end=t_end,
        steps=(last.k[0] * settings.substeps).astype(int),
        dt=dt,
        dt_critical=dt_critical,
        k0=k0,
        bending=final.bending,
        axial=final.axial,
        contact=final.contact,
        kinetic=kinetic,
        kinetic_block=jnp.asarray(block),
        elastic=final.elastic,
        drive_work=final.drive_work,
        final=final,
        ts=ts,
        history=hist,
        shape_ts=shape_ts,
        shapes=shapes,
        peaks=_peaks.as_dict(jax.tree_util.tree_map(lambda a: a[..., 0], last.peaks)),
    )


def _without_empty(y: BatchState) -> dict:
    fields = ((f.name, getattr(y, f.name)) for f in dataclasses.fields(y))
    return {name: v for name, v in fields if not (isinstance(v, tuple) and not v)}


def _with_empty(saved: dict) -> BatchState:
    return BatchState(**{f.name: saved.get(f.name, ()) for f in dataclasses.fields(BatchState)})


def simulate(
    scene: Scene,
    settings: Settings = Settings(),
    *,
    adjoint: diffrax.AbstractAdjoint | None = None,
    dt_critical=None,
) -> Solution:
    """Run one scene (jit/vmap/grad-compatible; see `run` for the checked, user-facing form).

    **Arguments:**
    - `scene`: what to simulate (`ring_on_beam`, ...).
    - `settings`: how to integrate (`Settings`).
    - `adjoint`: how to differentiate: diffrax's ``RecursiveCheckpointAdjoint`` (default,
      reverse mode) or ``ForwardMode`` (for ``jax.jvp``, cheapest for few design variables).
    - `dt_critical`: the scene's stability limit when already known (`critical_step(scene)`);
      None computes it. Giving a wrong value gives a wrong step: it is not checked.
    """
    return _simulate(*prepare(scene, settings, adjoint, dt_critical))


def require_float64() -> None:
    """Refuse to run in float32: `import msfd_jax` switches JAX to float64 for the process
    (``jax_enable_x64``), and the energy balance (1e-12 K0 in the regression record) and the
    stiff contact need it; code that switched it off afterwards gets this message, not a
    silently inaccurate run."""
    if not jax.config.jax_enable_x64:
        raise RuntimeError(
            "msfd_jax computes in float64, but jax_enable_x64 has been switched off after "
            "`import msfd_jax`; switch it back on (jax.config.update('jax_enable_x64', True))"
        )


def prepare(
    scene: Scene,
    settings: Settings,
    adjoint=None,
    dt_critical=None,
    *,
    loop_steps: int = 0,
    headroom: int = 1,
) -> tuple:
    """The arguments of the compiled `_simulate` for `simulate(scene, settings, ...)`.

    Every setting of a run is resolved here, once, in this order: the stability limit
    (`dt_critical`, else the scene's, `stability_limit`), the cap (`Settings.t_max`, else
    the scene's derived cap, `derived_cap`), the step bound (`Settings.max_steps`, else
    `step_bound`; under jit/vmap it must be given) and the sample times (`compiled_settings`:
    shape times past the cap dropped; the history's `history_points` span [0, cap]). The
    program then derives nothing again. ``_simulate.lower(*prepare(...)).compile()``
    compiles (or loads from the persistent cache) ahead of the run, so that `run` can time
    compilation and the run apart.

    The step bound is the clock's (a run stops there, `RESULTS.max_steps`); diffrax's loop
    bound, static, is the larger of `headroom` times it and `loop_steps` (the bound alone when
    `Settings.max_steps` is given), so that `run` compiles its first attempt with room for its
    reruns at a halved step (`_collision.attempts.retry_headroom`) and they reuse its program.
    """
    require_float64()
    if dt_critical is None:
        dt_critical = stability_limit(scene)
    dt_critical = jax.lax.stop_gradient(_as_float64(dt_critical))
    cap = run_cap(scene, settings)
    bound = max_steps_for(scene, settings, dt_critical, cap)
    # adjoint None stays None: `solver.solve` takes diffrax's RecursiveCheckpointAdjoint, the
    # same program, and a process that loads a stored program needs no diffrax for the key
    loop = bound if settings.max_steps is not None else max(bound * headroom, loop_steps)
    return (
        scene,
        compiled_settings(settings, cap),
        loop,
        adjoint,
        dt_critical,
        _as_float64(cap),
        _as_float64(bound),  # `step_limit`: the clock's bound, data
    )


def _as_float64(v):
    """A Settings number as a float64 array: numpy scalars and 0-d arrays (np.float32(0.5),
    np.int64(2)) too, which would otherwise key a new compiled program by their dtype."""
    if isinstance(v, jax.core.Tracer):
        return v
    return jnp.asarray(v, float)
