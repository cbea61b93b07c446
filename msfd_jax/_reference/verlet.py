"""The per-chain MS-FD step as a diffrax solver (after diffrax's ``SemiImplicitEuler``).

`VelocityVerlet` steps the per-chain reference (`dynamics.verlet_step`); the accuracy studies
compare it with the batched core's `_batched.verlet.BatchedVerlet`.

History (plastic parts, permanent sets, dissipation) is a discrete update, so it belongs to the
solver step, not to a vector field: the term below is only the rate form dx/dt = v,
dv/dt = a (with the plastic parts frozen), which diffrax may query but the step does not use.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import ClassVar

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp

from .dynamics import State, verlet_step


def rate_form(t, y: State, args):
    """dx/dt = v, dv/dt = a; everything else frozen (the elastic predictor of the state)."""
    zero = jax.tree_util.tree_map(jnp.zeros_like, y)
    return eqx.tree_at(lambda s: (s.x, s.v), zero, (y.v, y.a))


class VelocityVerlet(diffrax.AbstractSolver):
    """Explicit central-difference (velocity-Verlet) step with return mapping (Sect. 3).

    Second order and symplectic while the response is elastic; stable for dt < 2/omega_max.
    ``args`` must be ``(scene, settle_tolerance)``. Each diffrax step of length H makes
    ``substeps`` Verlet steps of H/substeps: diffrax's per-step bookkeeping (saving, events)
    is then paid once per ``substeps`` steps (benchmarks/results/profile.md at ee23c14^, git show).
    """

    term_structure: ClassVar = diffrax.AbstractTerm
    interpolation_cls: ClassVar[Callable[..., diffrax.LocalLinearInterpolation]] = (
        diffrax.LocalLinearInterpolation
    )

    substeps: int = eqx.field(static=True, default=1)

    def order(self, terms):
        return 2

    def init(self, terms, t0, t1, y0, args):
        return None

    def step(self, terms, t0, t1, y0, args, solver_state, made_jump):
        del solver_state, made_jump, terms
        scene, settle_tolerance = args
        h = (t1 - t0) / self.substeps

        def substep(i, y):
            return verlet_step(scene, y, t0 + (i + 1) * h, h, settle_tolerance)

        if self.substeps == 1:
            y1 = substep(0, y0)
        else:
            y1 = jax.lax.fori_loop(0, self.substeps, substep, y0)
        return y1, None, dict(y0=y0, y1=y1), None, diffrax.RESULTS.successful

    def func(self, terms, t0, y0, args):
        return terms.vf(t0, y0, args)
