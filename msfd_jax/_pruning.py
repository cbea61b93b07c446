"""Pruned node-to-node contact (issue 11): a set evaluated in blocks, far blocks skipped.

Each block of ring nodes x beam nodes is a ``lax.cond``: skipped when its two bounding boxes
are at least the gap apart in every collision of the batch (`near_blocks`), which is exact
(such pairs carry no force, keep their permanent sets, dissipate and store nothing). The
block shapes are `contact_blocks`'s, measured in benchmarks/results/contact_blocks.md; with
`SKIP_FAR_BLOCKS` off every block is evaluated, in the same blocks and order (the reference
tests/test_pruning.py holds the pruned step to, bit for bit).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from ._flat import PairLayout
from ._laws import contact_energy, contact_spring


def pad(a, before, after):
    return jnp.pad(a, ((before, after),) + ((0, 0),) * (a.ndim - 1))


def total(a):
    """Sum over every axis but the batch, as a matrix-vector product. Written as a reduction
    over the major axes, XLA:CPU fused it with the contact law into the step's two slowest
    kernels (issue 11: a per-kernel trace of the substep at B = 64)."""
    if a.ndim == 1:
        return a
    flat = jnp.reshape(a, (-1, a.shape[-1]))
    return jnp.ones(flat.shape[0], flat.dtype) @ flat


# Tests and benchmarks set this to False to evaluate every block, in the same blocks and the
# same order (the unpruned reference the pruned contact equals bit for bit,
# tests/test_pruning.py); read when a step is traced.
SKIP_FAR_BLOCKS = True
ONE_BLOCK_PAIRS = 2000  # a batch of one keeps a set of at most this many pairs whole
_REACH_MARGIN = 1.0 + 1e-9  # on the gap: covers the rounding of the pair distances


def contact_blocks(n_a: int, n_b: int, batch: int) -> tuple[int, int]:
    """The block shape (ring nodes, beam nodes) a node-to-node set is evaluated in.

    Blocks out of reach in every collision of the batch are skipped (`near_blocks`). The
    shapes are the fastest measured on XLA:CPU (`python benchmarks/contact_blocks.py`,
    benchmarks/results/contact_blocks.md): a batch of one on a set of up to 2000 pairs
    evaluates it as one block (skipped while ring and beam are apart); otherwise blocks of
    about a quarter of the ring's nodes by a fifth of the beam's (4 x 7 on the paper's
    16 x 21 mesh, 16 x 17 on four times as many segments).
    """
    if batch == 1 and n_a * n_b <= ONE_BLOCK_PAIRS:
        return n_a, n_b
    return min(n_a, max(4, -(-n_a // 4))), min(n_b, max(7, -(-n_b // 5)))


def _box(xs):
    """Bounding box (min x, max x, min y, max y), each (B,), of nodes xs (n, 2, B)."""
    return jnp.min(xs[:, 0], 0), jnp.max(xs[:, 0], 0), jnp.min(xs[:, 1], 0), jnp.max(xs[:, 1], 0)


def near_blocks(xa, xb, gap, blocks):
    """Yield (rows, columns, near) for the blocks of a node-to-node set: `near` (a scalar)
    is false only when the block's two bounding boxes are at least the gap apart in every
    collision of the batch. Then every pair of the block is at distance >= gap, has approach
    delta <= 0 <= its permanent set, and so carries no force, keeps its set, dissipates
    nothing and stores no energy (sharp and smoothed laws alike: the ramp is 0 for s <= 0):
    leaving the block out is exact. A NaN position makes every block near. With
    `SKIP_FAR_BLOCKS` false every block is near."""
    bi, bj = blocks
    rows = [(i, min(i + bi, xa.shape[0])) for i in range(0, xa.shape[0], bi)]
    cols = [(j, min(j + bj, xb.shape[0])) for j in range(0, xb.shape[0], bj)]
    boxes_b = [_box(xb[j0:j1]) for j0, j1 in cols]
    reach = (gap * _REACH_MARGIN) ** 2
    for i0, i1 in rows:
        ax0, ax1, ay0, ay1 = _box(xa[i0:i1])
        for (j0, j1), (bx0, bx1, by0, by1) in zip(cols, boxes_b, strict=True):
            gx = jnp.maximum(jnp.maximum(ax0 - bx1, bx0 - ax1), 0.0)
            gy = jnp.maximum(jnp.maximum(ay0 - by1, by0 - ay1), 0.0)
            near = ~(gx * gx + gy * gy >= reach)
            if not SKIP_FAR_BLOCKS:  # true, but not known to XLA: the branch stays a branch
                near = near | (reach >= 0.0)
            yield (i0, i1), (j0, j1), jnp.any(near)


def pair_geometry(xa, xb, gap):
    """Approaches (n_a, n_b, B) of nodes xa against xb, with (dx, dy, dist, apart)."""
    dx = xa[:, None, 0] - xb[None, :, 0]  # (n_a, n_b, B): the batch stays the minor axis
    dy = xa[:, None, 1] - xb[None, :, 1]
    sq = dx * dx + dy * dy
    apart = sq > 0
    dist = jnp.where(apart, jnp.sqrt(jnp.where(apart, sq, 1.0)), 0.0)
    return gap[None, None] - dist, (dx, dy, dist, apart)


def blocked_pairs(p: PairLayout, x, gap, k, fy, ps, blocks, width):
    """A node-to-node set's response, block by block, blocks out of reach skipped exactly
    (`near_blocks`). Returns (nodal forces (N, 2, B), new permanent set, total pair force
    per collision, dissipation per collision).

    Each block is a ``lax.cond`` whose operands are the whole arrays (a branch slices its
    block: slicing outside would copy every block's constants each step); the new set is
    assembled from the blocks (faster on XLA:CPU than in-place updates, measured)."""
    xa, xb = x[p.a : p.a + p.n_a], x[p.b : p.b + p.n_b]
    batch = x.shape[-1:]

    def branches(i0, i1, j0, j1):
        def pairs(xa, xb, ps, k, fy, gap):
            delta, (dx, dy, dist, apart) = pair_geometry(xa[i0:i1], xb[j0:j1], gap)
            sl = (slice(i0, i1), slice(j0, j1))
            f, ps1, dc = contact_spring(delta, ps[sl], k[sl], fy[sl], width)
            c = jnp.where(apart, f / jnp.where(apart, dist, 1.0), 0.0)
            fx, fy_ = c * dx, c * dy
            f_a = jnp.stack([jnp.sum(fx, axis=1), jnp.sum(fy_, axis=1)], axis=1)
            f_b = -jnp.stack([jnp.sum(fx, axis=0), jnp.sum(fy_, axis=0)], axis=1)
            return f_a, f_b, ps1, total(f), total(dc)

        def idle(xa, xb, ps, k, fy, gap):
            z = jnp.zeros(batch)
            f_a, f_b = jnp.zeros((i1 - i0, 2, *batch)), jnp.zeros((j1 - j0, 2, *batch))
            return f_a, f_b, ps[i0:i1, j0:j1], z, z

        return pairs, idle

    fa = {}
    fb = {}
    rows: dict[int, list] = {}
    f_sum = dissipated = jnp.zeros(batch)
    for (i0, i1), (j0, j1), near in near_blocks(xa, xb, gap, blocks):
        f_a, f_b, ps1, f_total, dc = jax.lax.cond(
            near, *branches(i0, i1, j0, j1), xa, xb, ps, k, fy, gap
        )
        fa[i0] = fa[i0] + f_a if i0 in fa else f_a
        fb[j0] = fb[j0] + f_b if j0 in fb else f_b
        rows.setdefault(i0, []).append(ps1)
        f_sum, dissipated = f_sum + f_total, dissipated + dc
    new_set = jnp.concatenate([jnp.concatenate(r, axis=1) for r in rows.values()])
    n_nodes = x.shape[0]
    force = pad(jnp.concatenate(list(fa.values())), p.a, n_nodes - p.a - p.n_a)
    force = force + pad(jnp.concatenate(list(fb.values())), p.b, n_nodes - p.b - p.n_b)
    return force, new_set, f_sum, dissipated


def blocked_energy(p: PairLayout, x, gap, k, ps, blocks, width):
    """A node-to-node set's stored energy (B,), blocks out of reach skipped (exactly 0)."""
    xa, xb = x[p.a : p.a + p.n_a], x[p.b : p.b + p.n_b]
    energy = jnp.zeros(x.shape[-1:])
    for (i0, i1), (j0, j1), near in near_blocks(xa, xb, gap, blocks):

        def stored(xa, xb, ps, k, gap, i0=i0, i1=i1, j0=j0, j1=j1):
            delta, _ = pair_geometry(xa[i0:i1], xb[j0:j1], gap)
            sl = (slice(i0, i1), slice(j0, j1))
            return jnp.sum(contact_energy(delta, ps[sl], k[sl], width), axis=(0, 1))

        energy = energy + jax.lax.cond(
            near, stored, lambda *a: jnp.zeros(x.shape[-1:]), xa, xb, ps, k, gap
        )
    return energy
