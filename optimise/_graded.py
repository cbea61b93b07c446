"""Guardrail design by gradients: a graded beam under a designer's limits, in SI.

The design variables are the beam's thickness along its span (`msfd_jax.CollisionParams`'s
``thickness_profile``, MODEL.md section 10), through K control points: the profile is the
piecewise-linear interpolant of the control values at the segments' midpoints (knots evenly
spaced over the half span O -> E). K = the number of beam segments gives one free value per
segment. A smooth parametrisation is the default (`DEFAULT_POINTS` = 6): one value per segment
lets a search find designs that live on the mesh (a notch one segment wide), which a finer
mesh then undoes; the finer-mesh recheck (`recheck`) catches them either way.

**Quantities** (SI, whole structure, as `msfd run --si` reports them; `QUANTITIES`):
``deceleration_10ms`` (the largest change of the block's velocity over 10 ms, divided by
10 ms, m/s^2), ``deflection`` (peak mid-span deflection, m), ``contact_force`` (peak total
contact force, N), ``beam_mass`` (beam mass over the uniform beam of ``thickness_ratio``) and
the energy shares (``beam``, ``ring``, ``contact``: fractions of K0).

**Sharp values, smoothed gradients.** Every value reported and every constraint checked is the
sharp model's (no smoothing; the deflection and contact-force peaks kept at every step, the
10 ms deceleration from the saved block velocity as `msfd_jax._model.si` reads it). Peaks and
the model's yield and contact switches are not smooth, so the gradient is that of a surrogate:
the model with `optimise.DEFAULT_SMOOTHING` (yield 0.05, contact 0.01), and each peak over the
saved samples replaced by a log-sum-exp smooth maximum of width `PEAK_WIDTH` (a fraction of
the peak): ``w log sum exp((x_i - max x)/w) + max x``, which lies between the sampled maximum
and it plus w log(n), n the samples within a few w of the top (its bias is in the design
benchmark's report). The step of `design` uses the surrogate's direction and the sharp model's
values (as `optimise.tune` does for the shares).

**Constrained methods** (`METHODS`; `optimise.design` runs them, `optimise/_search.py`):
``"slsqp"``, the default: scipy's SLSQP on the surrogate (values and the Jacobian of the
objective and the limited quantities), every point it evaluates checked on the sharp model.
``"adam"``: an augmented Lagrangian (Powell-Hestenes-Rockafellar) around optax's Adam in unit
coordinates (`_Lane`, `drive`; `design_front` runs it in lockstep); the thickness bounds and
the beam mass budget (linear in the control values) are enforced exactly by projection (clip,
then bisection on the budget's multiplier), so every iterate is within bounds and budget; the
other limits (deflection, deceleration, contact force) are constraints g = q / limit - 1 <= 0
with multipliers updated each step, lambda <- max(0, lambda + mu g). Either way the best
design that meets every limit on the sharp model is kept; none meeting them gives ``status =
"infeasible"`` with the closest design found (the smallest largest violation).

**Robust design**: with `optimise.Conditions` (impact speeds and masses), each iterate runs every
sample in one vmapped program; the objective is the mean over the samples, each limit applies to
the worst sample.
"""

from __future__ import annotations

import dataclasses
import functools
import time
from typing import Any

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optax

import msfd_jax as m
from msfd_jax._batched.simulate import max_steps_for
from msfd_jax._model.cap import time_cap
from msfd_jax._model.params import _check_count
from msfd_jax._model.si import AVERAGING_S, WHOLE

from ._conditions import Conditions
from ._gradient import DEFAULT_SMOOTHING

DEFAULT_POINTS = 6
PEAK_WIDTH = 0.002  # smooth-maximum width, fraction of the peak (bias: see the module doc)
SHARES = {
    "beam": ("beam_bending", "beam_axial"),
    "ring": ("ring_bending", "ring_axial"),
    "contact": ("contact",),
}
QUANTITIES = ("deceleration_10ms", "deflection", "contact_force", "beam_mass", *SHARES)
UNITS = {
    "deceleration_10ms": "m/s^2",
    "deflection": "m",
    "contact_force": "N",
    "beam_mass": "x uniform",
    "beam": "K0",
    "ring": "K0",
    "contact": "K0",
}
DEFAULT_HISTORY = 401


