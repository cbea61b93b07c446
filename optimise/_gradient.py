"""Derivatives of an objective with respect to the design, forward or reverse mode.

The objective J is a function of the partition f (fractions of K0), so
dJ/dx = sum_k dJ/df_k df_k/dx. The simulation is differentiated once per call:

- forward mode: `jax.jvp` through ``simulate(..., adjoint=diffrax.ForwardMode())`` gives
  df/dx along one design variable per solve: the cheap choice for one or a few variables;
- reverse mode: `jax.grad` of sum_k c_k f_k (c = dJ/df) through diffrax's
  ``RecursiveCheckpointAdjoint``: one backward sweep for any number of variables, recomputing
  the forward solve between checkpoints (one primal solve first gives c).

The compiled simulation programs never see the objective, so every objective shares them.
Both modes differentiate the same discrete map: the time step is held fixed (``msfd_jax``
stops its gradient), so a finite difference agrees with them only at a fixed ``Settings.dt``
and on a smoothed model (``yield_smoothing`` and ``contact_smoothing`` > 0); the sharp model's
derivative is exact for its discrete map but jagged in the design (below).

**The sharp model has no design gradient.** With ``yield_smoothing == contact_smoothing == 0``
a run of a few thousand steps switches contact and yield hundreds of times; the exact
derivative of that discrete map is dominated by the switches (measured on ``Mesh(8, 10, 3)``,
h_b/h_r = 2.5: d(ring bending)/d(h_b/h_r) = +203 at ``dt = 2e-4``, -1.9e7 at the derived
step, while central differences of the sharp model over h = 0.02-0.1 give 0.10-0.36, and the
smoothed model's derivative, 0.218, matches its own central differences to 3e-4). So
`gradient` differentiates the smoothed model by default (`DEFAULT_SMOOTHING`: yield 0.05,
contact 0.01) and warns (`SharpGradientWarning`) when both smoothings are given as zero;
``warnings.simplefilter("error", optimise.SharpGradientWarning)`` turns that into an error.
`tune` refuses a stage without smoothing. docs/tuning.md shows the bias and the check.
"""

from __future__ import annotations

import warnings
from typing import Any, Literal

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp

from ._design import Design
from ._problem import (
    Evaluation,
    Problem,
    _evaluate,
    _partition,
    arrays,
    evaluate,
    objective_value_and_grad,
)

MODES = ("forward", "reverse")

# the first stage of `tune`'s annealing (benchmarks/smoothing_bias.py: beam-share bias up to
# ~0.1 K0): widths at which the partition is smooth in the design on the meshes tested
DEFAULT_SMOOTHING = {"yield_smoothing": 0.05, "contact_smoothing": 0.01}


class SharpGradientWarning(UserWarning):
    """A derivative of the sharp model (no yield and no contact smoothing) was asked for."""


def is_sharp(yield_smoothing, contact_smoothing) -> bool:
    """True when both smoothing widths are known (concrete) to be zero; traced: False."""
    values = (yield_smoothing, contact_smoothing)
    if any(isinstance(v, jax.core.Tracer) for v in values):
        return False
    return all(not bool(jnp.any(jnp.asarray(v) != 0)) for v in values)


SHARP_REMEDY = (
    "give yield_smoothing=0.05, contact_smoothing=0.01 (optimise.DEFAULT_SMOOTHING), the "
    "widths at which the partition is smooth in the design; judge the design on the sharp "
    "model with optimise.evaluate (what optimise.tune does)"
)


def warn_if_sharp(yield_smoothing, contact_smoothing, stacklevel: int = 3) -> None:
    """Warn (`SharpGradientWarning`) when a derivative of the sharp model is asked for."""
    if is_sharp(yield_smoothing, contact_smoothing):
        warnings.warn(
            "a gradient of the sharp model (yield_smoothing = contact_smoothing = 0) is the "
            "exact derivative of a discrete map that switches contact and yield hundreds of "
            "times per collision, not a design gradient (it can be off by orders of magnitude "
            f"and in sign against central differences); {SHARP_REMEDY}",
            SharpGradientWarning,
            stacklevel=stacklevel,
        )


@eqx.filter_jit
def _forward(design, tangent, problem, yield_smoothing, contact_smoothing):
    def partition(d):
        adjoint = diffrax.ForwardMode()
        return _partition(d, problem, yield_smoothing, contact_smoothing, adjoint)

    fractions, derivative, (result, samples) = jax.jvp(
        partition, (design,), (tangent,), has_aux=True
    )
    return fractions, derivative, result, samples


