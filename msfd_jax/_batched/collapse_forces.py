"""The batched core's forces of the collapse contacts (`_model.collapse`), batch last:
ring-ring pairs, planes (the block's face, the symmetry plane) and the ring bars' crush stops.

Kept apart from `engine.batch_response`'s loop (which handles the paper's contact sets) so that a
scene without collapse contacts runs exactly the code it ran before; `batch_response` and
`pair_forces` hand the two new layouts to `collapse_response` / `collapse_pair_force`.
"""

from __future__ import annotations

import jax.numpy as jnp

from .._model.collapse import pair_mask
from .._model.laws import capped_contact_spring, contact_energy
from .._model.safe import safe_norm
from .flat import BarStopLayout, FacePlaneLayout, FlatScene, SelfPairLayout


def _approach(flat: FlatScene, p, x, gap):
    """(approach, pair geometry) of a collapse set at x: (n, n, B) or (n_a, B)."""
    if isinstance(p, SelfPairLayout):
        xs = x[p.a : p.a + p.n]
        d = xs[:, None] - xs[None]  # (n, n, 2, B)
        dist = safe_norm(d, axis=2)
        mask = pair_mask(p.n, p.separation)[:, :, None]
        # pairs outside the mask get approach -gap: never closed (and no NaN gradient)
        return jnp.where(mask, gap[None, None] - dist, -gap[None, None]), (d, dist)
    if isinstance(p, BarStopLayout):
        d = x[p.a + 1 : p.a + p.n] - x[p.a : p.a + p.n - 1]  # (n - 1, 2, B), bar i -> i + 1
        dist = safe_norm(d, axis=1)
        return gap - dist, (d, dist)
    face = x[p.anchor, p.axis][None]  # (1, B)
    offset = gap if gap.ndim == 2 else gap[None]  # one per node, or one for all
    return face + offset - x[p.a : p.a + p.n_a, p.axis], None


def _smoothing(flat: FlatScene, delta):
    return flat.contact_smoothing[(None,) * (delta.ndim - 1)]


def _cap(p, gap, delta):
    """The largest permanent set of a collapse set's springs: its gap (the centre line reaches
    the plane, the other centre line or, for a bar, its crush length), shaped like delta."""
    if isinstance(p, SelfPairLayout):
        return jnp.broadcast_to(gap[None, None], delta.shape)
    return jnp.broadcast_to(gap if gap.ndim == 2 else gap[None], delta.shape)


def _spring(flat: FlatScene, p, delta, gap, permanent_set, k, fy):
    """Eq. 18's spring with its permanent set stopped at `_cap` (`capped_contact_spring`)."""
    cap = _cap(p, gap, delta)
    return capped_contact_spring(delta, permanent_set, k, fy, _smoothing(flat, delta), cap)


def collapse_pair_force(flat: FlatScene, p, x, gap, k, fy, permanent_set):
    """Pair forces (>= 0) of one collapse set with the permanent set after the return map."""
    delta, _ = _approach(flat, p, x, gap)
    f, _, _ = _spring(flat, p, delta, gap, permanent_set, k, fy)
    return f


def collapse_energy(flat: FlatScene, p, x, gap, k, permanent_set):
    """Elastic energy (B,) of one collapse set at x with its permanent set (after the map)."""
    delta, _ = _approach(flat, p, x, gap)
    axes = tuple(range(delta.ndim - 1))
    return jnp.sum(contact_energy(delta, permanent_set, k, _smoothing(flat, delta)), axis=axes)


def collapse_response(flat: FlatScene, p, x, gap, k, fy, permanent_set):
    """One collapse set at x: (nodal forces (N, 2, B), new set, pair forces, dissipated (B,),
    elastic energy (B,)). Forces are -dU/dx of the contact energy (central, equal and opposite).
    """
    delta, geometry = _approach(flat, p, x, gap)
    cs = _smoothing(flat, delta)
    f, new_set, dc = _spring(flat, p, delta, gap, permanent_set, k, fy)
    axes = tuple(range(f.ndim - 1))
    elastic = jnp.sum(contact_energy(delta, new_set, k, cs), axis=axes)
    n_nodes = x.shape[0]
    if isinstance(p, SelfPairLayout):
        d, dist = geometry
        safe = jnp.where(dist > 0, dist, 1.0)
        along = jnp.where(dist > 0, f / safe, 0.0)[:, :, None] * d  # pushes i away from j
        fa = jnp.sum(along, axis=1) - jnp.sum(along, axis=0)
        force = jnp.pad(fa, ((p.a, n_nodes - p.a - p.n), (0, 0), (0, 0)))
    elif isinstance(p, BarStopLayout):
        d, dist = geometry
        safe = jnp.where(dist > 0, dist, 1.0)
        along = jnp.where(dist > 0, f / safe, 0.0)[:, None] * d  # pushes node i + 1 from i
        pad = ((0, 0), (0, 0))
        force = jnp.pad(along, ((1, 0), *pad)) - jnp.pad(along, ((0, 1), *pad))
        force = jnp.pad(force, ((p.a, n_nodes - p.a - p.n), *pad))
    else:
        assert isinstance(p, FacePlaneLayout)
        f_nodes = jnp.pad(f, ((p.a, n_nodes - p.a - p.n_a), (0, 0)))  # +f on each node
        f_nodes = f_nodes.at[p.anchor].add(-jnp.sum(f, axis=0))  # -sum f on the anchor
        zero = jnp.zeros_like(f_nodes)
        force = jnp.stack([f_nodes, zero] if p.axis == 0 else [zero, f_nodes], axis=1)
    return force, new_set, f, jnp.sum(dc, axis=axes), elastic