class GradedProblem(eqx.Module):
    """What stays fixed while a graded design changes (build it with `graded_problem`).

    **Arguments:**
    - `params`: the collision (arrays); its ``thickness_ratio`` is the reference uniform beam.
    - `mesh`: the node counts (static).
    - `settings`: integration settings (cap, step bound and samples fixed for every design).
    - `basis`: (segments, K) interpolation matrix from control values to the profile.
    - `lengths`: (segments,) beam segment lengths (units of R).
    - `scales`: the SI scales as arrays (length R, time T, force M_pr/R).
    - `conditions`: impact samples (`Conditions`) or None.
    - `bounds`: the thickness bounds (h/h_r) the cap and step bound were chosen for.
    """

    params: m.CollisionParams
    mesh: m.Mesh
    settings: m.Settings
    basis: jax.Array
    lengths: jax.Array
    length_scale: jax.Array
    time_scale: jax.Array
    force_scale: jax.Array
    conditions: Conditions | None = None
    bounds: tuple[float, float] = eqx.field(static=True, default=(1.0, 5.0))

    @property
    def points(self) -> int:
        return int(self.basis.shape[1])

    def profile(self, controls):
        """The per-segment profile h_k/h_r of control values `controls` (K,)."""
        return self.basis @ controls

    def mass_row(self) -> np.ndarray:
        """a with a . c = beam mass ratio at control values c (linear)."""
        lengths = np.asarray(self.lengths)
        reference = float(self.params.thickness_ratio) * lengths.sum()
        return lengths @ np.asarray(self.basis) / reference


def _basis(xs: np.ndarray, points: int) -> tuple[np.ndarray, np.ndarray]:
    """(interpolation matrix (segments, K), segment lengths) of a beam with nodes at `xs`
    (O -> E): hat functions on K knots evenly spaced over [0, span], evaluated at the segment
    midpoints; K = segments gives identity."""
    span = float(xs[-1])
    lengths, mid = np.diff(xs), 0.5 * (xs[1:] + xs[:-1])
    n = len(lengths)
    if points == n:
        return np.eye(n), lengths
    knots = np.linspace(0.0, span, points)
    basis = np.stack([np.interp(mid, knots, np.eye(points)[j]) for j in range(points)], axis=1)
    return basis, lengths


def graded_problem(
    params: m.CollisionParams,
    scales: m.Scales,
    mesh: m.Mesh = m.Mesh(),
    *,
    profile_points: int | None = DEFAULT_POINTS,
    conditions: Conditions | None = None,
    history_points: int = DEFAULT_HISTORY,
    bounds: tuple[float, float] = (1.0, 5.0),
    settings: m.Settings | None = None,
) -> GradedProblem:
    """A `GradedProblem` around `params` (SI scales `scales`, from `msfd_jax.from_si`).

    `profile_points`: K control points (None: one per beam segment). The cap and the step
    bound cover the thinnest and thickest uniform beams of `bounds` at every sample of
    `conditions` (so that no design compiles a new program or runs out of steps)."""
    n = m.beam_segments(mesh)
    points = n if profile_points is None else profile_points
    low, high = (float(v) for v in bounds)
    if not 0.0 < low < high <= 100.0:
        raise ValueError(f"bounds = {bounds!r}: give 0 < lower < upper <= 100 (h/h_r)")
    _check_count("profile_points", points, 2, n)
    if params.graded:
        raise ValueError(
            "give the reference uniform beam (thickness_ratio) without a thickness_profile: "
            "the design starts from it and compares with it"
        )
    corners = [dataclasses.replace(params, thickness_ratio=float(t)) for t in bounds]
    if conditions is not None:
        corners = [conditions.apply(p, i) for p in corners for i in range(len(conditions))]
    scenes = [m.ring_on_beam(p, mesh) for p in corners]
    beam = scenes[0].chains[scenes[0].chain_index("beam")]  # the nodes the model builds
    basis, lengths = _basis(np.asarray(beam.reference[:, 0], float), points)
    base = settings or m.Settings()
    cap = base.t_max or max(float(time_cap(s)) for s in scenes)
    chosen = dataclasses.replace(base, t_max=cap, history_points=history_points, shape_times=())
    steps = max(max_steps_for(s, chosen) for s in scenes)
    chosen = dataclasses.replace(chosen, max_steps=steps)
    f = jnp.float64
    return GradedProblem(
        params.as_arrays(),
        mesh,
        jax.tree_util.tree_map(lambda v: jnp.asarray(v, f) if isinstance(v, float) else v, chosen),
        jnp.asarray(basis, f),
        jnp.asarray(lengths, f),
        jnp.asarray(scales.length, f),
        jnp.asarray(scales.time, f),
        jnp.asarray(scales.force, f),
        conditions,
        (float(bounds[0]), float(bounds[1])),
    )


