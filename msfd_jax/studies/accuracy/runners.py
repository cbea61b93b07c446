"""The study's collisions (`CASES`), configuration (`Config`, `QUICK`) and runners.

Each runner returns a function of no arguments that runs once and returns a dict; `time_jobs`
times them as the diffrax FAQ recommends; `reference` is the small-step Verlet reference.
"""

from __future__ import annotations

import dataclasses
import math
import os
import time
from collections.abc import Callable, Sequence
from typing import Any

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp

from ..._batched.results import RESULTS
from ..._batched.simulate import Settings, critical_step, simulate
from ..._model.params import CollisionParams, Mesh
from ..._model.scene import Scene
from ..._reference.dynamics import initial_state
from ..._reference.verlet import VelocityVerlet, rate_form
from .methods import (
    YoshidaVerlet,
    lumped,
    max_error,
    state_fractions,
    viscoplastic_elastic,
    viscoplastic_field,
    viscoplastic_state,
)

# ----------------------------------------------------------------------------------------------
# Collisions and study configuration

CASES: dict[str, tuple[str, CollisionParams]] = {
    "showcase": (
        "the paper's showcase, CollisionParams() (h_b/h_r = 2.5, constrained)",
        CollisionParams(),
    ),
    "thin_free": (
        "thin free beam that folds and settles late (h_b/h_r = 0.5, free)",
        CollisionParams(thickness_ratio=0.5, axial_constraint=0.0),
    ),
    "thick": ("thick beam (h_b/h_r = 4, constrained)", CollisionParams(thickness_ratio=4.0)),
}
TINY_MESH = Mesh(6, 8, 2)  # the implicit solver's tiny case
# the quick form's mesh: on 6/8+2 the thin free beam breaks its energy balance at every step
# (the folding is too coarse to follow), on 8/10+3 it settles (as in tuning_success.md)
QUICK_MESH = Mesh(8, 10, 3)


@dataclasses.dataclass(frozen=True)
class Config:
    """What the study runs (the full form by default; `QUICK` for tests and ``--quick``).

    **Arguments:**
    - `mesh`: the mesh of every collision (the paper's by default).
    - `t_fixed`: tau at which the ``fixed_time`` metric compares all seven fractions.
    - `safeties`: Verlet step sizes, dt = safety x dt_crit (8 sub-steps per diffrax step).
    - `substep1_safeties`: the same with one Verlet step per diffrax step (cost only).
    - `yoshida_safeties`: step of the 4th-order composition, in units of dt_crit.
    - `rk_tolerances`: rtol of the adaptive Runge-Kutta runs (atol = rtol, energies are O(1)).
    - `etas`: Perzyna relaxation times of the rate form (non-dimensional time).
    - `kvaerno`: rtol values of the implicit Kvaerno5 runs (run on `kvaerno_mesh` only).
    - `yield_smoothings`, `contact_smoothings`: smoothing levels at the default step.
    - `reference_safeties`: successive halvings; the last is the reference.
    - `repeats`: timed runs per configuration (after one untimed warm-up run).
    - `stop_max_steps`, `fixed_max_steps`: static bounds on diffrax steps (one program each).
    """

    mesh: Mesh = Mesh()
    t_fixed: float = 6.0
    safeties: tuple[float, ...] = (1.0, 0.9, 0.8, 0.7, 0.6, 0.5, 0.35, 0.25, 0.125, 0.05)
    substep1_safeties: tuple[float, ...] = (1.0, 0.5, 0.125)
    yoshida_safeties: tuple[float, ...] = (0.75, 0.6, 0.4, 0.25, 0.15)
    rk_solvers: tuple[str, ...] = ("tsit5", "dopri5")
    rk_tolerances: tuple[float, ...] = (1e-4, 1e-6, 1e-8)
    etas: tuple[float, ...] = (1e-3, 3e-4)
    rk_eta: float = 1e-4
    kvaerno: tuple[float, ...] = (1e-3, 1e-5)
    kvaerno_mesh: Mesh = TINY_MESH
    kvaerno_t: float = 0.1
    yield_smoothings: tuple[float, ...] = (0.002, 0.005, 0.02, 0.05)
    contact_smoothings: tuple[float, ...] = (1e-4, 1e-3, 1e-2)
    reference_safeties: tuple[float, ...] = (0.04, 0.02, 0.01)
    repeats: int = 3
    stop_max_steps: int = 2**18
    fixed_max_steps: int = 2**17


