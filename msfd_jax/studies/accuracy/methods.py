"""Work-precision study: error of the energy partition against wall time (issue 5, item 1).

What is compared (docs/accuracy.md):

- **methods**: the default velocity-Verlet step (`VelocityVerlet`, second order, symplectic
  while elastic, return mapping at every step) at several step sizes, with 8 and 1 sub-steps;
  its fourth-order Yoshida composition (`YoshidaVerlet`); diffrax's adaptive Runge-Kutta
  (Tsit5, Dopri5) and implicit (Kvaerno5) solvers on a *rate form* of the laws, the
  elastic-viscoplastic (Perzyna) regularisation `viscoplastic_field`, whose limit for a
  vanishing relaxation time `eta` is the return mapping; and the smoothing parameters of
  `ring_on_beam` (yield, contact) with the default step.
- **error**: max over energy components of |fraction - reference| in units of K0, against a
  reference of the same model and mesh computed with Verlet at a much smaller step
  (`REFERENCE_SAFETIES`, checked by successive halvings and Richardson). Two metrics:
  ``fixed_time`` (all seven fractions at tau = T, no stopping rule) and ``at_stop`` (what a
  user gets from `run`: the dissipated fractions and K + U together at the settled stop; the
  kinetic/elastic split there is the phase of a residual vibration and the stop time depends
  on the step, so the seven-fraction error is recorded too but not used for the verdict).
- **timing** as the diffrax FAQ recommends: every program compiled and run once before timing,
  then `repeats` runs of each configuration, interleaved between methods, median and minimum
  recorded with ``os.getloadavg()`` at each run (the machine may be shared).

Run it with ``msfd bench accuracy`` (``--quick``: coarse mesh, short run) or
``python benchmarks/accuracy.py`` (writes benchmarks/results/accuracy.* and the figures).
"""

from __future__ import annotations

import dataclasses
import math
import os
import statistics
import sys
import time
from collections.abc import Callable, Sequence
from typing import Any

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp

from ..._dynamics import State, initial_state, verlet_step
from ..._laws import ramp, ramp_energy
from ..._outputs import FRACTION_KEYS
from ..._params import CollisionParams, Mesh
from ..._scene import Scene, ring_on_beam
from ..._simulate import RESULT_NAMES, Settings, critical_step, simulate
from ..._solver import VelocityVerlet, rate_form

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
DISSIPATED = FRACTION_KEYS[:5]  # beam bending/axial, ring bending/axial, contact
LUMPED_KEYS = (*DISSIPATED, "kinetic+elastic")
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
# Fourth-order composition of the Verlet step


_W1 = 1.0 / (2.0 - 2.0 ** (1.0 / 3.0))
_W0 = 1.0 - 2.0 * _W1


class YoshidaVerlet(VelocityVerlet):
    """Yoshida's (Forest-Ruth) 4th-order composition of the Verlet step with return mapping.

    Each step of length h is three Verlet steps of w1 h, w0 h, w1 h (w0 = 1 - 2 w1 < 0, a step
    backwards in time). Fourth order for a smooth elastic problem; the return mapping and the
    contact ramp are not smooth (and the backward step is not the inverse of a plastic
    forward step), so the order is not kept once anything yields. Stable for
    omega h < ~1.57 at three force evaluations per step, against 2 at one for Verlet.
    """

    def order(self, terms):
        return 4

    def step(self, terms, t0, t1, y0, args, solver_state, made_jump):
        del solver_state, made_jump, terms
        scene, settle_tolerance = args
        h = (t1 - t0) / self.substeps

        def substep(i, y):
            t = t0 + i * h
            y = verlet_step(scene, y, t + _W1 * h, _W1 * h, settle_tolerance)
            y = verlet_step(scene, y, t + (_W1 + _W0) * h, _W0 * h, settle_tolerance)
            return verlet_step(scene, y, t + h, _W1 * h, settle_tolerance)

        y1 = jax.lax.fori_loop(0, self.substeps, substep, y0)
        return y1, None, dict(y0=y0, y1=y1), None, diffrax.RESULTS.successful


# ----------------------------------------------------------------------------------------------
# Rate form: elastic-viscoplastic (Perzyna) regularisation of the laws