def smooth_max(x, width):
    """w log sum exp((x - max)/w) + max: >= max(x), within w log(len(x)) of it."""
    top = jax.lax.stop_gradient(jnp.max(x))
    return top + width * jnp.log(jnp.sum(jnp.exp((x - top) / width)))


def _held(values, ts, t_end, final):
    """Samples past the run's end (diffrax fills them with inf) held at the final value."""
    return jnp.where((ts <= t_end + 1e-12) & jnp.isfinite(values), values, final)


def _one(profile, params, problem: GradedProblem, smoothing, adjoint, sharp: bool):
    p = dataclasses.replace(params, thickness_profile=profile)
    scene = m.ring_on_beam(
        p, problem.mesh, yield_smoothing=smoothing[0], contact_smoothing=smoothing[1]
    )
    sol = m.simulate(scene, problem.settings, adjoint=adjoint)
    ts, h = sol.ts, sol.history
    ring = scene.chain_index("ring")
    beam = scene.chain_index("beam")
    v_end = sol.final.v[ring][-1, 1]
    d_end = sol.final.x[beam][0, 1] - scene.chains[beam].reference[0, 1]
    v = _held(h["block_velocity"], ts, sol.t_end, v_end)
    d = jnp.abs(_held(h["midspan_deflection"], ts, sol.t_end, d_end))
    force = _held(jnp.sum(h["contact_force"], axis=-1), ts, sol.t_end, 0.0)
    window = AVERAGING_S / problem.time_scale
    change = jnp.abs(jnp.interp(ts + window, ts, v) - v) / window
    accel = problem.length_scale / problem.time_scale**2
    k0 = jnp.where(sol.k0 > 0, sol.k0, 1.0)
    bending = sol.bending / k0
    axial = sol.axial / k0
    fractions = {
        "beam_bending": bending[beam],
        "beam_axial": axial[beam],
        "ring_bending": bending[ring],
        "ring_axial": axial[ring],
        "contact": jnp.sum(sol.contact) / k0,
    }
    shares = {k: sum(fractions[f] for f in keys) for k, keys in SHARES.items()}
    if sharp:
        peaks = sol.peaks
        deflection = peaks["peak_deflection"]
        contact_force = peaks["peak_contact_force"]
        decel = jnp.max(change)
    else:
        deflection = smooth_max(d, PEAK_WIDTH * jax.lax.stop_gradient(jnp.max(d)))
        contact_force = smooth_max(force, PEAK_WIDTH * jax.lax.stop_gradient(jnp.max(force)))
        decel = smooth_max(change, PEAK_WIDTH * jax.lax.stop_gradient(jnp.max(change)))
    out = {
        "deceleration_10ms": decel * accel,
        "deflection": deflection * problem.length_scale,
        "contact_force": WHOLE * contact_force * problem.force_scale,
        **shares,
    }
    return out, (sol.result, sol.energy_balance_error)


