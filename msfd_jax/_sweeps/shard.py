"""The chunked (vmapped) and sharded path of a sweep (`sweep(..., shard=True)`): each chunk
of collisions is one jit-compiled ``vmap`` of `simulate`, split across host devices with
``jax.shard_map`` when there are several. Moved out of `sweep` (which runs the queue
engine by default) to keep each module under the house's 500 lines.
"""

from __future__ import annotations

import dataclasses

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .._batched.simulate import Settings, simulate
from .._collision.run import fractions
from .._model.cap import expected_duration, time_cap
from .._model.params import CollisionParams, Mesh
from .._model.scene import ring_on_beam
from .._model.state import critical_step
from .._runtime import export as _export


def _run_chunk(function, columns, rows: range, chunk_size: int, *args):
    """Call `function` on one chunk padded (with its first row) to `chunk_size`; unpad.

    `function` gets the chunk's CollisionParams, then its stability limits when `columns`
    holds them (``"_dt_critical"``), then `args`.
    """
    index = np.asarray(rows)
    padded = np.concatenate([index, np.full(chunk_size - len(index), index[0])])
    # every field `columns` has (a sweep without profiles has no `thickness_profile`)
    names = [f.name for f in dataclasses.fields(CollisionParams) if f.name in columns]
    params = CollisionParams(**{k: jnp.asarray(columns[k][padded]) for k in names})
    if "_dt_critical" in columns:
        args = (jnp.asarray(columns["_dt_critical"][padded]), *args)
    out = jax.device_get(function(params, *args))
    return jax.tree_util.tree_map(lambda a: np.asarray(a)[: len(index)], out)


def _critical_chunk(params: CollisionParams, mesh: Mesh, smoothing):
    """Each collision's (stability limit, derived cap, expected duration); through the
    store of serialized programs when it is on (`_runtime.export`).

    Called from one thread only: two threads running this program at once (its eigen-solve
    is a LAPACK call) deadlocked, once, on jax 0.10.2's CPU client, both waiting for their
    outputs with no XLA thread at work (a trial of spreading the chunks over the sweep's
    threads).
    """
    return _export.call(_critical_program, params, mesh, smoothing, name="critical_chunk")


@eqx.filter_jit
def _critical_program(params: CollisionParams, mesh: Mesh, smoothing):
    def one(p):
        scene = ring_on_beam(p, mesh, contact_smoothing=smoothing[0])
        return critical_step(scene), time_cap(scene), expected_duration(scene)

    return jax.vmap(one)(params)


def _solve_one(p: CollisionParams, dt_crit, mesh: Mesh, smoothing, settings: Settings):
    """One collision inside the vmap: its outputs and a solution stripped of histories."""
    scene = ring_on_beam(p, mesh, contact_smoothing=smoothing[0], yield_smoothing=smoothing[1])
    solution = simulate(scene, settings, dt_critical=dt_crit)
    outputs = fractions(solution, scene)
    outputs["energy_balance_error"] = solution.energy_balance_error
    # what `diagnose` reads; histories and shapes are dropped so a chunk's output stays small
    slim = dataclasses.replace(solution, history={}, shapes=(), ts=solution.ts[:1])
    return outputs, slim


@eqx.filter_jit
def _solve_chunk(params: CollisionParams, dt_crit, mesh: Mesh, smoothing, settings: Settings):
    return jax.vmap(lambda p, d: _solve_one(p, d, mesh, smoothing, settings))(params, dt_crit)


_SHARDED: dict = {}


def _sharded_solver(devices):
    """`_solve_chunk` with the chunk split across `devices` (one stopping loop per device)."""
    key = tuple(devices)
    if key not in _SHARDED:
        from jax.sharding import Mesh as DeviceMesh
        from jax.sharding import PartitionSpec

        device_mesh = DeviceMesh(np.asarray(devices), ("batch",))
        batch = PartitionSpec("batch")

        @eqx.filter_jit
        def solve(params, dt_crit, mesh, smoothing, settings):
            def local(p, d, smoothing, settings):
                return jax.vmap(lambda q, e: _solve_one(q, e, mesh, smoothing, settings))(p, d)

            # numbers replicated on every device; the batch split; no cross-device loop
            dynamic, static = eqx.partition(settings, eqx.is_array)
            sharded = jax.shard_map(
                lambda p, d, sm, dyn: local(p, d, sm, eqx.combine(dyn, static)),
                mesh=device_mesh,
                in_specs=(batch, batch, PartitionSpec(), PartitionSpec()),
                out_specs=batch,
                check_vma=False,
            )
            return sharded(params, dt_crit, smoothing, dynamic)

        _SHARDED[key] = solve
    return _SHARDED[key]
