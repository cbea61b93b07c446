"""Contacts of a collapsing structure: ring against the block, itself and the symmetry plane,
beam against its mirror image, and a ring bar's crush stop.

The paper's model (Sect. 3.2) has one contact, ring against beam. A heavy fast impact folds
the ring until it meets the rigid block or itself, and without these contacts the block
passes through the flattened ring (a ring bar is crushed, the energy balance breaks); a thin
beam struck hard folds at O until its two halves pass through each other. They are built
only in a collapse scene (`Mesh.collapse_contacts`; by default a run or sweep row the
paper's model leaves without an answer is solved again with them, `_collision.collapse`;
docs/model.md, "Collapse contacts"):

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

- `MirrorContact`: nodes of a chain against the symmetry plane x = 0 (the plane through O and
  S). A node and its mirror image are a pair of equal blocks at distance 2 x_I; in the half
  model that is the node against a rigid plane with its own block: approach h/(2R) - x_I,
  the half thickness h/2 (beam: the node's tributary mean thickness), at most half the node's
  rest distance from the plane (thick beams: no node starts in contact). Beam nodes O+1..E and
  ring nodes S+1..G-1 (O, S and G never move in x).
- `BarStop`: a ring bar cannot shorten below its crush length l_c = min(h_r/R, l0/2) (the
  section's thickness, and at most half the bar for a ring meshed finer than it is thick):
  past it the bar's two nodes meet as an elastic contact of the bar's axial stiffness
  EA/l_c. The bar's axial law is perfectly plastic in compression, so without the stop a
  heavy impact shortens it without bound (to a few % of its length, then through itself).

Springs are Eq. 18's blocks: the block face and the symmetry plane are rigid (only the node's
half thickness is compressed); a ring-ring pair is two ring blocks in series. The crush stop
does not yield (it stands for material with nowhere left to flow).
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
    """Nodes of chain `chain` against the plane x_axis = x[`anchor`, axis] (the plane on their
    -axis side; axis 1: the block's face y = y_G).

    approach = x_anchor + offset - x_I (along `axis`), offset = h/2 (the node's half
    thickness): one value, or one per node.
    """

    chain: int = eqx.field(static=True)
    nodes: tuple[int, ...] = eqx.field(static=True)
    anchor: int = eqx.field(static=True)
    offset: Float[Array, ""] | Float[Array, " a"]
    stiffness: Float[Array, " a"]
    yield_force: Float[Array, " a"]
    axis: int = eqx.field(static=True, default=1)

    def approach(self, xs):
        x = xs[self.chain]
        return x[self.anchor, self.axis] + self.offset - _take(x, self.nodes)[:, self.axis]

    def set_cap(self):
        """The largest permanent set of each spring (`laws.capped_contact_spring`)."""
        return jnp.broadcast_to(self.offset, self.stiffness.shape)

    def max_partners(self):
        # a node touches one plane; the anchor carries every node's spring
        return jnp.ones(()), jnp.asarray(float(len(self.nodes)))

    def masses(self, chain_masses):
        m = chain_masses[self.chain]
        return m[jnp.array(self.nodes)], m[self.anchor][None]


class MirrorContact(BlockFaceContact):
    """Nodes of chain `chain` against the symmetry plane x = x[`anchor`, 0] = 0 (`anchor` a
    symmetry node, O or S, whose x is held): a rigid plane, so the stability bound counts
    one spring per node and none on the plane (the anchor's x does not move)."""

    def max_partners(self):
        return jnp.ones(()), jnp.zeros(())

    def masses(self, chain_masses):
        return chain_masses[self.chain][jnp.array(self.nodes)], jnp.full(1, jnp.inf)


class BarStop(AbstractContact):
    """The bars of chain `chain` between consecutive nodes of `nodes`: approach = l_c - |x_{i+1}
    - x_i| (`gap` l_c, one per bar), a spring that keeps each bar longer than l_c."""

    chain: int = eqx.field(static=True)
    nodes: tuple[int, ...] = eqx.field(static=True)
    gap: Float[Array, " a"]
    stiffness: Float[Array, " a"]
    yield_force: Float[Array, " a"]

    def approach(self, xs):
        x = _take(xs[self.chain], self.nodes)
        return self.gap - safe_norm(x[1:] - x[:-1])

    def set_cap(self):
        return jnp.broadcast_to(self.gap, self.stiffness.shape)

    def max_partners(self):
        # a node ends two bars; the Gershgorin bound counts both sides' two springs
        return 2.0 * jnp.ones(()), 2.0 * jnp.ones(())

    def masses(self, chain_masses):
        m = chain_masses[self.chain][jnp.array(self.nodes)]
        return m, m


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

    def set_cap(self):
        return jnp.broadcast_to(self.gap, self.stiffness.shape)

    def max_partners(self):
        partners = 1.0 + jnp.floor(2.0 * self.gap / self.spacing)
        return partners, partners

    def masses(self, chain_masses):
        m = chain_masses[self.chain][jnp.array(self.nodes)]
        return m, m


COLLAPSE_TYPES = (BlockFaceContact, SelfContact, BarStop)  # MirrorContact is a BlockFaceContact


def pair_mask(n: int, separation: int) -> np.ndarray:
    """The (n, n) boolean mask of the pairs i < j with j - i >= separation (static)."""
    return np.triu(np.ones((n, n), dtype=bool), separation)


def _mirror_offset(half, x_rest):
    """A node's offset from the symmetry plane: its half thickness h/(2R), but at most half its
    distance from the plane at rest (a node nearer the plane than its half thickness, on a
    thick beam or ring, would otherwise start in contact); one per node."""
    return jnp.minimum(half, 0.5 * x_rest)


def collapse_contacts(
    p, mesh, ring: Chain, beam_mirror=None, ring_index: int = 0
) -> tuple[AbstractContact, ...]:
    """The collapse contacts of the quarter ring S -> G (node G is the last) and, given
    `beam_mirror` = (beam chain index, beam Chain, half thickness h/(2R) per node or one value,
    block stiffness per node, block yield force per node), the beam's mirror contact.

    `p` are the collision's parameters as arrays (`CollisionParams.as_arrays`). Order: block
    face, ring-ring, ring crush stops, ring mirror, beam mirror.
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
    l0 = ring.rest_length
    crush = jnp.minimum(1.0 / slender, 0.5 * l0)  # l_c: the section's thickness, <= l0 / 2
    k_stop = ring.section.axial_modulus / crush  # EA / l_c
    stops = BarStop(
        chain=ring_index,
        nodes=tuple(range(n)),
        gap=crush,
        stiffness=k_stop,
        yield_force=k_stop * crush,  # holds until the bar would vanish (it does not yield)
    )
    ring_mirror = MirrorContact(
        chain=ring_index,
        nodes=tuple(range(1, n - 1)),  # S and G never move in x
        anchor=0,
        offset=_mirror_offset(0.5 / slender, ring.reference[1:-1, 0]),
        stiffness=k_r[1:-1],
        yield_force=fy_r[1:-1],
        axis=0,
    )
    contacts = (face, ring_ring, stops, ring_mirror)
    if beam_mirror is None:
        return contacts
    beam_index, beam, half, k_b, fy_b = beam_mirror
    if jnp.ndim(half):
        half = half[1:]
    beam_contact = MirrorContact(
        chain=beam_index,
        nodes=tuple(range(1, beam.n_nodes)),  # O never moves in x
        anchor=0,
        offset=_mirror_offset(half, beam.reference[1:, 0]),
        stiffness=k_b[1:],
        yield_force=fy_b[1:],
        axis=0,
    )
    return (*contacts, beam_contact)
