"""A Pareto front of graded designs in one batched run: `design` for several values of one
limit, in lockstep, each iteration one vmapped sharp run and one vmapped gradient for every
design of the front.

Each design of the front follows `design`'s rules (`_graded._Lane`: the same projected Adam
steps, multipliers, stopping and result); only the programs differ (batched over the designs,
so the results equal `design`'s to rounding, not bit for bit). A design that stops (it
converged or ran out of steps) keeps its place in the batch, unchanged, until the last one
stops: the batch's shape, hence its program, stays the same throughout.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence

import equinox as eqx
import jax
import numpy as np

from ._graded import (
    LIMITS,
    GradedDesign,
    GradedProblem,
    _checked,
    _Lane,
    drive,
    quantities,
    stored_checkpoints,
    surrogate_value_and_grad,
)

VARIED = (*LIMITS, "beam_mass")  # what a front may vary: a limit, or the mass budget


@eqx.filter_jit
def _sharp_lanes(controls, problem):
    """The sharp quantities of designs `controls` (L, K), one vmapped program."""
    return jax.vmap(lambda c: quantities(c, problem, sharp=True))(controls)


@eqx.filter_jit
def _surrogate_grad_lanes(controls, weights, problem, objective, checkpoints):
    """`_graded._surrogate_grad` of L designs, each with its own weights ({q: (L,)})."""
    return jax.vmap(lambda c, w: surrogate_value_and_grad(c, w, problem, objective, checkpoints))(
        controls, weights
    )


def design_front(
    problem: GradedProblem,
    vary: str,
    values: Sequence[float],
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
    progress: Callable[[int, int, dict], None] | None = None,
) -> list[GradedDesign]:
    """`optimise.design` for each of `values` of one limit, all in one batched run.

    `vary`: ``"deflection"``, ``"deceleration_10ms"`` or ``"contact_force"`` (its limit takes
    each of `values`, in its SI unit; leave it out of `limits`), or ``"beam_mass"`` (the mass
    budget `max_beam_mass_ratio` takes each of `values`). The other arguments are `design`'s,
    shared by every design of the front. Each iteration runs every design's sharp run in one
    vmapped program and every design's gradient in another, so the front compiles two
    programs whatever its length; a stopped design is carried along unchanged. `progress(i,
    it, record)`: design i's iteration it (`design`'s record). Returns one `GradedDesign` per
    value, in the order given; their `wall_time_s` is the whole front's, and their history's
    ``sharp_s`` and ``gradient_s`` are the batch's calls.
    """
    t0 = time.perf_counter()
    if vary not in VARIED:
        raise ValueError(f"vary = {vary!r}: a front varies one of {', '.join(VARIED)}")
    values = [float(v) for v in np.atleast_1d(np.asarray(values, dtype=float))]
    if not values:
        raise ValueError("values is empty: give the limits (or budgets) of the front")
    if vary in (limits or {}):
        raise ValueError(f"{vary} is varied by the front; leave it out of limits")
    options = dict(
        steps=steps, learning_rate=learning_rate, penalty=penalty, patience=patience,
        tolerance=tolerance, aim=aim,
    )  # fmt: skip
    lanes = []
    for value in values:
        lane_limits, budget = dict(limits or {}), max_beam_mass_ratio
        if vary == "beam_mass":
            budget = value
        else:
            lane_limits[vary] = value
        checked, low, high, row = _checked(problem, minimise, lane_limits, budget, thickness_bounds)
        lanes.append(_Lane(problem, start, minimise, checked, budget, low, high, row, options))
    stored = stored_checkpoints(problem, checkpoints)

    def sharp(controls):  # positional, as benchmarks/design.py compiles it beforehand
        return _sharp_lanes(controls, problem)

    drive(problem, lanes, minimise, stored, sharp, _surrogate_grad_lanes, progress)
    wall = time.perf_counter() - t0
    return [lane.result(wall) for lane in lanes]