class Viscoplastic(eqx.Module):
    """ODE state of the rate form: positions, velocities, plastic parts, dissipated energies."""

    x: tuple[jax.Array, ...]
    v: tuple[jax.Array, ...]
    plastic_rotation: tuple[jax.Array, ...]
    plastic_strain: tuple[jax.Array, ...]
    permanent_set: tuple[jax.Array, ...]
    bending: jax.Array
    axial: jax.Array
    contact: jax.Array


def viscoplastic_state(state: State) -> Viscoplastic:
    """The rate-form state holding the same positions, velocities and history as `state`."""
    return Viscoplastic(
        state.x,
        state.v,
        state.plastic_rotation,
        state.plastic_strain,
        state.permanent_set,
        state.bending,
        state.axial,
        state.contact,
    )


def _overstress_rate(force, yield_force, stiffness, eta):
    """Perzyna flow: dq_p/dt = sign(f) <|f| - f_y> / (k eta); dissipation rate f dq_p/dt."""
    rate = jnp.sign(force) * jnp.maximum(jnp.abs(force) - yield_force, 0.0) / (stiffness * eta)
    return rate, force * rate


def _viscoplastic_response(scene: Scene, y: Viscoplastic, eta):
    """Generalized forces (no clipping: the overstress relaxes at rate 1/eta), flow rates."""
    from ..._dynamics import deformations

    (q_chains, q_contacts), pullback = jax.vjp(lambda x: deformations(scene, x), y.x)
    g_chains, rot_rates, strain_rates, bend, axial, elastic = [], [], [], [], [], 0.0
    for c, (angle, strain), rp, sp in zip(
        scene.chains, q_chains, y.plastic_rotation, y.plastic_strain, strict=True
    ):
        stiffness, weight = c.joint_stiffness_and_weight()
        s = c.section
        moment = stiffness * (angle - rp)
        normal = s.axial_modulus * (strain - sp)
        rot_rate, bend_power = _overstress_rate(moment, s.plastic_moment, stiffness, eta)
        strain_rate, axial_power = _overstress_rate(normal, s.plastic_axial, s.axial_modulus, eta)
        l0 = c.rest_length
        g_chains.append((weight * moment, normal * l0))
        rot_rates.append(rot_rate)
        strain_rates.append(strain_rate)
        bend.append(jnp.sum(weight * bend_power))
        axial.append(jnp.sum(l0 * axial_power))
        elastic = elastic + 0.5 * jnp.sum(weight * moment**2 / stiffness)
        elastic = elastic + 0.5 * jnp.sum(l0 * normal**2 / s.axial_modulus)
    g_contacts, set_rates, contact = [], [], []
    width = scene.contact_smoothing
    for k, delta, ps in zip(scene.contacts, q_contacts, y.permanent_set, strict=True):
        force = k.stiffness * ramp(delta - ps, width)
        over = jnp.maximum(force - k.yield_force, 0.0)
        rate = over / (k.stiffness * eta)
        g_contacts.append(force)
        set_rates.append(rate)
        contact.append(jnp.sum(force * rate))
        elastic = elastic + jnp.sum(k.stiffness * ramp_energy(delta - ps, width))
    (forces,) = pullback((tuple(g_chains), tuple(g_contacts)))
    accelerations = tuple(
        -f / c.mass[:, None] * c.free for c, f in zip(scene.chains, forces, strict=True)
    )
    rates = (
        tuple(rot_rates),
        tuple(strain_rates),
        tuple(set_rates),
        jnp.stack(bend),
        jnp.stack(axial),
        jnp.stack(contact) if contact else jnp.zeros(1),
    )
    return accelerations, rates, jnp.asarray(elastic)


def viscoplastic_field(t, y: Viscoplastic, args) -> Viscoplastic:
    """dy/dt of the elastic-viscoplastic rate form; ``args = (scene, eta)``.

    dx/dt = v, dv/dt = M^-1 f(x, plastic parts) (the elastic forces -dU_e/dx with the plastic
    parts held, as in the Verlet step), d(plastic part)/dt = <overstress> / (stiffness eta)
    for every joint, bar and contact spring, d(dissipated)/dt = force x plastic rate.
    K + U_e + D is conserved exactly; as eta -> 0 the overstress vanishes and the solution
    tends to the rate-independent one of the return mapping. ``eta`` is a relaxation time
    (non-dimensional), not a property of the paper's material: its bias is measured.
    The scene's drive (if any) is not modelled here: ring_on_beam has none.
    """
    scene, eta = args
    accelerations, (rot, strain, sets, bend, axial, contact), _ = _viscoplastic_response(
        scene, y, eta
    )
    return Viscoplastic(y.v, accelerations, rot, strain, sets, bend, axial, contact)


