"""The batched core as a diffrax solver, and one batched solve.

`BatchedVerlet` (`verlet`) is the project's diffrax solver: each diffrax step advances every
collision of the batch by ``substeps`` Verlet steps on its own time grid and applies its
stopping rule (`engine.advance`). The same solver serves a single run (a batch of one, whose
diffrax time is then the physical time, so histories are saved with ``SaveAt(ts=...)`` as
before), a fixed batch, the sweep's segments between refills, and gradients (diffrax's
adjoints).

diffrax is imported only when a solve is traced (`solve`), not with this module: a process
that runs stored programs (`_runtime.export`, the CLI's warm start) never needs it, and importing it
(with optimistix and lineax) costs ~0.5 s of CPU (benchmarks/results/startup.md).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import equinox as eqx
import jax
import jax.numpy as jnp

from .._model.state import State
from .._runtime.export import checks_as_nan
from .engine import BatchState, Clock, kinetic, pair_forces
from .flat import FlatScene

if TYPE_CHECKING:
    import diffrax


def _rate_form(t, y: BatchState, args):
    zero = jax.tree_util.tree_map(jnp.zeros_like, y)
    return eqx.tree_at(lambda s: (s.x, s.v), zero, (y.v, y.a))


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
    import diffrax  # at trace time only (see the module's docstring)

    from .verlet import BatchedVerlet

    if t1 is None:
        t1 = jnp.max(clock.t_max)
    if dt0 is None:
        dt0 = jnp.min(clock.dt0)
    with checks_as_nan():  # diffrax's input checks, met by construction: no host callbacks
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
    if flat.tracked is not None:  # the SI quantities' histories (`_model.si`): O's and G's motion
        o, _, g = flat.tracked
        out["midspan_deflection"] = one.x[o, 1] - flat.x0[o, 1, 0]
        out["block_velocity"] = one.v[g, 1]
    return out
