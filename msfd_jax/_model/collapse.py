"""Contacts of a collapsing ring: ring against the rigid block, ring against ring.

The paper's model (Sect. 3.2) has one contact, ring against beam. A heavy fast impact folds
the ring until it meets the rigid block or itself, and without these contacts the block
passes through the flattened ring (a ring bar is crushed, the energy balance breaks). Both
are built only when `Mesh.collapse_contacts` is set (docs/model.md, "Collapse contacts"):

- `BlockFaceContact`: ring nodes against the block's face, the plane y = y_G through the
  ring ends (the block joins them at G and, clamped and symmetric, only translates in y). The
  plane moves with G, so the spring acts between the node and G: approach
  delta = y_G + h_r/(2R) - y_I, force +f on the node and -f on G along y.
- `SelfContact`: every pair of ring nodes (i, j) with j - i >= `separation` (= 2: nodes
  either side of one joint meet when that joint folds flat), node to node like the
  ring-beam contact, gap = h_r/R (two half thicknesses).

Node to node is the simplest sound choice for ring on ring: its energy depends on node
distances only (a smooth potential: Verlet conserves it, forces are central and equal and
opposite), it is the paper's own contact law and element, and it has no closest-segment
switching (node-to-segment projections jump at the chain's kinks and at segment ends, which
creates or destroys energy in an explicit step). Its limit, that a node may slip between two
nodes of the other wall, is excluded by the validity check `params._check_collapse`
(node spacing below twice the gap), made from the inputs before anything runs.

Springs are Eq. 18's blocks: the block face is rigid (only the ring's half thickness is
compressed); a ring-ring pair is two ring blocks in series.
"""

from __future__ import annotations

import math

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from .chain import Chain
from .contact import AbstractContact, _take, block_stiffness, block_yield
from .safe import safe_norm

SEPARATION = 2  # ring pairs i < j with j - i >= 2: every pair but a bar's own two ends


class BlockFaceContact(AbstractContact):
    """Nodes of chain `chain` against the plane y = y[`anchor`] (the plane on their -y side).

    approach = y_anchor + offset - y_I, offset = h/2 (the node's half thickness).
    """

    chain: int = eqx.field(static=True)
    nodes: tuple[int, ...] = eqx.field(static=True)
    anchor: int = eqx.field(static=True)
    offset: Float[Array, ""]
    stiffness: Float[Array, " a"]
    yield_force: Float[Array, " a"]

    def approach(self, xs):
        x = xs[self.chain]
        return x[self.anchor, 1] + self.offset - _take(x, self.nodes)[:, 1]

    def max_partners(self):
        # a node touches one plane; the anchor carries every node's spring
        return jnp.ones(()), jnp.asarray(float(len(self.nodes)))

    def masses(self, chain_masses):
        m = chain_masses[self.chain]
        return m[jnp.array(self.nodes)], m[self.anchor][None]


class SelfContact(AbstractContact):
    """Nodes `nodes` of chain `chain` against each other, pairs i < j with j - i >= separation.

    approach = gap - |x_i - x_j| on those pairs; the others (the lower triangle, the diagonal
    and near neighbours) are given approach -gap, so they never close.
    """

    chain: int = eqx.field(static=True)
    nodes: tuple[int, ...] = eqx.field(static=True)
    separation: int = eqx.field(static=True)
    spacing: float = eqx.field(static=True)
    gap: Float[Array, ""]
    stiffness: Float[Array, "a a"]
    yield_force: Float[Array, "a a"]

    def approach(self, xs):
        x = _take(xs[self.chain], self.nodes)
        delta = self.gap - safe_norm(x[:, None, :] - x[None, :, :])
        return jnp.where(pair_mask(len(self.nodes), self.separation), delta, -self.gap)

    def max_partners(self):
        partners = 1.0 + jnp.floor(2.0 * self.gap / self.spacing)
        return partners, partners

    def masses(self, chain_masses):
        m = chain_masses[self.chain][jnp.array(self.nodes)]
        return m, m


def pair_mask(n: int, separation: int) -> np.ndarray:
    """The (n, n) boolean mask of the pairs i < j with j - i >= separation (static)."""
    return np.triu(np.ones((n, n), dtype=bool), separation)


def collapse_contacts(p, mesh, ring: Chain, ring_index: int = 0) -> tuple[AbstractContact, ...]:
    """The block face and ring-ring contacts of the quarter ring S -> G (node G is the last).

    `p` are the collision's parameters as arrays (`CollisionParams.as_arrays`).
    """
    beta, slender = p.modulus_ratio, p.slenderness
    lt = ring.tributary_length()
    k_r = block_stiffness(beta, slender, lt, 1.0, 1.0)
    fy_r = block_yield(slender, lt, 1.0)
    n = ring.n_nodes
    face = BlockFaceContact(
        chain=ring_index,
        nodes=tuple(range(n - 1)),  # every node but G itself, which is on the face
        anchor=n - 1,
        offset=0.5 / slender,
        stiffness=k_r[:-1],
        yield_force=fy_r[:-1],
    )
    ring_ring = SelfContact(
        chain=ring_index,
        nodes=tuple(range(n)),
        separation=SEPARATION,
        spacing=2.0 * math.sin(math.pi / 4 / mesh.ring_segments),
        gap=1.0 / slender,
        stiffness=1.0 / (1.0 / k_r[:, None] + 1.0 / k_r[None, :]),
        yield_force=jnp.minimum(fy_r[:, None], fy_r[None, :]),
    )
    return face, ring_ring