def quantities(controls, problem: GradedProblem, *, sharp: bool = True, adjoint=None):
    """The design quantities at control values `controls` (K,): per sample with conditions.

    Returns ({quantity: value or (samples,)}, (result codes, energy balance errors)). The beam
    mass ratio is exact (linear in the controls). `sharp`: the sharp model's values; else the
    surrogate (smoothed model, smooth peaks) that `design` differentiates."""
    adjoint = adjoint or diffrax.RecursiveCheckpointAdjoint()
    widths = (
        (0.0, 0.0)
        if sharp
        else (
            DEFAULT_SMOOTHING["yield_smoothing"],
            DEFAULT_SMOOTHING["contact_smoothing"],
        )
    )
    smoothing = tuple(jnp.asarray(w, jnp.float64) for w in widths)
    profile = problem.profile(controls)
    if problem.conditions is None:
        out, aux = _one(profile, problem.params, problem, smoothing, adjoint, sharp)
    else:

        def sample(fields):
            at = dataclasses.replace(problem.params, **fields)
            return _one(profile, at, problem, smoothing, adjoint, sharp)

        out, aux = jax.vmap(sample)(problem.conditions.fields())
    lengths = problem.lengths
    reference = problem.params.thickness_ratio * jnp.sum(lengths)
    out["beam_mass"] = jnp.sum(profile * lengths) / reference
    return out, aux


@eqx.filter_jit
def _sharp(controls, problem):
    return quantities(controls, problem, sharp=True)


def _reduce(values: dict, problem: GradedProblem, objective: str, worst: bool):
    """One number per quantity: the mean over samples (objective) or the worst (limits)."""
    if problem.conditions is None:
        return values
    w = problem.conditions.weights
    out = {}
    for k, v in values.items():
        if jnp.ndim(v) == 0:
            out[k] = v
        elif k == objective or not worst:
            out[k] = jnp.sum(w * v)
        else:
            out[k] = jnp.max(v)
    return out


@eqx.filter_jit
def _surrogate_grad(controls, weights, problem, objective, checkpoints):
    """Value and gradient of sum_q weights[q] * surrogate q (one reverse sweep), the worst
    sample's limit as a smooth maximum over the samples."""
    return surrogate_value_and_grad(controls, weights, problem, objective, checkpoints)


def reduce_surrogate(values: dict, problem: GradedProblem, objective: str) -> dict:
    """The surrogate's one number per quantity over the samples of conditions (none: as
    given): the mean for the objective, a smooth maximum of the worst sample for a limit."""
    if problem.conditions is None:
        return values
    w = problem.conditions.weights
    return {
        k: (
            v
            if jnp.ndim(v) == 0
            else jnp.sum(w * v)
            if k == objective
            else smooth_max(v, PEAK_WIDTH * jax.lax.stop_gradient(jnp.max(jnp.abs(v))))
        )
        for k, v in values.items()
    }


def surrogate_value_and_grad(controls, weights, problem, objective, checkpoints):
    """`_surrogate_grad` unjitted (`design_front` vmaps it over designs)."""
    adjoint = diffrax.RecursiveCheckpointAdjoint(checkpoints)

    def weighted(c):
        values, _ = quantities(c, problem, sharp=False, adjoint=adjoint)
        values = reduce_surrogate(values, problem, objective)
        return sum(weights[k] * values[k] for k in weights), values

    (_, values), grad = jax.value_and_grad(weighted, has_aux=True)(controls)
    return values, grad


def stored_checkpoints(problem: GradedProblem, checkpoints: int | None = None) -> int:
    """The checkpoints `design` gives `_surrogate_grad` (a static argument: another value is
    another program). None: every step's state stored, one per step bound, so the gradient
    recomputes no part of the forward run (diffrax's default recomputes; 8192 steps of a few
    kB each fit easily)."""
    return int(problem.settings.max_steps) if checkpoints is None else int(checkpoints)


def project_budget(c, low, high, row, budget):
    """The closest point to `c` with low <= c <= high and row . c <= budget (None: no budget):
    clip, then bisection on the budget's multiplier (the projection onto a box cut by one
    half-space is clip(c - lam row) for the lam that meets the budget)."""
    c = np.asarray(c, float)
    x = np.clip(c, low, high)
    if budget is None or row @ x <= budget:
        return x
    lo, hi = 0.0, 1.0
    while row @ np.clip(c - hi * row, low, high) > budget and hi < 1e12:
        hi *= 2.0
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        if row @ np.clip(c - mid * row, low, high) > budget:
            lo = mid
        else:
            hi = mid
    return np.clip(c - hi * row, low, high)