QUICK = Config(
    mesh=QUICK_MESH,
    t_fixed=1.0,
    safeties=(1.0, 0.8, 0.5, 0.25),
    substep1_safeties=(0.5,),
    yoshida_safeties=(0.6, 0.3),
    rk_solvers=("tsit5",),
    rk_tolerances=(1e-4, 1e-6),
    etas=(1e-3,),
    kvaerno=(1e-4,),
    kvaerno_t=0.02,
    yield_smoothings=(0.005,),
    contact_smoothings=(1e-3,),
    reference_safeties=(0.1, 0.05, 0.025),
    repeats=2,
    stop_max_steps=2**14,
    fixed_max_steps=2**14,
)

METHODS = (
    "verlet",
    "verlet_substeps1",
    "yoshida4",
    "rk",
    "perzyna_eta",
    "kvaerno5",
    "smoothing",
)

# ----------------------------------------------------------------------------------------------
# Runners: each returns a function of no arguments that runs once and returns a dict


@eqx.filter_jit
def _solve(term, solver, y0, args, t1, dt0, controller, max_steps: int):
    sol = diffrax.diffeqsolve(
        term,
        solver,
        t0=0.0,
        t1=t1,
        dt0=dt0,
        y0=y0,
        args=args,
        saveat=diffrax.SaveAt(t1=True),
        stepsize_controller=controller,
        max_steps=max_steps,
        throw=False,
    )
    y1 = jax.tree_util.tree_map(lambda a: a[-1], sol.ys)
    return y1, sol.stats["num_steps"], sol.stats["num_rejected_steps"], sol.result


def _finish(scene, y1, elastic, steps, rejected, result, force_evals_per_step) -> dict[str, Any]:
    f = {k: float(v) for k, v in state_fractions(scene, y1, elastic).items()}
    ok = result == diffrax.RESULTS.successful and all(math.isfinite(v) for v in f.values())
    return dict(
        fractions=f,
        steps=int(steps),
        rejected=int(rejected),
        force_evaluations=int((int(steps) + int(rejected)) * force_evals_per_step),
        ok=bool(ok),
        result="ok" if ok else "failed",
    )


def verlet_fixed(
    scene: Scene,
    safety: float,
    t1: float,
    substeps: int = 8,
    max_steps=2**17,
    yoshida: bool = False,
) -> Callable[[], dict]:
    """Verlet (or its Yoshida composition) to tau = t1 at dt = safety x dt_crit."""
    solve = verlet_solver(scene, safety, t1, substeps, max_steps, yoshida)

    def run():
        y1, steps, _, result = solve()
        return _finish(scene, y1, y1.elastic, steps * substeps, 0, result, 3 if yoshida else 1)

    return run


def verlet_solver(
    scene: Scene,
    safety: float,
    t1: float,
    substeps: int = 8,
    max_steps=2**17,
    yoshida: bool = False,
) -> Callable[[], tuple]:
    """A function running Verlet to t1: (final State, diffrax steps, rejected, result)."""
    dt = jnp.asarray(safety * float(critical_step(scene)))
    solver = (YoshidaVerlet if yoshida else VelocityVerlet)(substeps)
    y0 = initial_state(scene)
    args = (scene, jnp.asarray(1e-5) * scene.initial_kinetic_energy)
    t1 = jnp.asarray(t1, float)

    def run():
        return jax.block_until_ready(
            _solve(
                diffrax.ODETerm(rate_form),
                solver,
                y0,
                args,
                t1,
                dt * substeps,
                diffrax.ConstantStepSize(),
                max_steps,
            )
        )

    return run


_RK = {"tsit5": diffrax.Tsit5, "dopri5": diffrax.Dopri5, "kvaerno5": diffrax.Kvaerno5}
_EVALS = {"tsit5": 6, "dopri5": 6, "kvaerno5": 5}  # explicit: FSAL stages; implicit: stages


def rk_fixed(
    scene: Scene, solver: str, rtol: float, eta: float, t1: float, max_steps=2**17
) -> Callable[[], dict]:
    """An adaptive diffrax solver on the Perzyna rate form to tau = t1 (atol = rtol)."""
    y0 = viscoplastic_state(initial_state(scene))
    args = (scene, jnp.asarray(eta, float))
    controller = diffrax.PIDController(
        rtol=jnp.asarray(rtol, float),
        atol=jnp.asarray(rtol, float),
        pcoeff=0.0 if solver == "kvaerno5" else 0.3,
        icoeff=1.0 if solver == "kvaerno5" else 0.4,
    )
    dt0 = jnp.asarray(0.1 * float(critical_step(scene)))
    t1 = jnp.asarray(t1, float)

    def run():
        y1, steps, rejected, result = jax.block_until_ready(
            _solve(
                diffrax.ODETerm(viscoplastic_field),
                _RK[solver](),
                y0,
                args,
                t1,
                dt0,
                controller,
                max_steps,
            )
        )
        return _finish(
            scene, y1, viscoplastic_elastic(scene, y1), steps, rejected, result, _EVALS[solver]
        )

    return run


