"""Pruned ring-beam contact (issue 11): blocks out of reach are skipped, and nothing changes.

`_pruning.contact_blocks` splits a node-to-node set into blocks and `near_blocks` skips the
blocks whose bounding boxes are at least the gap apart in every collision of the batch. These
tests hold the pruned step to the unpruned one (`_pruning.SKIP_FAR_BLOCKS` off: every block
evaluated, in the same blocks and order): the block test never skips a pair within reach, and
a sweep, a single run and a forward-mode derivative come out the same bit for bit. (Against
the former one-block formulation the sums are grouped differently: rounding-level forces, and
tests/test_regression.py holds the recorded runs to 1e-9 K0 and their step counts.)
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from conftest import SMALL_MESH

import msfd_jax as m
from msfd_jax._batched import engine as _engine
from msfd_jax._batched import pruning as _pruning
from msfd_jax._sweeps import sweep as _sweep


@pytest.fixture
def dense():
    """`dense(True)`: from then on every block is evaluated (`SKIP_FAR_BLOCKS` off, read when a
    program is traced). jit's cache key does not hold that flag, so the dense programs are
    traced under another value of a setting it does hold and that changes no arithmetic:
    rank promotion "warn" instead of the suite's "raise" (an implicit promotion would then
    warn, and the suite's warnings are errors). A pruned program is never served for a dense
    call or the reverse, and the programs traced before stay cached for the later tests
    (clearing jit's caches made them trace again)."""
    suite = jax.config.jax_numpy_rank_promotion
    other = "allow" if suite == "warn" else "warn"

    def use(flag: bool):
        _pruning.SKIP_FAR_BLOCKS = not flag
        jax.config.update("jax_numpy_rank_promotion", other if flag else suite)
        # a program traced under the other value sees the flag as it is now
        assert bool(_SKIPS_FAR_BLOCKS()) is (not flag)

    yield use
    use(False)


# what a jitted program saw of the flag when it was traced
_SKIPS_FAR_BLOCKS = jax.jit(lambda: jnp.asarray(_pruning.SKIP_FAR_BLOCKS))


def test_block_shapes():
    assert _pruning.contact_blocks(16, 21, 1) == (16, 21)  # one block, skipped while apart
    assert _pruning.contact_blocks(16, 21, 32) == (4, 7)
    assert _pruning.contact_blocks(61, 81, 32) == (16, 17)
    assert _pruning.contact_blocks(61, 81, 1) == (16, 17)  # a large set: blocks even for one
    assert _pruning.contact_blocks(3, 4, 32) == (3, 4)  # never larger than the set
    assert _pruning.contact_blocks(31, 41, 16) == (8, 9)
    assert _pruning.contact_blocks(31, 41, 1) == (31, 41)  # one block pays up to 2000 pairs


@pytest.mark.parametrize("seed", range(3))
def test_no_block_with_a_pair_in_reach_is_skipped(seed):
    """Random rows of nodes where some pairs are within the gap in some of eight lanes: every
    block holding such a pair is near; NaN positions make blocks near."""
    rng = np.random.default_rng(seed)
    na, nb, b = 13, 17, 8
    # two rows of nodes along x (a ring and a beam side by side), jittered in every lane
    xa = np.stack([np.linspace(0, 2, na)[:, None] + 0 * np.ones(b), np.full((na, b), 0.1)], 1)
    xb = np.stack([np.linspace(0, 3, nb)[:, None] + 0 * np.ones(b), np.zeros((nb, b))], 1)
    xa = xa + rng.normal(0.0, 0.05, xa.shape)
    xb = xb + rng.normal(0.0, 0.05, xb.shape)
    gap = jnp.full(b, 0.15)
    dist = np.sqrt(((xa[:, None] - xb[None]) ** 2).sum(2))  # (na, nb, B)
    within = dist < 0.15
    assert within.any() and not within.all()
    skipped = 0
    for (i0, i1), (j0, j1), near in _pruning.near_blocks(xa, xb, gap, (4, 5)):
        if within[i0:i1, j0:j1].any():
            assert bool(near)
        skipped += not bool(near)
    assert skipped > 0  # the test can fail both ways
    xa[0, 0, 3] = np.nan
    nearness = [bool(n) for (i0, _), _, n in _pruning.near_blocks(xa, xb, gap, (4, 5)) if i0 == 0]
    assert all(nearness)


def test_a_pair_exactly_at_the_gap_is_not_skipped():
    """Two nodes a gap apart up to rounding: the margin keeps their block in."""
    gap = 0.3
    xa = np.array([[0.0, 0.0]])[..., None]
    for d in (gap * (1 - 1e-15), gap, gap * (1 + 1e-12)):
        xb = np.array([[d, 0.0]])[..., None]
        ((_, _, near),) = _pruning.near_blocks(xa, xb, jnp.full(1, gap), (1, 1))
        assert bool(near)
    xb = np.array([[gap * 1.01, 0.0]])[..., None]
    ((_, _, near),) = _pruning.near_blocks(xa, xb, jnp.full(1, gap), (1, 1))
    assert not bool(near)


GRID = dict(
    thickness_ratio=[0.25, 5.0], axial_constraint=[0.0, 1.0], mass_ratio=[40.0]
)  # thin free beams wrap the ring (contact over most pairs), thick held ones touch locally;
# the sweep's path (queue, refills, rows) on the small mesh: 2 slots, 2 x 2 blocks of 4 x 7 with
# the last row and column shifted back (the paper mesh's 4 x 3 blocks: the jvp tests below)
COLUMNS = ("beam_bending", "beam_axial", "ring_bending", "ring_axial", "contact", "kinetic")


def test_a_pruned_sweep_equals_the_dense_one(dense):
    settings = _sweep.SWEEP_SETTINGS
    pruned = m.sweep(GRID, SMALL_MESH, settings, chunk_size=2)
    dense(True)
    full = m.sweep(GRID, SMALL_MESH, settings, chunk_size=2)
    for name in ("steps", "result", "t_end", *COLUMNS):
        np.testing.assert_array_equal(pruned[name], full[name], err_msg=name)


def test_a_pruned_single_run_and_its_histories_equal_the_dense_one(dense):
    params = m.CollisionParams(thickness_ratio=0.5, axial_constraint=0.0)
    settings = m.Settings(history_points=64)
    pruned = m.run(params, m.Mesh(), settings)
    dense(True)
    full = m.run(params, m.Mesh(), settings)
    assert int(pruned.solution.steps) == int(full.solution.steps)
    assert pruned.fractions == full.fractions
    for key in ("kinetic", "elastic", "contact_force"):
        np.testing.assert_array_equal(pruned.solution.history[key], full.solution.history[key])


@pytest.fixture(scope="module")
def in_contact():
    """A batch of 8 collisions (h_b/h_r 0.5-4, free and held) on the small mesh (7 ring x 9
    beam contact nodes) 1200 substeps into contact: (flat, y) with permanent sets grown."""
    from msfd_jax._sweeps import queue as _queue

    base = m.CollisionParams().scalars()
    params = m.CollisionParams(
        **{k: jnp.full(8, float(v)) for k, v in base.items()}
        | {
            "thickness_ratio": jnp.linspace(0.5, 4.0, 8),
            "axial_constraint": jnp.tile(jnp.array([0.0, 1.0]), 4),
        }
    )
    smoothing = _queue.with_flags((0.0, 0.0))
    flat, clock, y = _queue._start(
        params, jnp.full(8, 3e-4), SMALL_MESH, smoothing, _sweep.SWEEP_SETTINGS, 10**6
    )
    h = jnp.full(8, 2e-4)
    body = lambda i, s: _engine.verlet_substep(flat, s, i * h, h, clock.tolerance)  # noqa: E731
    y = jax.jit(lambda y: jax.lax.fori_loop(0, 1200, body, y))(y)
    assert float(jnp.max(y.permanent_set[0])) > 0  # some pairs have yielded
    return flat, y


@pytest.mark.parametrize("blocks", [(1, 3), (2, 4)])
def test_the_listed_loop_equals_the_blocks_bit_for_bit(in_contact, blocks):
    """`listed_pairs` / `listed_energy` (near blocks in a while loop) against `blocked_pairs` /
    `blocked_energy` (a conditional per block) in the same blocks: forces, permanent sets,
    total force and dissipation equal to the bit, with blocks that divide the 7 x 9 set and
    blocks whose last row and column are shifted back (masked overlap). The stored energy is
    equal to the bit where the blocks divide the set; a shifted block sums its masked zeros
    at other places of XLA's reduction than the smaller block does, which moved the last
    bit (measured 3.5e-16 relative with 4 x 5 blocks): there it is held to 1e-15."""
    flat, y = in_contact
    p, gap, k, fy = flat.pairs[0], flat.gap[0], flat.stiffness[0], flat.yield_force[0]
    # a second state: the ring (below the beam, moving up) pressed 0.02 R further into it
    changed = []
    for x in (y.x, y.x.at[p.a : p.a + p.n_a, 1].add(0.02)):
        ps = y.permanent_set[0]
        listed = jax.jit(_pruning.listed_pairs, static_argnums=(0, 6, 7))
        blocked = jax.jit(_pruning.blocked_pairs, static_argnums=(0, 6, 7))
        a = listed(p, x, gap, k, fy, ps, blocks, None)
        b = blocked(p, x, gap, k, fy, ps, blocks, None)
        for name, u, v in zip(("force", "set", "total", "dissipated"), a, b, strict=True):
            np.testing.assert_array_equal(u, v, err_msg=name)
        changed.append(bool(jnp.any(a[1] != ps)) and float(jnp.max(jnp.abs(a[0]))) > 0)
        e_listed = jax.jit(_pruning.listed_energy, static_argnums=(0, 5, 6))
        e_blocked = jax.jit(_pruning.blocked_energy, static_argnums=(0, 5, 6))
        e = e_listed(p, x, gap, k, a[1], blocks, None), e_blocked(p, x, gap, k, a[1], blocks, None)
        if p.n_a % blocks[0] == 0 and p.n_b % blocks[1] == 0:
            np.testing.assert_array_equal(*e)
        else:
            np.testing.assert_allclose(*e, rtol=1e-15, atol=0)
    assert changed[-1]  # pressed further: forces, and pairs yield (the sets' update compared)


def test_the_dense_loop_equals_one_near_block_bit_for_bit(in_contact):
    """`dense_pairs` / `dense_energy` (every pair, no conditional: for a GPU) against
    `blocked_pairs` / `blocked_energy` with the whole set as one block: equal to the bit; and
    against the default blocks (sums grouped otherwise) to 1e-12 of the largest."""
    flat, y = in_contact
    p, gap, k, fy = flat.pairs[0], flat.gap[0], flat.stiffness[0], flat.yield_force[0]
    x, ps = y.x.at[p.a : p.a + p.n_a, 1].add(0.02), y.permanent_set[0]  # pressed further
    whole, shape = (p.n_a, p.n_b), _pruning.contact_blocks(p.n_a, p.n_b, 8)
    assert shape != whole  # the default splits the set
    pairs = {
        name: jax.jit(f, static_argnums=(0, 6, 7))
        for name, f in (("dense", _pruning.dense_pairs), ("blocks", _pruning.blocked_pairs))
    }
    energy = {
        name: jax.jit(f, static_argnums=(0, 5, 6))
        for name, f in (("dense", _pruning.dense_energy), ("blocks", _pruning.blocked_energy))
    }
    d = pairs["dense"](p, x, gap, k, fy, ps, shape, None)
    assert float(jnp.max(jnp.abs(d[0]))) > 0 and bool(jnp.any(d[1] != ps))  # forces, yields
    for blocks, exact in ((whole, True), (shape, False)):
        b = pairs["blocks"](p, x, gap, k, fy, ps, blocks, None)
        e = energy["dense"](p, x, gap, k, d[1], blocks, None)
        e_b = energy["blocks"](p, x, gap, k, d[1], blocks, None)
        for name, u, v in zip(
            ("force", "set", "total", "dissipated", "energy"), (*d, e), (*b, e_b), strict=True
        ):
            if exact:
                np.testing.assert_array_equal(u, v, err_msg=name)
            else:
                np.testing.assert_allclose(
                    u, v, rtol=0, atol=1e-12 * float(jnp.max(jnp.abs(v))), err_msg=name
                )


def test_contact_loop_is_checked():
    allowed = "contact_loop must be None or one of 'blocks', 'listed', 'dense'"
    with pytest.raises(ValueError, match=allowed):
        m.Settings(contact_loop="pruned")
    paper, finer = m.Mesh(), m.Mesh(ring_segments=60, beam_contact_segments=80)
    assert _sweep._sweep_settings(m.Settings(), paper).contact_loop == "blocks"
    assert _sweep._sweep_settings(m.Settings(), finer).contact_loop == "listed"  # 61 x 81
    listed = m.Settings(contact_loop="listed")
    assert _sweep._sweep_settings(listed, paper).contact_loop == "listed"  # as asked
    assert m.Settings().contact_loop is None  # simulate: the blocks (reverse mode works)


def test_a_sweep_on_an_accelerator_takes_the_dense_loop(monkeypatch):
    """On a GPU a sweep's default contact loop is the dense one (no conditional), whatever
    the mesh; a loop asked for is kept; on a CPU the blocks and listed loops stay."""
    from msfd_jax._batched import simulate as _simulate

    paper, finer = m.Mesh(), m.Mesh(ring_segments=60, beam_contact_segments=80)
    assert _simulate.platform() == "cpu"
    monkeypatch.setattr(_simulate, "platform", lambda: "gpu")
    assert _sweep._sweep_settings(m.Settings(), paper).contact_loop == "dense"
    assert _sweep._sweep_settings(m.Settings(), finer).contact_loop == "dense"
    blocks = m.Settings(contact_loop="blocks")
    assert _sweep._sweep_settings(blocks, paper).contact_loop == "blocks"


@pytest.mark.parametrize("loop", ["blocks", "listed"])
def test_forward_mode_through_the_pruned_contact_equals_the_dense_one(dense, loop):
    """jvp of 400 substeps of a batch in contact (blocks skipped and evaluated) along x, with
    a conditional per block and with the listed loop (forward mode works through both)."""
    from msfd_jax._sweeps import queue as _queue

    base = m.CollisionParams().scalars()
    params = m.CollisionParams(
        **{k: jnp.full(4, float(v)) for k, v in base.items()}
        | {"thickness_ratio": jnp.linspace(0.5, 4.0, 4)}
    )
    smoothing = _queue.with_flags((0.0, 0.0))
    flat, clock, y = _queue._start(
        params, jnp.full(4, 3e-4), m.Mesh(), smoothing, _sweep.SWEEP_SETTINGS, 10**6
    )
    h = jnp.full(4, 2e-4)

    def advance(steps):
        def loop(x):
            def body(i, s):
                return _engine.verlet_substep(flat, s, i * h, h, clock.tolerance, loop)

            out = jax.lax.fori_loop(0, steps, body, eqx.tree_at(lambda s: s.x, y, x))
            return out.x, jnp.sum(out.contact, 0)

        return loop

    x_mid, _ = jax.jit(advance(600))(y.x)  # a state in contact
    tangent = jnp.zeros_like(x_mid).at[:16, 1].set(1.0)
    pruned = jax.jvp(jax.jit(advance(400)), (x_mid,), (tangent,))
    dense(True)
    full = jax.jvp(jax.jit(advance(400)), (x_mid,), (tangent,))
    for a, b in zip(
        jax.tree_util.tree_leaves(pruned), jax.tree_util.tree_leaves(full), strict=True
    ):
        np.testing.assert_array_equal(a, b)
    assert float(jnp.min(pruned[0][1])) > 0  # every collision dissipated in contact
