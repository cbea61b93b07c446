"""Pruned node-to-node contact: a set evaluated in blocks, far blocks skipped.

A block of ring nodes x beam nodes is skipped when its two bounding boxes are at least the gap
apart in every collision of the batch (`near_blocks`), which is exact (such pairs carry no
force, keep their permanent sets, dissipate and store nothing). Two ways to skip, chosen by
``Settings.contact_loop`` (static):

- ``"blocks"`` (`blocked_pairs`): each block is a ``lax.cond``; differentiable in forward and
  reverse mode. A skipped block still costs its conditional and passes its part of the
  permanent set through (results/profile_contact.md at ee23c14^, git show).
- ``"dense"`` (`dense_pairs`): every pair in one block, no conditional, nothing skipped:
  straight-line code for a GPU, where XLA may run a conditional by reading its predicate on
  the host (benchmarks/gpu_throughput.py compares the loops there).
- ``"listed"`` (`listed_pairs`): the near blocks are listed and a ``lax.while_loop`` visits
  only them, updating the permanent set and the forces in place; a far block costs nothing
  but its bounding-box test. Forward mode (``jax.jvp``) works through it, reverse mode does
  not (a while loop of dynamic length): the sweeps use it (results/contact_loop.md at ee23c14^).

For the same block shape the two give the same numbers bit for bit (tests/test_pruning.py),
and with `SKIP_FAR_BLOCKS` off every block is evaluated, in the same blocks and order (the
reference the pruned step equals, bit for bit).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from .._model.laws import contact_energy, contact_spring
from .flat import PairLayout


def pad(a, before, after):
    return jnp.pad(a, ((before, after),) + ((0, 0),) * (a.ndim - 1))


def total(a):
    """Sum over every axis but the batch, as a matrix-vector product. Written as a reduction
    over the major axes, XLA:CPU fused it with the contact law into the step's two slowest
    kernels (a per-kernel trace of the substep at B = 64)."""
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


LISTED_BLOCK = (2, 7)  # block shape of the listed loop (results/contact_loop.md at ee23c14^)


def listed_blocks(n_a: int, n_b: int, batch: int) -> tuple[int, int]:
    """The block shape of `listed_pairs`: a far block costs nothing there but its box test,
    so blocks are small (2 ring nodes x 7 beam nodes, the fastest measured at 1x and 4x the
    paper's mesh, `python benchmarks/contact_loop.py`); a batch of one keeps a set of up to
    `ONE_BLOCK_PAIRS` pairs whole, as `contact_blocks` does."""
    if batch == 1 and n_a * n_b <= ONE_BLOCK_PAIRS:
        return n_a, n_b
    return min(n_a, LISTED_BLOCK[0]), min(n_b, LISTED_BLOCK[1])


def _boxes(xs, size: int):
    """Bounding boxes (min x, max x, min y, max y), each (blocks, B), of the consecutive
    blocks of `size` nodes of xs (n, 2, B), the last one shorter where `size` does not
    divide n: one reduction over every block at once."""
    n = xs.shape[0]
    whole = n // size
    out = []
    for a in (xs[:, 0], xs[:, 1]):
        head = jnp.reshape(a[: whole * size], (whole, size, *a.shape[1:]))
        low, high = [jnp.min(head, 1)], [jnp.max(head, 1)]
        if whole * size < n:
            low.append(jnp.min(a[whole * size :], 0)[None])
            high.append(jnp.max(a[whole * size :], 0)[None])
        out += [jnp.concatenate(low), jnp.concatenate(high)]
    return out


def near_matrix(xa, xb, gap, blocks):
    """(rows, cols) booleans, one per block of a node-to-node set: false only when the
    block's two bounding boxes are at least the gap apart in every collision of the batch.
    Then every pair of the block is at distance >= gap, has approach delta <= 0 <= its
    permanent set, and so carries no force, keeps its set, dissipates nothing and stores no
    energy (sharp and smoothed laws alike: the ramp is 0 for s <= 0): leaving the block out
    is exact. A NaN position makes every block near. With `SKIP_FAR_BLOCKS` false every
    block is near. The boxes and gaps of all blocks are computed at once (a few kernels
    rather than a few per block)."""
    ax0, ax1, ay0, ay1 = _boxes(xa, blocks[0])
    bx0, bx1, by0, by1 = _boxes(xb, blocks[1])
    gx = jnp.maximum(jnp.maximum(ax0[:, None] - bx1[None], bx0[None] - ax1[:, None]), 0.0)
    gy = jnp.maximum(jnp.maximum(ay0[:, None] - by1[None], by0[None] - ay1[:, None]), 0.0)
    reach = (_widest(gap) * _REACH_MARGIN) ** 2
    near = ~(gx * gx + gy * gy >= reach[None, None])  # (rows, cols, B)
    if not SKIP_FAR_BLOCKS:  # true, but not known to XLA: the branch stays a branch
        near = near | (reach >= 0.0)[None, None]
    return jnp.any(near, axis=-1)


def _widest(gap):
    """The gap per collision (B,): a set's one gap, or the largest of a per-pair gap
    (n_a, n_b, B), a graded beam's (a block at least that far apart carries no force)."""
    return jnp.max(gap, axis=(0, 1)) if gap.ndim == 3 else gap


def _gap_block(gap, rows, cols):
    """The gap of a block (rows, cols): the set's one gap (B,), or its slice of a per-pair gap."""
    if gap.ndim == 3:
        return gap[rows[0] : rows[1], cols[0] : cols[1]]
    return gap


def near_blocks(xa, xb, gap, blocks):
    """Yield (rows, columns, near) for the blocks of a node-to-node set, `near` a scalar
    (`near_matrix`)."""
    bi, bj = blocks
    near = near_matrix(xa, xb, gap, blocks)
    for r, i0 in enumerate(range(0, xa.shape[0], bi)):
        for q, j0 in enumerate(range(0, xb.shape[0], bj)):
            yield (i0, min(i0 + bi, xa.shape[0])), (j0, min(j0 + bj, xb.shape[0])), near[r, q]


def pair_geometry(xa, xb, gap):
    """Approaches (n_a, n_b, B) of nodes xa against xb, with (dx, dy, dist, apart); `gap`
    one per collision (B,) or one per pair (n_a, n_b, B)."""
    dx = xa[:, None, 0] - xb[None, :, 0]  # (n_a, n_b, B): the batch stays the minor axis
    dy = xa[:, None, 1] - xb[None, :, 1]
    sq = dx * dx + dy * dy
    apart = sq > 0
    dist = jnp.where(apart, jnp.sqrt(jnp.where(apart, sq, 1.0)), 0.0)
    gap = gap if gap.ndim == 3 else gap[None, None]
    return gap - dist, (dx, dy, dist, apart)


def _block_response(xa, xb, ps, k, fy, gap, rows, cols, width):
    """One block (ring nodes `rows`, beam nodes `cols`) of a node-to-node set: its nodal
    forces on each side, new permanent set, total pair force and dissipation per collision."""
    (i0, i1), (j0, j1) = rows, cols
    delta, (dx, dy, dist, apart) = pair_geometry(xa[i0:i1], xb[j0:j1], _gap_block(gap, rows, cols))
    sl = (slice(i0, i1), slice(j0, j1))
    f, ps1, dc = contact_spring(delta, ps[sl], k[sl], fy[sl], width)
    c = jnp.where(apart, f / jnp.where(apart, dist, 1.0), 0.0)
    fx, fy_ = c * dx, c * dy
    f_a = jnp.stack([jnp.sum(fx, axis=1), jnp.sum(fy_, axis=1)], axis=1)
    f_b = -jnp.stack([jnp.sum(fx, axis=0), jnp.sum(fy_, axis=0)], axis=1)
    return f_a, f_b, ps1, total(f), total(dc)


def dense_pairs(p: PairLayout, x, gap, k, fy, ps, blocks, width):
    """A node-to-node set's response with every pair evaluated in one block and no
    conditional (``Settings.contact_loop = "dense"``; `blocks` is ignored). The same
    arithmetic as `blocked_pairs` with one block that is near, bit for bit
    (tests/test_pruning.py). Without a branch the step is straight-line code, for a GPU
    (benchmarks/gpu_throughput.py compares the loops there)."""
    xa, xb = x[p.a : p.a + p.n_a], x[p.b : p.b + p.n_b]
    f_a, f_b, new_set, f_sum, dissipated = _block_response(
        xa, xb, ps, k, fy, gap, (0, p.n_a), (0, p.n_b), width
    )
    n_nodes = x.shape[0]
    force = pad(f_a, p.a, n_nodes - p.a - p.n_a) + pad(f_b, p.b, n_nodes - p.b - p.n_b)
    return force, new_set, f_sum, dissipated


def _block_energy(xa, xb, ps, k, gap, rows, cols, width):
    """One block's stored contact energy per collision (B,) (see `_block_response`)."""
    (i0, i1), (j0, j1) = rows, cols
    delta, _ = pair_geometry(xa[i0:i1], xb[j0:j1], _gap_block(gap, rows, cols))
    sl = (slice(i0, i1), slice(j0, j1))
    return jnp.sum(contact_energy(delta, ps[sl], k[sl], width), axis=(0, 1))


def dense_energy(p: PairLayout, x, gap, k, ps, blocks, width):
    """A node-to-node set's stored energy (B,), every pair evaluated (`dense_pairs`)."""
    xa, xb = x[p.a : p.a + p.n_a], x[p.b : p.b + p.n_b]
    return _block_energy(xa, xb, ps, k, gap, (0, p.n_a), (0, p.n_b), width)


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
            return _block_response(xa, xb, ps, k, fy, gap, (i0, i1), (j0, j1), width)

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

        def stored(xa, xb, ps, k, gap, rows=(i0, i1), cols=(j0, j1)):
            return _block_energy(xa, xb, ps, k, gap, rows, cols, width)

        energy = energy + jax.lax.cond(
            near, stored, lambda *a: jnp.zeros(x.shape[-1:]), xa, xb, ps, k, gap
        )
    return energy


def _grid(n: int, size: int):
    """Blocks of `size` along n nodes: each block's nominal first node (the nodes it owns
    start there) and its first node, the last block shifted back to end at n (it then
    overlaps the one before, and the overlapped nodes are masked out of it)."""
    nominal = np.arange(0, n, size)
    return nominal, np.minimum(nominal, n - size)


def near_list(xa, xb, gap, blocks):
    """The near blocks of a node-to-node set as a list: (count, block numbers (rows x cols,
    the near ones first in row-major order), row and column grids (`_grid`)). Whether a
    block is near is `near_matrix`'s test of its nominal nodes: a shifted last block's
    overlapped nodes belong to the block before, and are masked out of it."""
    (bi, bj), n_a, n_b = blocks, xa.shape[0], xb.shape[0]
    near = near_matrix(xa, xb, gap, blocks).reshape(-1)
    (order,) = jnp.nonzero(near, size=near.shape[0], fill_value=0)
    return jnp.sum(near), order, _grid(n_a, bi), _grid(n_b, bj)


def _gap_slice(gap, i0, j0, bi, bj):
    """A listed block's gap: the set's one gap (B,), or its dynamic slice of a per-pair gap."""
    if gap.ndim == 3:
        return jax.lax.dynamic_slice(gap, (i0, j0, 0), (bi, bj, gap.shape[-1]))
    return gap


def _owned(start, nominal, size):
    """(size,) true for the nodes of a block it owns (not those of the block before)."""
    return start + jnp.arange(size) >= nominal


def listed_pairs(p: PairLayout, x, gap, k, fy, ps, blocks, width):
    """`blocked_pairs` with the near blocks listed (`near_list`) and visited by a while loop:
    the same returns, equal bit for bit for the same `blocks` (the same per-block arithmetic;
    the sums meet their blocks in the same order and a skipped block added exact zeros).

    Each visit slices its block, evaluates it inside a ``lax.cond`` (always taken: the
    conditional makes XLA:CPU materialise the slices, so that the in-place update of the
    permanent set does not copy the whole set at every visit, measured) and writes the block
    of the set and its forces back in place. Forward mode only (a dynamic trip count)."""
    xa, xb = x[p.a : p.a + p.n_a], x[p.b : p.b + p.n_b]
    batch = x.shape[-1:]
    bi, bj = blocks
    count, order, (nom_a, start_a), (nom_b, start_b) = near_list(xa, xb, gap, blocks)
    cols = len(start_b)
    mask_rows, mask_cols = p.n_a % bi != 0, p.n_b % bj != 0
    nom_a, start_a, nom_b, start_b = map(jnp.asarray, (nom_a, start_a, nom_b, start_b))

    def block(xa_s, xb_s, ps_s, k_s, fy_s, gap_s, own_a, own_b):
        delta, (dx, dy, dist, apart) = pair_geometry(xa_s, xb_s, gap_s)
        f, ps1, dc = contact_spring(delta, ps_s, k_s, fy_s, width)
        if mask_rows or mask_cols:  # the overlapped nodes of a shifted last block
            own = own_a[:, None, None] & own_b[None, :, None]
            f, ps1, dc = jnp.where(own, f, 0.0), jnp.where(own, ps1, ps_s), jnp.where(own, dc, 0.0)
        c = jnp.where(apart, f / jnp.where(apart, dist, 1.0), 0.0)
        fx, fy_ = c * dx, c * dy
        f_a = jnp.stack([jnp.sum(fx, axis=1), jnp.sum(fy_, axis=1)], axis=1)
        f_b = -jnp.stack([jnp.sum(fx, axis=0), jnp.sum(fy_, axis=0)], axis=1)
        return f_a, f_b, ps1, total(f), total(dc)

    def unused(xa_s, xb_s, ps_s, *_):
        z = jnp.zeros(batch)
        return jnp.zeros_like(xa_s), jnp.zeros_like(xb_s), ps_s, z, z

    # each listed block's first and nominal first nodes, looked up once (fewer scalar
    # kernels per visit: a visit's fixed cost is what the listed loop pays per near block)
    r, q = order // cols, order % cols
    first_a, first_b, own_a, own_b = start_a[r], start_b[q], nom_a[r], nom_b[q]

    def visit(carry):
        i, ps, fa, fb, f_sum, dissipated = carry
        i0, j0 = first_a[i], first_b[i]
        xa_s = jax.lax.dynamic_slice(xa, (i0, 0, 0), (bi, 2, *batch))
        xb_s = jax.lax.dynamic_slice(xb, (j0, 0, 0), (bj, 2, *batch))
        ps_s, k_s, fy_s = (
            jax.lax.dynamic_slice(a, (i0, j0, 0), (bi, bj, *batch)) for a in (ps, k, fy)
        )
        gap_s = _gap_slice(gap, i0, j0, bi, bj)
        own = _owned(i0, own_a[i], bi), _owned(j0, own_b[i], bj)
        f_a, f_b, ps1, f_total, dc = jax.lax.cond(
            i < count, block, unused, xa_s, xb_s, ps_s, k_s, fy_s, gap_s, *own
        )
        ps = jax.lax.dynamic_update_slice(ps, ps1, (i0, j0, 0))
        f_a = jax.lax.dynamic_slice(fa, (i0, 0, 0), f_a.shape) + f_a
        f_b = jax.lax.dynamic_slice(fb, (j0, 0, 0), f_b.shape) + f_b
        fa = jax.lax.dynamic_update_slice(fa, f_a, (i0, 0, 0))
        fb = jax.lax.dynamic_update_slice(fb, f_b, (j0, 0, 0))
        return i + 1, ps, fa, fb, f_sum + f_total, dissipated + dc

    z = jnp.zeros(batch)
    start = (jnp.zeros((), count.dtype), ps, jnp.zeros_like(xa), jnp.zeros_like(xb), z, z)
    _, new_set, fa, fb, f_sum, dissipated = jax.lax.while_loop(lambda c: c[0] < count, visit, start)
    n_nodes = x.shape[0]
    force = pad(fa, p.a, n_nodes - p.a - p.n_a) + pad(fb, p.b, n_nodes - p.b - p.n_b)
    return force, new_set, f_sum, dissipated


def listed_energy(p: PairLayout, x, gap, k, ps, blocks, width):
    """`blocked_energy` with the near blocks listed (`listed_pairs`): equal bit for bit."""
    xa, xb = x[p.a : p.a + p.n_a], x[p.b : p.b + p.n_b]
    batch = x.shape[-1:]
    bi, bj = blocks
    count, order, (nom_a, start_a), (nom_b, start_b) = near_list(xa, xb, gap, blocks)
    cols = len(start_b)
    masked = p.n_a % bi != 0 or p.n_b % bj != 0
    nom_a, start_a, nom_b, start_b = map(jnp.asarray, (nom_a, start_a, nom_b, start_b))

    r, q = order // cols, order % cols
    first_a, first_b, own_a, own_b = start_a[r], start_b[q], nom_a[r], nom_b[q]

    def visit(carry):
        i, energy = carry
        i0, j0 = first_a[i], first_b[i]
        xa_s = jax.lax.dynamic_slice(xa, (i0, 0, 0), (bi, 2, *batch))
        xb_s = jax.lax.dynamic_slice(xb, (j0, 0, 0), (bj, 2, *batch))
        ps_s, k_s = (jax.lax.dynamic_slice(a, (i0, j0, 0), (bi, bj, *batch)) for a in (ps, k))
        delta, _ = pair_geometry(xa_s, xb_s, _gap_slice(gap, i0, j0, bi, bj))
        e = contact_energy(delta, ps_s, k_s, width)
        if masked:
            own = _owned(i0, own_a[i], bi)[:, None, None] & _owned(j0, own_b[i], bj)[None, :, None]
            e = jnp.where(own, e, 0.0)
        return i + 1, energy + jnp.sum(e, axis=(0, 1))

    start = (jnp.zeros((), count.dtype), jnp.zeros(batch))
    return jax.lax.while_loop(lambda c: c[0] < count, visit, start)[1]
