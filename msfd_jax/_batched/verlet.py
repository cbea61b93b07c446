"""`BatchedVerlet`: the batched core's step as a diffrax solver.

Its own module because defining a diffrax solver imports diffrax (with optimistix and lineax,
~0.5 s of CPU): `solver.solve` imports it when a solve is traced, so a process that only runs
stored programs (`_runtime.export`) never pays it.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import ClassVar

import diffrax
import equinox as eqx

from .engine import advance


class BatchedVerlet(diffrax.AbstractSolver):
    """Velocity Verlet with return mapping (Sect. 3) for a batch, each collision on its clock.

    ``args`` is ``(flat, clock, settings)``. History (plastic parts, dissipation, the
    stopping rule) is a discrete update of the step; the term is only the rate form
    dx/dt = v, dv/dt = a, which diffrax may query for dense output.
    """

    term_structure: ClassVar = diffrax.AbstractTerm
    interpolation_cls: ClassVar[Callable[..., diffrax.LocalLinearInterpolation]] = (
        diffrax.LocalLinearInterpolation
    )
    substeps: int = eqx.field(static=True, default=8)

    def order(self, terms):
        return 2

    def init(self, terms, t0, t1, y0, args):
        return None

    def step(self, terms, t0, t1, y0, args, solver_state, made_jump):
        del solver_state, made_jump, terms, t0, t1
        flat, clock, settings = args
        y1 = advance(flat, clock, y0, self.substeps, settings)
        return y1, None, dict(y0=y0, y1=y1), None, diffrax.RESULTS.successful

    def func(self, terms, t0, y0, args):
        return terms.vf(t0, y0, args)
