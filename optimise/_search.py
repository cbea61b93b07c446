"""`optimise.design`: the search for a graded design, by one of two methods (`METHODS`).

``"slsqp"`` (the default): sequential quadratic programming (scipy's SLSQP) on the surrogate,
every point it evaluates checked on the sharp model. ``"adam"``: the augmented Lagrangian
around projected Adam steps (`_graded._Lane`, `_graded.drive`), the method `design_front`
runs in lockstep.

SLSQP needs values and gradients of one smooth problem, so it works on the surrogate (the
smoothed model, smooth peaks; `_graded`'s module doc): the objective and each limit's quantity
come with their gradients from one reverse-mode Jacobian (`_surrogate_jacobian`: one forward
run, one backward sweep per row, vmapped). The thickness bounds and the beam mass budget are
linear and exact. Each limit is a constraint on the surrogate quantity, `aim` inside the
limit. The first round leaves the surrogate's bias in (on the paper's case the surrogate
deflects more than the sharp model, so its limit is conservative); a later round offsets each
limit by the sharp value minus the surrogate's at its start point. Offsetting the first round
too was tried: better at K = 6, worse at K = 10 (probe `git show cbd7d9a`).

Every point SLSQP evaluates (its iterates and its line search's trial points) is run on the
sharp model too, and the bookkeeping of the projected-gradient method decides what is kept
(`_graded._Lane`: the best design meeting every sharp limit, else the closest; stopping after
`patience` points without a `tolerance` gain, or after `steps` points). When a round of SLSQP
ends (converged, or stopped by its own rules) with points left and the point it ended on
outside a sharp limit, a new round starts from the best (else closest) design with the
offsets measured there; at most `ROUNDS` rounds.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from scipy.optimize import minimize

import msfd_jax as m

from ._graded import (
    METHODS,
    GradedDesign,
    GradedProblem,
    _checked,
    _Lane,
    _reduce,
    _refuse_failed,
    _sharp,
    _surrogate_grad,
    _violation,
    drive,
    failed_codes,
    quantities,
    reduce_surrogate,
    stored_checkpoints,
)

ROUNDS = 3


@eqx.filter_jit
def _surrogate_jacobian(controls, problem: GradedProblem, names: tuple[str, ...], checkpoints):
    """Surrogate values of `names` (objective first, then the limits) and their Jacobian
    (len(names), K): one forward run, the backward sweeps vmapped over the rows. With
    conditions the objective is the mean over the samples and a limit's quantity the worst
    sample's, as a smooth maximum (`_graded.reduce_surrogate`, as for Adam's gradient)."""
    adjoint = diffrax.RecursiveCheckpointAdjoint(checkpoints)

    def rows(c):
        values, _ = quantities(c, problem, sharp=False, adjoint=adjoint)
        values = reduce_surrogate(values, problem, names[0])
        return jnp.stack([values[k] for k in names])

    values, pullback = jax.vjp(rows, controls)
    (jac,) = jax.vmap(pullback)(jnp.eye(len(names), dtype=values.dtype))
    return values, jac


class _Stop(Exception):
    """Raised inside SLSQP's callbacks when the lane's own rules stop the design."""


# a surrogate Jacobian of the objective and one limit (every step stored) in sharp forward runs
# at the uniform start on the paper mesh, one core (benchmarks/design.py, section 1)
JACOBIAN_COST = 24.0


def run_sqp(lane: _Lane, problem: GradedProblem, stored: int, progress) -> None:
    """Drive `lane` (a `_Lane`, its iterate the start) with SLSQP until its rules stop it."""
    names = (lane.minimise, *lane.limits)
    low, high, row, budget = lane.low, lane.high, lane.row, lane.budget
    # each limit's constraint aims `aim` inside it
    targets = np.array([lane.limits[k] for k in names[1:]]) * (1.0 - lane.aim)
    offsets = np.zeros(len(targets))
    points: dict[tuple, tuple] = {}  # every point evaluated: (sharp values or None, values, jac)
    scale = 1.0  # the objective's surrogate value at the start

    def key(x):
        return tuple(np.asarray(x, float).round(14))

    def evaluate(x):
        nonlocal scale
        point = key(x)
        if point in points:
            return points[point][1:]
        if lane.done:
            raise _Stop
        c = np.clip(np.asarray(x, float), low, high)  # SLSQP may step a rounding outside
        lane.c = c
        controls = jnp.asarray(c)
        tick = time.perf_counter()
        raw, (codes, _) = _sharp(controls, problem)
        codes = np.asarray(codes)
        sharp_s = time.perf_counter() - tick
        failed = failed_codes(codes)
        start = not lane.history
        if failed and start:
            _refuse_failed(codes, problem, controls)
        if failed:  # a trial point whose sharp collision failed: never kept, never closest
            raw = {k: np.full(np.shape(v), np.inf) for k, v in raw.items()}
        lane.observe(len(lane.history), raw, sharp_s, progress)
        if failed:
            lane.history[-1]["ended"] = m.RESULTS(failed[0]).status
        if lane.done:
            raise _Stop
        tick = time.perf_counter()
        values, jac = _surrogate_jacobian(controls, problem, names, stored)
        values, jac = np.asarray(values), np.asarray(jac)
        lane.history[-1]["gradient_s"] = time.perf_counter() - tick
        lane.evaluations += JACOBIAN_COST * lane.samples
        if not np.all(np.isfinite(values)) or not np.all(np.isfinite(jac)):
            lane.history[-1]["ended"] = "surrogate not finite"
            raise _Stop
        sharp = None if failed else _reduce(raw, problem, lane.minimise, True)
        if start:
            scale = abs(float(values[0])) or 1.0
        points[point] = (sharp, values, jac)
        return values, jac

    def start_round(x):
        """Evaluate the round's start and set the limits' offsets there (sharp - surrogate)."""
        values, _ = evaluate(x)
        sharp = points[key(x)][0]
        if sharp is not None:
            offsets[:] = [float(sharp[k]) - values[i + 1] for i, k in enumerate(names[1:])]

    def objective(x):
        return float(evaluate(x)[0][0]) / scale

    def objective_grad(x):
        return evaluate(x)[1][0] / scale

    constraints = [{"type": "ineq", "fun": lambda x: budget - row @ x, "jac": lambda x: -row}]
    if budget is None:
        constraints = []
    for i in range(len(targets)):

        def g(x, i=i):
            values, _ = evaluate(x)
            return 1.0 - (values[i + 1] + offsets[i]) / targets[i]

        def g_jac(x, i=i):
            return -evaluate(x)[1][i + 1] / targets[i]

        constraints.append({"type": "ineq", "fun": g, "jac": g_jac})

    x = lane.c.copy()
    for round_ in range(ROUNDS):
        try:
            if round_ == 0:
                evaluate(x)  # the surrogate as it is: its bias left in (see the module doc)
            else:
                start_round(x)
            found = minimize(
                objective,
                x,
                jac=objective_grad,
                method="SLSQP",
                bounds=[(low, high)] * len(x),
                constraints=constraints,
                options={"maxiter": lane.steps, "ftol": lane.tolerance * 1e-2},
            )
        except _Stop:
            break
        # the point SLSQP ended on (its last iterate, not a line search's last trial)
        end = points.get(key(found.x))
        outside = end is None or end[0] is None or _violation(end[0], lane.limits) > 0.0
        if found.success and not outside:
            lane.converged = True  # SLSQP's own test, at a point that meets every limit
        if lane.done or not outside:
            break
        x = (lane.best or lane.closest)[0].copy()


def design(
    problem: GradedProblem,
    *,
    minimise: str = "deceleration_10ms",
    limits: Mapping[str, float] | None = None,
    max_beam_mass_ratio: float | None = None,
    thickness_bounds: tuple[float, float] | None = None,
    start=None,
    steps: int = 30,
    learning_rate: float = 0.04,
    penalty: float = 50.0,
    patience: int = 8,
    tolerance: float = 2e-3,
    aim: float = 0.005,
    checkpoints: int | None = None,
    progress: Callable[[int, dict], None] | None = None,
    method: str = "slsqp",
) -> GradedDesign:
    """Minimise `minimise` (a `QUANTITIES` name) subject to upper `limits` on others
    ({quantity: limit in its SI unit}, e.g. {"deflection": 0.16}), the beam mass ratio at most
    `max_beam_mass_ratio` and every thickness in `thickness_bounds` (h/h_r; None: the
    problem's bounds).

    Starts from the uniform beam of the problem's ``thickness_ratio`` (or `start`, control
    values), clipped into the bounds and the budget. `method`: ``"slsqp"`` (scipy's SLSQP on
    the surrogate, each point it evaluates checked on the sharp model; `run_sqp`) or
    ``"adam"`` (the augmented Lagrangian around projected Adam steps, as `design_front` runs
    it; `learning_rate` and `penalty` are its own). `steps`: at most this many points after
    the start, each a sharp run (values, limits) and one reverse-mode gradient of the
    surrogate (SLSQP: the Jacobian of the objective and the limited quantities); stops early
    when the best feasible objective has not improved by `tolerance` (relative) for
    `patience` points. `aim`: the search steers to this fraction inside each limit (the
    limits themselves are checked exactly). `checkpoints`: diffrax's
    RecursiveCheckpointAdjoint (None: one per step bound, nothing recomputed).
    """
    if method not in METHODS:
        raise ValueError(f"method = {method!r}; allowed: {', '.join(METHODS)}")
    t0 = time.perf_counter()
    limits, low, high, row = _checked(
        problem, minimise, limits, max_beam_mass_ratio, thickness_bounds
    )
    options = dict(
        steps=steps, learning_rate=learning_rate, penalty=penalty, patience=patience,
        tolerance=tolerance, aim=aim,
    )  # fmt: skip
    lane = _Lane(problem, start, minimise, limits, max_beam_mass_ratio, low, high, row, options)
    stored = stored_checkpoints(problem, checkpoints)
    if method == "slsqp":
        run_sqp(lane, problem, stored, progress)
        return lane.result(time.perf_counter() - t0)

    def sharp(controls):  # one design: the single program, given and giving a lane axis
        return jax.tree_util.tree_map(lambda x: x[None], _sharp(controls[0], problem))

    def gradient(controls, weights, *args):
        _, grad = _surrogate_grad(controls[0], {k: w[0] for k, w in weights.items()}, *args)
        return None, grad[None]

    drive(problem, [lane], minimise, stored, sharp, gradient,
          None if progress is None else lambda i, it, record: progress(it, record))  # fmt: skip
    return lane.result(time.perf_counter() - t0)