@dataclasses.dataclass
class GradedDesign:
    """What `design` found (sharp-model values throughout).

    - `status`: ``"converged"`` (every limit met, the objective stopped improving, or SLSQP
      met its own test at a point that meets every limit),
      ``"feasible"`` (every limit met, the step budget ran out first) or ``"infeasible"``
      (no design met every limit; the closest is returned).
    - `controls`, `thickness_profile`: the design (control values; h_k/h_r per segment).
    - `values`: the sharp quantities of the design (worst sample for limits, mean for the
      objective); `samples`: per-sample values with conditions.
    - `constraints`: per limit, ``{"value", "limit", "margin"}`` (margin = limit - value, in the
      quantity's unit; >= 0 is met).
    - `start`: the sharp values of the starting (uniform) design.
    - `evaluations`: forward-run equivalents (a sharp run 1; Adam's surrogate gradient
      `GRADIENT_COST` = 20, SLSQP's surrogate Jacobian `_search.JACOBIAN_COST`, each as
      measured on the paper mesh by benchmarks/design.py); `iterations`: the points evaluated
      after the start (each one sharp run and, but a last one the step budget stopped, one
      gradient or Jacobian; SLSQP's line-search trials count); `wall_time_s`.
    - `history`: per point, the objective, the largest violation, the profile, and the
      wall times of its sharp run and gradient (``sharp_s``, ``gradient_s``; the first
      iteration's include compiling where the programs were not compiled before).
    """

    status: str
    minimise: str
    controls: np.ndarray
    thickness_profile: np.ndarray
    values: dict[str, float]
    constraints: dict[str, dict[str, float]]
    start: dict[str, float]
    evaluations: float
    iterations: int
    wall_time_s: float
    history: list[dict[str, Any]]
    samples: dict[str, list[float]] | None = None

    def as_json(self) -> dict[str, Any]:
        return {
            "status": self.status,
            "minimise": self.minimise,
            "thickness_profile": [float(v) for v in self.thickness_profile],
            "control_values": [float(v) for v in self.controls],
            "beam_mass_ratio": float(self.values["beam_mass"]),
            "values": {k: float(v) for k, v in self.values.items()},
            "constraints": self.constraints,
            "start": {k: float(v) for k, v in self.start.items()},
            "evaluations": float(self.evaluations),
            "iterations": self.iterations,
            "wall_time_s": self.wall_time_s,
            **({"samples": self.samples} if self.samples is not None else {}),
        }


# a surrogate gradient (every step stored, as `design` runs it) in sharp forward runs at the
# uniform start on the paper mesh, one core: 20.5x and 16.9x in two runs of
# benchmarks/design.py (section 1); along a design the sharp run settles earlier or later
# with the profile, and `history` records both times
GRADIENT_COST = 20.0
METHODS = ("slsqp", "adam")
LIMITS = {
    "deflection": "max_deflection_m",
    "deceleration_10ms": "max_deceleration_10ms_m_s2",
    "contact_force": "max_contact_force_N",
}


def _violation(values, limits) -> float:
    """The largest relative excess over the limits (0: every limit met)."""
    return max([0.0] + [float(values[k]) / v - 1.0 for k, v in limits.items()])


def _checked(problem, minimise, limits, max_beam_mass_ratio, thickness_bounds):
    """`design`'s inputs refused at the boundary; (limits, low, high, mass row)."""
    limits = dict(limits or {})
    for name in [minimise, *limits]:
        if name not in QUANTITIES:
            raise ValueError(f"unknown quantity {name!r}; allowed: {', '.join(QUANTITIES)}")
    if minimise in limits:
        raise ValueError(f"{minimise} is minimised; it cannot also be limited")
    for name, value in limits.items():
        if not (np.isfinite(value) and value > 0):
            raise ValueError(f"limit on {name} = {value!r}: give a positive number")
    thickness_bounds = problem.bounds if thickness_bounds is None else thickness_bounds
    low, high = (float(v) for v in thickness_bounds)
    if not 0.0 < low < high <= 100.0:
        raise ValueError(
            f"thickness_bounds = {thickness_bounds!r}: give 0 < lower < upper <= 100 (h/h_r)"
        )
    if low < problem.bounds[0] or high > problem.bounds[1]:
        raise ValueError(
            f"thickness_bounds = {thickness_bounds!r} reach outside the problem's bounds "
            f"{problem.bounds} (its cap and step bound cover those): build the problem with "
            "graded_problem(..., bounds=...)"
        )
    row = problem.mass_row()
    if max_beam_mass_ratio is not None:
        if not max_beam_mass_ratio > 0:
            raise ValueError(f"max_beam_mass_ratio = {max_beam_mass_ratio!r}: give a ratio > 0")
        if row @ np.full(problem.points, low) > max_beam_mass_ratio * (1 + 1e-12):
            raise ValueError(
                f"max_beam_mass_ratio = {max_beam_mass_ratio:g} is below the mass of the "
                f"thinnest beam the bounds allow ({row @ np.full(problem.points, low):.4g} at "
                f"h/h_r = {low:g} everywhere): lower the thickness bound or raise the budget"
            )
    return limits, low, high, row