def verlet_at_stop(scene: Scene, safety: float, config: Config) -> Callable[[], dict]:
    """What `run` gives at the settled stop (default settings but the step)."""
    settings = Settings(
        safety=safety, history_points=11, shape_times=(), max_steps=config.stop_max_steps
    )

    def run():
        sol = jax.block_until_ready(simulate(scene, settings))
        k0 = float(sol.k0)
        f = {
            k: float(v) / k0
            for k, v in (
                ("beam_bending", sol.bending[scene.chain_index("beam")]),
                ("beam_axial", sol.axial[scene.chain_index("beam")]),
                ("ring_bending", sol.bending[scene.chain_index("ring")]),
                ("ring_axial", sol.axial[scene.chain_index("ring")]),
                ("contact", jnp.sum(sol.contact)),
                ("kinetic", jnp.sum(sol.kinetic)),
                ("elastic", sol.elastic),
            )
        }
        code = int(sol.result)
        return dict(
            fractions=f,
            steps=int(sol.steps),
            rejected=0,
            force_evaluations=int(sol.steps),
            t_end=float(sol.t_end),
            ok=code in (0, 1),
            result=RESULTS(code).status,
        )

    return run


# ----------------------------------------------------------------------------------------------
# Timing


def _timed(fn: Callable[[], dict]) -> tuple[dict, float, float]:
    load = os.getloadavg()[0]
    start = time.perf_counter()
    out = fn()
    return out, time.perf_counter() - start, load


@dataclasses.dataclass
class Job:
    """One configuration of one method on one collision (a row of the results)."""

    case: str
    metric: str
    method: str
    parameter: str
    value: float
    run: Callable[[], dict]
    out: dict | None = None
    times: list = dataclasses.field(default_factory=list)
    loads: list = dataclasses.field(default_factory=list)
    compile_s: float = math.nan


def time_jobs(jobs: Sequence[Job], repeats: int, progress: Callable[[str], None]) -> None:
    """Warm-up (compile) every job, then `repeats` timed rounds interleaving all jobs."""
    for i, job in enumerate(jobs, 1):
        job.out, job.compile_s, _ = _timed(job.run)
        progress(
            f"  warm-up [{i}/{len(jobs)}] {job.case} {job.metric} {job.method} "
            f"{job.parameter}={job.value:g}: {job.compile_s:.1f} s"
        )
    for r in range(repeats):
        order = jobs if r % 2 == 0 else list(reversed(jobs))  # interleave, alternate order
        for job in order:
            _, wall, load = _timed(job.run)
            job.times.append(wall)
            job.loads.append(load)
        progress(f"  timing round {r + 1}/{repeats} done (load {os.getloadavg()[0]:.2f})")


# ----------------------------------------------------------------------------------------------
# Reference


def reference(
    scene: Scene, config: Config, metric: str, progress: Callable[[str], None]
) -> dict[str, Any]:
    """Verlet at successive halvings of the step; the last is the reference.

    Returns the fractions at each level, the max differences between successive levels and
    the observed order p = log2(d1 / d2) (Richardson), and the estimated error of the
    reference d2 / (2^p - 1).
    """
    levels = []
    for safety in config.reference_safeties:
        if metric == "fixed_time":
            fn = verlet_fixed(scene, safety, config.t_fixed, max_steps=config.fixed_max_steps * 64)
        else:
            cfg = dataclasses.replace(config, stop_max_steps=config.stop_max_steps * 64)
            fn = verlet_at_stop(scene, safety, cfg)
        out, wall, load = _timed(fn)
        progress(f"  reference {metric} safety {safety}: {wall:.1f} s ({out['result']})")
        levels.append(dict(safety=safety, wall_s=wall, load=load, **out))
    pick = (lambda f: f) if metric == "fixed_time" else lumped
    diffs = [
        max_error(pick(b["fractions"]), pick(a["fractions"]))
        for a, b in zip(levels[:-1], levels[1:], strict=True)
    ]
    order = math.nan
    estimate = diffs[-1] if diffs else math.nan
    if len(diffs) >= 2 and diffs[-1] > 0 and diffs[-2] > 0:
        order = math.log2(diffs[-2] / diffs[-1])
        estimate = diffs[-1] / max(2.0**order - 1.0, 1.0) if order > 0 else diffs[-1]
    return dict(
        metric=metric,
        levels=levels,
        successive_differences=diffs,
        observed_order=order,
        estimated_error=estimate,
        fractions=levels[-1]["fractions"],
    )