def viscoplastic_elastic(scene: Scene, y: Viscoplastic):
    """Elastic energy U_e of a rate-form state (units of M_pr)."""
    return _viscoplastic_response(scene, y, 1.0)[2]


# ----------------------------------------------------------------------------------------------
# Fractions from a final state


def _kinetic(scene: Scene, vs):
    return sum(0.5 * jnp.sum(c.mass[:, None] * v**2) for c, v in zip(scene.chains, vs, strict=True))


def state_fractions(scene: Scene, y, elastic) -> dict[str, jax.Array]:
    """The seven energy fractions of K0 (FRACTION_KEYS) of a Verlet or rate-form state."""
    k0 = scene.initial_kinetic_energy
    out = {}
    for name in ("beam", "ring"):
        i = scene.chain_index(name)
        out[f"{name}_bending"] = y.bending[i] / k0
        out[f"{name}_axial"] = y.axial[i] / k0
    out["contact"] = jnp.sum(y.contact) / k0
    out["kinetic"] = _kinetic(scene, y.v) / k0
    out["elastic"] = elastic / k0
    return out


def lumped(fractions: dict[str, float]) -> dict[str, float]:
    """Dissipated fractions and K + U together (the at-stop comparison)."""
    out = {k: fractions[k] for k in DISSIPATED}
    out["kinetic+elastic"] = fractions["kinetic"] + fractions["elastic"]
    return out


def max_error(values: dict[str, float], reference: dict[str, float]) -> float:
    """max over components |value - reference| (fractions: units of K0)."""
    return max(abs(values[k] - reference[k]) for k in reference)


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
            result=RESULT_NAMES[code],
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


# ----------------------------------------------------------------------------------------------
# The study


def _progress_default(line: str) -> None:
    print(line, file=sys.stderr, flush=True)


def case_jobs(name: str, scene: Scene, config: Config, methods: Sequence[str]) -> list[Job]:
    """Every timed configuration of one collision."""
    t1, jobs = config.t_fixed, []
    fmax = config.fixed_max_steps
    if "verlet" in methods:
        for s in config.safeties:
            jobs.append(
                Job(
                    name,
                    "fixed_time",
                    "verlet",
                    "safety",
                    s,
                    verlet_fixed(scene, s, t1, max_steps=fmax),
                )
            )
            jobs.append(
                Job(name, "at_stop", "verlet", "safety", s, verlet_at_stop(scene, s, config))
            )
    if "verlet_substeps1" in methods:
        for s in config.substep1_safeties:
            jobs.append(
                Job(
                    name,
                    "fixed_time",
                    "verlet_substeps1",
                    "safety",
                    s,
                    verlet_fixed(scene, s, t1, substeps=1, max_steps=fmax * 8),
                )
            )
    if "yoshida4" in methods:
        for s in config.yoshida_safeties:
            jobs.append(
                Job(
                    name,
                    "fixed_time",
                    "yoshida4",
                    "safety",
                    s,
                    verlet_fixed(scene, s, t1, max_steps=fmax, yoshida=True),
                )
            )
    if "rk" in methods:
        for solver in config.rk_solvers:
            for tol in config.rk_tolerances:
                jobs.append(
                    Job(
                        name,
                        "fixed_time",
                        f"{solver}_perzyna",
                        "rtol",
                        tol,
                        rk_fixed(scene, solver, tol, config.rk_eta, t1, fmax),
                    )
                )
    if "perzyna_eta" in methods:
        # the regularisation's own error: tight tolerance, several relaxation times
        tight = min(config.rk_tolerances)
        for eta in config.etas:
            if eta == config.rk_eta and "rk" in methods:
                continue
            jobs.append(
                Job(
                    name,
                    "fixed_time",
                    "tsit5_perzyna_eta",
                    "eta",
                    eta,
                    rk_fixed(scene, "tsit5", tight, eta, t1, fmax),
                )
            )
    if "smoothing" in methods:
        params = CASES[name][1]
        for method, symbol, levels in (
            ("yield_smoothing", "s", config.yield_smoothings),
            ("contact_smoothing", "w", config.contact_smoothings),
        ):
            for level in levels:
                sc = ring_on_beam(params, config.mesh, **{method: level})
                fixed = verlet_fixed(sc, 0.5, t1, max_steps=fmax)
                jobs.append(Job(name, "fixed_time", method, symbol, level, fixed))
                stop = verlet_at_stop(sc, 0.5, config)
                jobs.append(Job(name, "at_stop", method, symbol, level, stop))
    return jobs


