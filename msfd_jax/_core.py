"""The batched core as a diffrax solver, and one batched solve (issue 11).

`BatchedVerlet` is the project's diffrax solver: each diffrax step advances every collision of
the batch by ``substeps`` Verlet steps on its own time grid and applies its stopping rule
(`_engine.advance`). The same solver serves a single run (a batch of one, whose diffrax time
is then the physical time, so histories are saved with ``SaveAt(ts=...)`` as before), a fixed
batch, the sweep's segments between refills, and gradients (diffrax's adjoints).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import ClassVar

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp

from ._dynamics import State
from ._engine import BatchState, Clock, advance, kinetic, pair_forces
from ._flat import FlatScene


def _rate_form(t, y: BatchState, args):
    zero = jax.tree_util.tree_map(jnp.zeros_like, y)
    return eqx.tree_at(lambda s: (s.x, s.v), zero, (y.v, y.a))


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


def _all_done(t, y: BatchState, args, **kwargs):
    return jnp.all(y.done > 0)


def solve(
    flat: FlatScene,
    clock: Clock,
    y0: BatchState,
    settings,
    *,
    max_steps: int,
    t1=None,
    dt0=None,
    saveat: diffrax.SaveAt | None = None,
    adjoint: diffrax.AbstractAdjoint | None = None,
):
    """diffeqsolve of the batch until every collision has stopped or `max_steps` steps.

    The diffrax clock runs from 0 to `t1` with step `dt0`; by default it is the grid of the
    batch's smallest step (for a batch of one: its physical time). Returns diffrax's solution.
    """
    if t1 is None:
        t1 = jnp.max(clock.t_max)
    if dt0 is None:
        dt0 = jnp.min(clock.dt0)
    return diffrax.diffeqsolve(
        diffrax.ODETerm(_rate_form),
        BatchedVerlet(settings.substeps),
        t0=0.0,
        t1=t1,
        dt0=dt0,
        y0=y0,
        args=(flat, clock, settings),
        saveat=saveat or diffrax.SaveAt(t1=True),
        stepsize_controller=diffrax.ConstantStepSize(),
        event=diffrax.Event(_all_done),
        max_steps=max_steps,
        adjoint=adjoint or diffrax.RecursiveCheckpointAdjoint(),
        throw=False,
    )


def chain_state(flat: FlatScene, s: BatchState, b: int = 0) -> State:
    """Collision `b` of a batch state as the per-chain `State` of `Solution.final`."""
    one = jax.tree_util.tree_map(lambda a: a[..., b], s)

    def per_chain(a, start, size):
        return tuple(a[getattr(c, start) : getattr(c, start) + size(c)] for c in flat.chains)

    def nodes(a):
        return per_chain(a, "node", lambda c: c.n_nodes)

    return State(
        nodes(one.x),
        nodes(one.v),
        nodes(one.a),
        per_chain(one.plastic_rotation, "joint", lambda c: c.n_joints),
        per_chain(one.plastic_strain, "bar", lambda c: c.n_nodes - 1),
        one.permanent_set,
        _pick(flat, s, b),
        one.bending,
        one.axial,
        one.contact,
        one.elastic,
        one.reaction,
        one.drive_work,
        one.last_dissipation,
        one.dissipation_mark,
        one.last_contact,
    )


def _pick(flat: FlatScene, s: BatchState, b: int):
    return tuple(f[..., b] for f in pair_forces(flat, s.x, s.permanent_set))


def history_of(flat: FlatScene, s: BatchState) -> dict:
    """The saved history of a batch of one (as `Solution.history` holds it)."""
    one = jax.tree_util.tree_map(lambda a: a[..., 0], s)
    forces = tuple(f[..., 0] for f in pair_forces(flat, s.x, s.permanent_set))
    out = dict(
        kinetic=kinetic(flat, s.v)[:, 0],
        elastic=one.elastic,
        bending=one.bending,
        axial=one.axial,
        contact=one.contact,
        contact_force=jnp.stack([jnp.sum(f) for f in forces]) if flat.pairs else jnp.zeros(1),
        contact_pairs=tuple(f > 0 for f in forces),
        reaction=one.reaction,
        drive_work=one.drive_work,
    )
    if not flat.pairs:
        del out["contact_pairs"]
    return out