@eqx.filter_jit
def _reverse(design, cotangent, problem, yield_smoothing, contact_smoothing, checkpoints=None):
    def weighted(d):
        adjoint = diffrax.RecursiveCheckpointAdjoint(checkpoints)
        fractions, aux = _partition(d, problem, yield_smoothing, contact_smoothing, adjoint)
        return sum(cotangent[k] * fractions[k] for k in cotangent), (fractions, aux)

    (_, (fractions, (result, samples))), grad = jax.value_and_grad(weighted, has_aux=True)(design)
    return fractions, grad, result, samples


def _basis(design: Design) -> list[Design]:
    leaves, treedef = jax.tree_util.tree_flatten(design)
    unit = [[jnp.ones_like(x) if j == i else jnp.zeros_like(x) for j, x in enumerate(leaves)]
            for i in range(len(leaves))]  # fmt: skip
    return [jax.tree_util.tree_unflatten(treedef, basis) for basis in unit]


def gradient(
    design: Design,
    problem: Problem,
    objective,
    *,
    mode: Literal["forward", "reverse"] = "forward",
    yield_smoothing=DEFAULT_SMOOTHING["yield_smoothing"],
    contact_smoothing=DEFAULT_SMOOTHING["contact_smoothing"],
    partition_at: dict[str, Any] | None = None,
    checkpoints: int | None = None,
) -> tuple[Evaluation, Design]:
    """The objective at `design` and its gradient with respect to every design variable.

    **Arguments:**
    - `design`: the point (`Design`).  `problem`: the collision around it (`make_problem`).
    - `objective`: a function of the partition (`Objective`, or any term).
    - `mode`: ``"forward"`` (one jvp per variable) or ``"reverse"`` (one vjp).
    - `yield_smoothing` (fraction of the yield value), `contact_smoothing` (units of R): the
      model that is differentiated (default `DEFAULT_SMOOTHING`: 0.05 and 0.01). Both zero
      (the sharp model) warns with `SharpGradientWarning`: its derivative is not a design
      gradient (module docstring).
    - `partition_at`: where to evaluate J and dJ/df (default: the differentiated model's
      partition). `tune` passes the sharp model's partition here, so that the value is the
      sharp model's and only df/dx comes from the smoothed one.
    - `checkpoints`: reverse mode only, `diffrax.RecursiveCheckpointAdjoint`'s number of saved
      states (None: diffrax's default, log2(max_steps); more trades memory for recomputation).

    With conditions in `problem`, J is of the expected partition and its gradient that of
    J(E[f]) (the samples are vmapped inside each differentiated solve).

    **Returns:** (`Evaluation` of the differentiated model, with ``value`` J at
    `partition_at` when given; the gradient dJ/dx as a `Design`).
    """
    if mode not in MODES:
        raise ValueError(f"mode must be one of {MODES}, got {mode!r}")
    warn_if_sharp(yield_smoothing, contact_smoothing)
    design, objective = arrays(design), arrays(objective)
    smoothing = arrays((yield_smoothing, contact_smoothing))
    if mode == "reverse":
        if partition_at is None:  # dJ/df at the smoothed partition: one primal solve first
            partition_at, _, _ = _evaluate(design, problem, *smoothing)
        value, weights = objective_value_and_grad(objective, partition_at)
        fractions, grad, result, samples = _reverse(
            design, weights, problem, *smoothing, checkpoints
        )
        return Evaluation(value, fractions, result, samples), grad
    columns = []
    for tangent in _basis(design):  # one tangent solve per variable, one compiled program
        fractions, derivative, result, samples = _forward(design, tangent, problem, *smoothing)
        columns.append(derivative)
    value, weights = objective_value_and_grad(
        objective, fractions if partition_at is None else partition_at
    )
    slopes = [sum(weights[k] * column[k] for k in weights) for column in columns]
    leaves, treedef = jax.tree_util.tree_flatten(design)
    grad = jax.tree_util.tree_unflatten(treedef, slopes)
    return Evaluation(value, fractions, result, samples), grad


def finite_difference(
    design: Design, problem: Problem, objective, *, step=1e-3, **smoothing
) -> Design:
    """Central finite differences (J(x + h) - J(x - h)) / 2h of the objective, per variable.

    `smoothing`: `evaluate`'s ``yield_smoothing`` and ``contact_smoothing`` (default: the sharp
    model, whose slope over a small `step` is jagged; check `gradient` against the same
    smoothing it differentiates, and hold ``Settings.dt`` fixed).
    """
    leaves, treedef = jax.tree_util.tree_flatten(arrays(design))
    out = []
    for i, x in enumerate(leaves):
        values = []
        for sign in (1.0, -1.0):
            moved = [x + sign * step if j == i else y for j, y in enumerate(leaves)]
            point = jax.tree_util.tree_unflatten(treedef, moved)
            values.append(evaluate(point, problem, objective, **smoothing).value)
        out.append((values[0] - values[1]) / (2.0 * step))
    return jax.tree_util.tree_unflatten(treedef, out)