def _row(job: Job, references: dict) -> dict[str, Any]:
    out = job.out or {}
    ref = references[(job.case, job.metric)]["fractions"]
    row = dict(
        case=job.case,
        metric=job.metric,
        method=job.method,
        parameter=job.parameter,
        value=job.value,
        result=out.get("result", "not run"),
        ok=out.get("ok", False),
        steps=out.get("steps", 0),
        rejected=out.get("rejected", 0),
        force_evaluations=out.get("force_evaluations", 0),
        t_end=out.get("t_end"),
        fractions=out.get("fractions", {}),
        compile_and_first_run_s=job.compile_s,
        wall_s=list(job.times),
        wall_median_s=statistics.median(job.times) if job.times else math.nan,
        wall_min_s=min(job.times) if job.times else math.nan,
        loadavg_1min=list(job.loads),
    )
    f = row["fractions"]
    if f and row["ok"]:
        if job.metric == "fixed_time":
            row["error"] = max_error(f, ref)
            row["error_lumped"] = max_error(lumped(f), lumped(ref))
        else:
            row["error"] = max_error(lumped(f), lumped(ref))
            row["error_lumped"] = row["error"]
        row["error_all_fractions"] = max_error(f, ref)
        row["error_components"] = {k: f[k] - ref[k] for k in ref}
    else:
        row["error"] = row["error_lumped"] = row["error_all_fractions"] = math.nan
    return row


def study(
    config: Config = Config(),
    cases: Sequence[str] | None = None,
    methods: Sequence[str] | None = None,
    metrics: Sequence[str] = ("fixed_time", "at_stop"),
    progress: Callable[[str], None] | None = None,
) -> dict[str, Any]:
    """Run the work-precision study; returns references and one row per configuration.

    **Arguments:**
    - `config`: what to run (`Config()` full, `QUICK` coarse and short).
    - `cases`: names in `CASES` (default all). `methods`: names in `METHODS` (default all).
    - `metrics`: "fixed_time" and/or "at_stop".
    - `progress`: called with a line per stage (default: stderr).
    """
    progress = progress or _progress_default
    cases = list(cases or CASES)
    methods = list(methods or METHODS)
    unknown = [c for c in cases if c not in CASES] + [m for m in methods if m not in METHODS]
    if unknown:
        raise ValueError(
            f"unknown case(s)/method(s) {unknown}; cases: {', '.join(CASES)}; "
            f"methods: {', '.join(METHODS)}"
        )
    references, rows, meta = {}, [], {}
    for name in cases:
        scene = ring_on_beam(CASES[name][1], config.mesh)
        meta[name] = dict(
            description=CASES[name][0],
            dt_critical=float(critical_step(scene)),
            k0=float(scene.initial_kinetic_energy),
        )
        progress(f"{name}: {CASES[name][0]}, dt_crit = {meta[name]['dt_critical']:.3e}")
        for metric in metrics:
            references[(name, metric)] = reference(scene, config, metric, progress)
        jobs = [j for j in case_jobs(name, scene, config, methods) if j.metric in metrics]
        time_jobs(jobs, config.repeats, progress)
        rows += [_row(j, references) for j in jobs]
    if "kvaerno5" in methods and "fixed_time" in metrics:
        try:
            rows += kvaerno_comparison(config, cases, progress)
        except Exception as error:  # noqa: BLE001 - report, keep the rest of the study
            progress(f"kvaerno5 comparison failed: {error!r}")
    return dict(
        config=_config_dict(config),
        cases=meta,
        references=[dict(case=c, **r) for (c, _), r in references.items()],
        rows=rows,
        affinity=sorted(os.sched_getaffinity(0)),
        cpu_count=os.cpu_count(),
    )