def failed_codes(codes) -> list[int]:
    """The result codes among `codes` (one or per sample) that are failures."""
    return [int(k) for k in np.atleast_1d(np.asarray(codes)) if m.RESULTS(int(k)).failed]


def _refuse_failed(codes, problem: GradedProblem, controls) -> None:
    failed = failed_codes(codes)
    if failed:
        raise m.SimulationError(
            f"the collision at thickness profile {np.round(problem.profile(controls), 4)} "
            f"ended with '{m.RESULTS(failed[0]).status}'; narrow thickness_bounds"
        )


class _Lane:
    """One design's state in the loop of `design` (`design_front` runs several in lockstep):
    the iterate, Adam's state, the multipliers, the best and the closest designs so far."""

    def __init__(self, problem, start, minimise, limits, budget, low, high, row, options):
        self.problem, self.minimise, self.limits = problem, minimise, limits
        self.budget, self.low, self.high, self.row = budget, low, high, row
        self.width = high - low
        self.steps, self.penalty, self.patience = (
            options["steps"],
            options["penalty"],
            options["patience"],
        )
        self.tolerance, self.aim = options["tolerance"], options["aim"]
        reference = float(problem.params.thickness_ratio)
        c = np.full(problem.points, reference) if start is None else np.asarray(start, float)
        self.c = project_budget(c, low, high, row, budget)
        self.optimiser = optax.adam(options["learning_rate"])
        self.u = jnp.asarray((self.c - low) / self.width)
        self.opt_state = self.optimiser.init(self.u)
        self.multipliers = {k: 0.0 for k in limits}
        self.history: list[dict[str, Any]] = []
        self.best = self.closest = None
        self.scale = None
        self.stale = 0
        self.evaluations = 0.0
        self.samples = 1 if problem.conditions is None else len(problem.conditions)
        self.start_values: dict[str, float] = {}
        self.done = False
        self.converged = False  # set by a method that has its own convergence test (SLSQP)

    def observe(self, it, raw, sharp_s, progress):
        """Take the sharp values of the current iterate; the surrogate's weights for the next
        gradient, or None when this design stops here."""
        worst = self.problem.conditions is not None
        values = {k: float(v) for k, v in _reduce(raw, self.problem, self.minimise, worst).items()}
        self.evaluations += self.samples
        if it == 0:
            self.start_values = values
            self.scale = abs(values[self.minimise]) or 1.0
        violation = _violation(values, self.limits)
        record = {
            "objective": values[self.minimise],
            "violation": violation,
            "controls": self.c.tolist(),
            "sharp_s": sharp_s,
            "gradient_s": 0.0,
        }
        self.history.append(record)
        if progress is not None:
            progress(it, record)
        best = self.best
        if violation <= 0.0:
            if best is None or values[self.minimise] < best[1][self.minimise] * (
                1 - self.tolerance
            ):
                self.stale = 0
            else:
                self.stale += 1
            if best is None or values[self.minimise] < best[1][self.minimise]:
                self.best = (self.c.copy(), values, raw)
        else:
            self.stale += 1 if best is not None else 0
        if self.closest is None or violation < self.closest[2]:
            self.closest = (self.c.copy(), values, violation, raw)
        if it == self.steps or self.stale >= self.patience:
            self.done = True
            return None
        # the multipliers aim a little inside each limit (`aim`), so that the iterates, which
        # approach the boundary from either side, land on the feasible one
        aim = self.aim
        g = {k: values[k] / (v * (1.0 - aim)) - 1.0 for k, v in self.limits.items()}
        for k in self.limits:
            self.multipliers[k] = max(0.0, self.multipliers[k] + self.penalty * g[k])
        weights = {self.minimise: 1.0 / self.scale}
        for (
            k,
            v,
        ) in self.limits.items():  # PHR: d/dq of (max(0, lam + mu g)^2 - lam^2) / (2 mu)
            weights[k] = max(0.0, self.multipliers[k] + self.penalty * g[k]) / (v * (1.0 - aim))
        return {k: jnp.asarray(w, jnp.float64) for k, w in weights.items()}

    def step(self, grad, gradient_s) -> None:
        """One projected Adam step along the surrogate's gradient (control values)."""
        self.evaluations += GRADIENT_COST * self.samples
        grad_u = np.asarray(grad) * self.width
        self.history[-1]["gradient_s"] = gradient_s
        updates, self.opt_state = self.optimiser.update(jnp.asarray(grad_u), self.opt_state, self.u)
        u = optax.apply_updates(self.u, updates)
        self.c = project_budget(
            self.low + np.asarray(u) * self.width,
            self.low,
            self.high,
            self.row,
            self.budget,
        )
        self.u = jnp.asarray((self.c - self.low) / self.width)

    def result(self, wall_time_s: float) -> GradedDesign:
        if self.best is not None:
            converged = self.converged or self.stale >= self.patience
            status = "converged" if converged else "feasible"
            chosen, values, raw = self.best
        else:
            status = "infeasible"
            chosen, values, _, raw = self.closest
        constraints = {
            k: {"value": values[k], "limit": v, "margin": v - values[k]}
            for k, v in self.limits.items()
        }
        budget = self.budget
        if budget is not None:
            constraints["beam_mass"] = {
                "value": values["beam_mass"],
                "limit": budget,
                # met by projection: the last bits of the sum are rounding
                "margin": max(0.0, budget - values["beam_mass"])
                if values["beam_mass"] <= budget * (1 + 1e-12)
                else budget - values["beam_mass"],
            }
        samples = None
        if self.problem.conditions is not None:
            samples = {k: np.atleast_1d(np.asarray(v)).tolist() for k, v in raw.items()}
        return GradedDesign(
            status,
            self.minimise,
            chosen,
            np.asarray(self.problem.profile(jnp.asarray(chosen))),
            values,
            constraints,
            self.start_values,
            self.evaluations,
            len(self.history) - 1,
            wall_time_s,
            self.history,
            samples,
        )


