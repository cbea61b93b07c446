"""A design problem: the collision around the design, how it is integrated, and evaluation.

`Problem` holds what stays fixed while a design changes: the base `CollisionParams` (the
designed fields are replaced), the mesh (static: one compiled program per mesh) and the
`Settings` with every number an array and a fixed step bound `max_steps`, so that evaluating,
differentiating and changing the smoothing never compiles a new program.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp

import msfd_jax as m
from msfd_jax._simulate import max_steps_for

from ._design import Box, Design

FAILED = (2, 3, 4)  # non-finite, energy balance broken, max steps (msfd_jax.RESULT_NAMES)


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
    """

    params: m.CollisionParams
    mesh: m.Mesh
    settings: m.Settings


def make_problem(
    params: m.CollisionParams = m.CollisionParams(),
    mesh: m.Mesh = m.Mesh(),
    settings: m.Settings = m.Settings(),
    box: Box | None = None,
) -> Problem:
    """A `Problem` whose step bound covers every design in `box` (its corners).

    The stable step depends on the design (a thicker beam is stiffer), so `max_steps` is the
    largest bound that `msfd_jax` would choose at any corner of the box, unless given.
    """
    kept = tuple(t for t in settings.shape_times if t <= float(settings.t_max))
    settings = dataclasses.replace(settings, shape_times=kept)
    if settings.max_steps is None:
        corners = box.corners() if box is not None else []
        scenes = [m.ring_on_beam(d.apply(params), mesh) for d in corners]
        scenes = scenes or [m.ring_on_beam(params, mesh)]
        steps = max(max_steps_for(scene, settings) for scene in scenes)
        settings = dataclasses.replace(settings, max_steps=steps)
    return Problem(params.as_arrays(), mesh, arrays(settings))


class Evaluation(eqx.Module):
    """The objective, the partition (fractions of K0) and the result code at one design."""

    value: Any
    fractions: dict
    result: Any


def _partition(design: Design, problem: Problem, yield_smoothing, contact_smoothing, adjoint):
    """The partition (fractions of K0) and the result code of the collision at `design`."""
    params = design.apply(problem.params)
    scene = m.ring_on_beam(
        params,
        problem.mesh,
        contact_smoothing=contact_smoothing,
        yield_smoothing=yield_smoothing,
    )
    solution = m.simulate(scene, problem.settings, adjoint=adjoint)
    return m.fractions(solution, scene), solution.result


@eqx.filter_jit
def _evaluate(design, problem, yield_smoothing, contact_smoothing):
    adjoint = diffrax.RecursiveCheckpointAdjoint()  # the primal program is the same either way
    return _partition(design, problem, yield_smoothing, contact_smoothing, adjoint)


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
    fractions, result = _evaluate(arrays(design), problem, *smoothing)
    return Evaluation(arrays(objective)(fractions), fractions, result)


def check(evaluation: Evaluation, design: Design) -> None:
    """Raise `msfd_jax.SimulationError` if the run at `design` failed (never tune on garbage)."""
    code = int(evaluation.result)
    if code in FAILED:
        raise m.SimulationError(
            f"the collision at design {design.as_floats()} ended with '{m.RESULT_NAMES[code]}'; "
            "lower Settings.safety, raise Settings.max_steps or narrow the bounds"
        )