def kvaerno_comparison(
    config: Config, cases: Sequence[str], progress: Callable[[str], None]
) -> list[dict[str, Any]]:
    """The implicit solver on a tiny case (coarse mesh, short run) against Verlet and Tsit5.

    Rows use metric "fixed_time_tiny" with their own Verlet reference.
    """
    name = cases[0]
    scene = ring_on_beam(CASES[name][1], config.kvaerno_mesh)
    tiny = dataclasses.replace(config, t_fixed=config.kvaerno_t)
    ref = reference(scene, tiny, "fixed_time", progress)
    refs = {(name, "fixed_time_tiny"): ref}
    t1 = config.kvaerno_t
    jobs = [
        Job(
            name,
            "fixed_time_tiny",
            "kvaerno5_perzyna",
            "rtol",
            tol,
            rk_fixed(scene, "kvaerno5", tol, config.rk_eta, t1, 2**11),
        )
        for tol in config.kvaerno
    ]
    jobs += [
        Job(
            name,
            "fixed_time_tiny",
            "tsit5_perzyna",
            "rtol",
            tol,
            rk_fixed(scene, "tsit5", tol, config.rk_eta, t1, config.fixed_max_steps),
        )
        for tol in config.kvaerno
    ]
    jobs += [
        Job(
            name,
            "fixed_time_tiny",
            "verlet",
            "safety",
            s,
            verlet_fixed(scene, s, t1, max_steps=config.fixed_max_steps),
        )
        for s in (1.0, 0.5, 0.25)
    ]
    time_jobs(jobs, max(1, config.repeats // 2), progress)
    rows = [_row(j, refs) for j in jobs]
    for r in rows:
        r["mesh"] = _mesh_name(config.kvaerno_mesh)
        r["t_fixed"] = t1
        r["reference"] = dict(
            successive_differences=ref["successive_differences"],
            observed_order=ref["observed_order"],
        )
    return rows


def _mesh_name(mesh: Mesh) -> str:
    return f"{mesh.ring_segments}/{mesh.beam_contact_segments}+{mesh.beam_outer_segments}"


def _config_dict(config: Config) -> dict[str, Any]:
    out = dataclasses.asdict(config)
    out["mesh"] = _mesh_name(config.mesh)
    out["kvaerno_mesh"] = _mesh_name(config.kvaerno_mesh)
    return out


# ----------------------------------------------------------------------------------------------
# Stability of a candidate default step on the stability catalogue


def candidate_stability(
    safety: float, quick: bool = False, progress: Callable[[str], None] | None = None
) -> list[dict[str, Any]]:
    """Every catalogue scene run at the default step (no `step_factor`) with `safety` instead."""
    from .. import stability as st

    rows = []
    for entry in st.CATALOGUE:
        if entry.step_factor is not None or entry.float32 or entry.expect != st.FINISHES:
            continue
        e = dataclasses.replace(entry, step_factor=safety)
        row = st.run_scene(e, quick)
        (progress or _progress_default)(
            f"  stability {entry.name} at safety {safety}: {row['result']}, "
            f"error {row['energy_balance_error']:+.2e}; {row['verdict']}"
        )
        rows.append(row)
    return rows


# ----------------------------------------------------------------------------------------------
# Mesh refinement (extends benchmarks/convergence.py)


def mesh_refinement(
    factors: Sequence[int] = (4, 8),
    cases: Sequence[str] | None = None,
    progress: Callable[[str], None] | None = None,
) -> list[dict[str, Any]]:
    """Dissipated fractions at the settled stop (default settings) on refined paper meshes."""
    progress = progress or _progress_default
    rows = []
    for name in cases or CASES:
        for factor in factors:
            mesh = Mesh().refined(factor)
            scene = ring_on_beam(CASES[name][1], mesh)
            settings = Settings(history_points=11, shape_times=())
            start = time.perf_counter()
            sol = jax.block_until_ready(simulate(scene, settings))
            wall = time.perf_counter() - start
            k0 = float(sol.k0)
            f = {
                "beam_bending": float(sol.bending[scene.chain_index("beam")]) / k0,
                "beam_axial": float(sol.axial[scene.chain_index("beam")]) / k0,
                "ring_bending": float(sol.bending[scene.chain_index("ring")]) / k0,
                "ring_axial": float(sol.axial[scene.chain_index("ring")]) / k0,
                "contact": float(jnp.sum(sol.contact)) / k0,
            }
            row = dict(
                case=name,
                factor=factor,
                fractions=f,
                t_end=float(sol.t_end),
                steps=int(sol.steps),
                result=RESULT_NAMES[int(sol.result)],
                wall_s_with_compile=wall,
            )
            progress(f"  mesh x{factor} {name}: {row}")
            rows.append(row)
    return rows


# ----------------------------------------------------------------------------------------------
# Report


def markdown(result: dict[str, Any]) -> str:
    """The references and the rows as the markdown tables recorded in docs/accuracy.md."""
    lines = [
        "## References (Verlet, successive halvings)",
        "",
        "| case | metric | safeties | max diff between successive levels [K0] "
        "| observed order | estimated error of the reference [K0] | t_end | results |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in result["references"]:
        safeties = ", ".join(f"{lv['safety']:g}" for lv in r["levels"])
        diffs = ", ".join(f"{d:.1e}" for d in r["successive_differences"])
        t_end = ", ".join(f"{lv['t_end']:.3f}" for lv in r["levels"] if "t_end" in lv) or "-"
        results = ", ".join(dict.fromkeys(lv["result"] for lv in r["levels"]))
        lines.append(
            f"| {r['case']} | {r['metric']} | {safeties} | {diffs} "
            f"| {r['observed_order']:.2f} | {r['estimated_error']:.1e} | {t_end} | {results} |"
        )
    lines += [
        "",
        "## Runs",
        "",
        "| case | metric | method | parameter | error [K0] | all 7 fractions [K0] "
        "| median s | min s | steps | rejected | force evals | result | load (1 min) |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in result["rows"]:
        loads = r["loadavg_1min"]
        load = f"{min(loads):.1f}-{max(loads):.1f}" if loads else "-"
        lines.append(
            f"| {r['case']} | {r['metric']} | {r['method']} | {r['parameter']} = {r['value']:g} "
            f"| {r['error']:.2e} | {r['error_all_fractions']:.2e} | {r['wall_median_s']:.3f} "
            f"| {r['wall_min_s']:.3f} | {r['steps']} | {r['rejected']} "
            f"| {r['force_evaluations']} | {r['result']} | {load} |"
        )
    return "\n".join(lines)


def fastest_within(
    rows: Sequence[dict[str, Any]], tolerance: float = 1e-3, metric: str = "at_stop"
) -> dict[str, Any]:
    """Per case, the fastest configuration (median time) with error <= tolerance."""
    best = {}
    for r in rows:
        if r["metric"] != metric or not r["ok"] or not r["error"] <= tolerance:
            continue
        key = r["case"]
        if key not in best or r["wall_median_s"] < best[key]["wall_median_s"]:
            best[key] = r
    return best


def plot(result: dict[str, Any], metric: str, path) -> None:
    """Log-log error against median wall time, one panel per collision."""
    from matplotlib.figure import Figure
    from matplotlib.ticker import NullFormatter

    rows = [r for r in result["rows"] if r["metric"] == metric and r["ok"]]
    cases = list(dict.fromkeys(r["case"] for r in rows))
    fig = Figure(figsize=(4.2 * len(cases), 3.8), layout="constrained")
    axes = fig.subplots(1, len(cases), squeeze=False)[0]
    styles = {
        "verlet": ("o-", "C0"),
        "verlet_substeps1": ("s--", "C9"),
        "yoshida4": ("^-", "C1"),
        "tsit5_perzyna": ("D-", "C2"),
        "dopri5_perzyna": ("v-", "C4"),
        "tsit5_perzyna_eta": ("P", "C5"),
        "kvaerno5_perzyna": ("X-", "C3"),
        "yield_smoothing": ("*", "C6"),
        "contact_smoothing": ("h", "C7"),
    }
    for ax, case in zip(axes, cases, strict=True):
        for method in dict.fromkeys(r["method"] for r in rows if r["case"] == case):
            sel = sorted(  # along the method's parameter (step, tolerance, width)
                (r for r in rows if r["case"] == case and r["method"] == method),
                key=lambda r: r["value"],
            )
            t = [r["wall_median_s"] for r in sel]
            e = [max(r["error"], 1e-9) for r in sel]
            style, color = styles.get(method, (".-", "k"))
            ax.loglog(t, e, style, color=color, label=method, ms=5)
            if method == "verlet":
                for r in sel:
                    if r["value"] in (1.0, 0.8, 0.5, 0.25, 0.05):
                        ax.annotate(
                            f"{r['value']:g}",
                            (r["wall_median_s"], max(r["error"], 1e-9)),
                            fontsize=7,
                            xytext=(3, 3),
                            textcoords="offset points",
                        )
        ax.axhline(1e-3, color="gray", lw=0.8, ls=":")
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.set_title(case)
        ax.set_xlabel("wall time, median [s]")
        ax.set_ylabel("max error [K0]")
    axes[-1].legend(fontsize=7, loc="best")
    fig.savefig(path, dpi=110)