def drive(problem, lanes, minimise, stored, sharp, gradient, progress) -> None:
    """The loop of `design` and `design_front`: each iteration one sharp run of every design
    and one gradient of every design that goes on (`sharp(controls)` and `gradient(controls,
    weights, problem, minimise, stored)` take and give a leading axis over `lanes`); a design
    that has stopped is carried along unchanged until the last one stops. `progress(i, it,
    record)`: design i's iteration it."""
    steps = max(lane.steps for lane in lanes)
    for it in range(steps + 1):
        controls = jnp.asarray(np.stack([lane.c for lane in lanes]))
        tick = time.perf_counter()
        raw, (codes, _) = sharp(controls)
        codes = np.asarray(codes)
        sharp_s = time.perf_counter() - tick
        weights = []
        for i, lane in enumerate(lanes):
            if lane.done:
                weights.append(None)
                continue
            _refuse_failed(codes[i], problem, controls[i])
            told = None if progress is None else functools.partial(progress, i)
            weights.append(lane.observe(it, {k: v[i] for k, v in raw.items()}, sharp_s, told))
        if all(lane.done for lane in lanes):
            return
        keys = next(w for w in weights if w is not None)
        zero = jnp.zeros((), jnp.float64)  # a stopped design: its gradient is not used
        stacked = {k: jnp.stack([zero if w is None else w[k] for w in weights]) for k in keys}
        tick = time.perf_counter()
        _, grads = gradient(controls, stacked, problem, minimise, stored)
        grads = np.asarray(grads)
        gradient_s = time.perf_counter() - tick
        for i, lane in enumerate(lanes):
            if weights[i] is not None:
                lane.step(grads[i], gradient_s)
