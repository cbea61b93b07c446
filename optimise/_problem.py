"""A design problem: the collision around the design, how it is integrated, and evaluation.

`Problem` holds what stays fixed while a design changes: the base `CollisionParams` (the
designed fields are replaced), the mesh (static: one compiled program per mesh) and the
`Settings` with every number an array and a fixed step bound `max_steps`, so that evaluating,
differentiating and changing the smoothing never compiles a new program.

With `Conditions` (samples of the impact velocity and mass), the problem's partition is the
*expected* one over the samples, computed by `jax.vmap` over the sampled fields in one compiled
program; the per-sample partitions come along (`Evaluation.samples`).
"""

from __future__ import annotations

import dataclasses
from typing import Any

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp

import msfd_jax as m
from msfd_jax._batched.simulate import max_steps_for
from msfd_jax._model.cap import time_cap

from ._conditions import Conditions, expectation
from ._design import Box, Design

FAILED = tuple(r for r in m.RESULTS if r.failed)  # non-finite, energy balance, max steps


def arrays(tree):
    """Every Python number in a pytree as a float64 array (numbers would be static under jit)."""

    def convert(leaf):
        if isinstance(leaf, bool):
            return leaf
        return jnp.asarray(leaf, dtype=jnp.float64) if isinstance(leaf, float | int) else leaf

    return jax.tree_util.tree_map(convert, tree)


class Problem(eqx.Module):
    """What is fixed while the design changes (build it with `make_problem`).

    **Arguments:**
    - `params`: the collision (`msfd_jax.CollisionParams`, arrays); designed fields are replaced.
    - `mesh`: node counts (static).
    - `settings`: integration settings, numbers as arrays, `max_steps` set.
    - `conditions`: samples of the impact conditions (`Conditions`), or None for one collision.
    """

    params: m.CollisionParams
    mesh: m.Mesh
    settings: m.Settings
    conditions: Conditions | None = None


def make_problem(
    params: m.CollisionParams = m.CollisionParams(),
    mesh: m.Mesh = m.Mesh(),
    settings: m.Settings = m.Settings(),
    box: Box | None = None,
    conditions: Conditions | None = None,
    lean: bool = True,
) -> Problem:
    """A `Problem` whose step bound covers every design in `box` (its corners).

    `lean`: save no histories or shapes (``history_points=2``, ``shape_times=()``): tuning
    reads only the final partition, and fewer saved outputs make the primal, and above all the
    tangent and adjoint programs, cheaper (benchmarks/optimise_cost.py); the partition is the
    same (saving interpolates, it never moves a step).

    The stable step depends on the design (a thicker beam is stiffer) and on the sample (the
    block's mass), so `max_steps` is the largest bound that `msfd_jax` would choose at any
    corner of the box and any sample of `conditions`, unless given.
    """
    corners = box.corners() if box is not None else []
    designs = [d.apply(params) for d in corners] or [params]
    if conditions is not None:
        designs = [conditions.apply(p, i) for p in designs for i in range(len(conditions))]
    if settings.t_max is None:  # one cap for the problem: the largest derived cap of its box
        cap = max(float(time_cap(m.ring_on_beam(p, mesh))) for p in designs)
        settings = dataclasses.replace(settings, t_max=cap)
    kept = tuple(t for t in settings.shape_times if t <= float(settings.t_max))
    settings = dataclasses.replace(settings, shape_times=kept)
    if lean:
        settings = dataclasses.replace(settings, history_points=2, shape_times=())
    if settings.max_steps is None:
        steps = max(max_steps_for(m.ring_on_beam(p, mesh), settings) for p in designs)
        settings = dataclasses.replace(settings, max_steps=steps)
    elif conditions is not None:
        for i in range(len(conditions)):
            conditions.apply(params, i)  # validated
    return Problem(params.as_arrays(), mesh, arrays(settings), conditions)


class Evaluation(eqx.Module):
    """The objective, the partition (fractions of K0) and the result code at one design.

    With conditions, `fractions` is the expected partition, `result` the result code of each
    sample and `samples` each sample's partition (arrays over the samples); else None.
    """

    value: Any
    fractions: dict
    result: Any
    samples: dict | None = None


def _single(params, problem: Problem, yield_smoothing, contact_smoothing, adjoint):
    scene = m.ring_on_beam(
        params,
        problem.mesh,
        contact_smoothing=contact_smoothing,
        yield_smoothing=yield_smoothing,
    )
    solution = m.simulate(scene, problem.settings, adjoint=adjoint)
    return m.fractions(solution, scene), solution.result


def _partition(design: Design, problem: Problem, yield_smoothing, contact_smoothing, adjoint):
    """(partition, (result code, per-sample partitions)) of the collision(s) at `design`.

    One collision: the partition, its result code and None. With conditions: `jax.vmap` over
    the sampled fields, the expected partition, the result code per sample and the samples.
    """
    params = design.apply(problem.params)
    conditions = problem.conditions
    if conditions is None:
        fractions, result = _single(params, problem, yield_smoothing, contact_smoothing, adjoint)
        return fractions, (result, None)

    def sample(fields):
        at = dataclasses.replace(params, **fields)
        return _single(at, problem, yield_smoothing, contact_smoothing, adjoint)

    samples, results = jax.vmap(sample)(conditions.fields())
    return expectation(samples, conditions.weights), (results, samples)


@eqx.filter_jit
def _evaluate(design, problem, yield_smoothing, contact_smoothing):
    adjoint = diffrax.RecursiveCheckpointAdjoint()  # the primal program is the same either way
    fractions, (result, samples) = _partition(
        design, problem, yield_smoothing, contact_smoothing, adjoint
    )
    return fractions, result, samples


@eqx.filter_jit
def objective_value_and_grad(objective, fractions):
    """(J(f), dJ/df): the objective and its derivative with respect to each fraction.

    Compiled per objective structure in well under a second; the simulation programs never
    see the objective, so every objective shares them.
    """
    return jax.value_and_grad(lambda f: objective(f))(fractions)


def evaluate(
    design: Design,
    problem: Problem,
    objective,
    *,
    yield_smoothing=0.0,
    contact_smoothing=0.0,
) -> Evaluation:
    """The objective and partition at `design` (the sharp model unless smoothing is given)."""
    smoothing = arrays((yield_smoothing, contact_smoothing))
    fractions, result, samples = _evaluate(arrays(design), problem, *smoothing)
    return Evaluation(arrays(objective)(fractions), fractions, result, samples)


def check(evaluation: Evaluation, design: Design, conditions: Conditions | None = None) -> None:
    """Raise `msfd_jax.SimulationError` if a run at `design` failed (never tune on garbage)."""
    codes = [int(c) for c in jnp.atleast_1d(evaluation.result)]
    for i, code in enumerate(codes):
        if code in FAILED:
            where = "" if conditions is None else f" under impact conditions {conditions.rows()[i]}"
            raise m.SimulationError(
                f"the collision at design {design.as_floats()}{where} ended with "
                f"'{m.RESULTS(code).status}'; lower Settings.safety, raise Settings.max_steps "
                "or narrow the bounds"
            )
