"""Node-to-node and node-to-plane contact (Sect. 3.2, Eq. 18, Fig. 8-9).

Each contact pair is a compression-only elastic-perfectly plastic spring along the line joining
the two nodes (no friction). The spring is the two fictitious blocks of Fig. 8 (half of each
thickness in uniaxial compression over the node's tributary length) acting in series:
stiffness 1/k = 1/k_a + 1/k_b with k = E b l_t / (h/2), yield force min(Y b l_t) of the two.
For a monotone elastic-perfectly plastic pair in series only the weaker block can yield, so the
series pair is itself elastic-perfectly plastic with those constants (docs/model.md).
"""

from __future__ import annotations

import abc

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, Float

from .safe import safe_norm


class AbstractContact(eqx.Module):
    """A set of contact springs between nodes of the scene's chains."""

    stiffness: eqx.AbstractVar[Array]
    yield_force: eqx.AbstractVar[Array]

    @abc.abstractmethod
    def approach(self, xs: tuple[Float[Array, "nodes 2"], ...]) -> Array:
        """Approach delta of every pair (positive when the surfaces overlap)."""

    @abc.abstractmethod
    def max_partners(self) -> tuple[int, int]:
        """How many springs one node of each side can load at once (for the stability bound)."""

    @abc.abstractmethod
    def masses(self, chain_masses) -> tuple[Array, Array]:
        """Masses of the nodes on each side (the plane side is rigid: infinite)."""


class NodeToNodeContact(AbstractContact):
    """Every node in `nodes_a` of chain `chain_a` against every node in `nodes_b` of `chain_b`.

    approach = gap - |x_I - x_J|, with gap = (h_a + h_b) / 2 (centre lines touch when the
    surfaces do). Pairs are dense (n_a x n_b): small for this model, and no pair is ever missed.
    `gap` is one number, or one per pair (n_a, n_b) where the thickness varies (a graded beam).
    """

    chain_a: int = eqx.field(static=True)
    chain_b: int = eqx.field(static=True)
    nodes_a: tuple[int, ...] = eqx.field(static=True)
    nodes_b: tuple[int, ...] = eqx.field(static=True)
    gap: Float[Array, ""] | Float[Array, "a b"]
    stiffness: Float[Array, "a b"]
    yield_force: Float[Array, "a b"]
    spacing_b: float = eqx.field(static=True)
    spacing_a: float = eqx.field(static=True)

    def approach(self, xs):
        xa = _take(xs[self.chain_a], self.nodes_a)
        xb = _take(xs[self.chain_b], self.nodes_b)
        return self.gap - safe_norm(xa[:, None, :] - xb[None, :, :])

    def max_partners(self):
        # nodes of the other side closer than the gap on a straight row of spacing s
        gap = jnp.max(self.gap) if jnp.ndim(self.gap) else self.gap
        return (
            1.0 + jnp.floor(2.0 * gap / self.spacing_b),
            1.0 + jnp.floor(2.0 * gap / self.spacing_a),
        )

    def masses(self, chain_masses):
        return (
            chain_masses[self.chain_a][jnp.array(self.nodes_a)],
            chain_masses[self.chain_b][jnp.array(self.nodes_b)],
        )


class NodeToPlaneContact(AbstractContact):
    """Nodes of chain `chain` against a rigid plate y = `level` (the plate is on the +y side).

    approach = y_I + offset - level, offset = h/2 (the node's half thickness).
    """

    chain: int = eqx.field(static=True)
    nodes: tuple[int, ...] = eqx.field(static=True)
    level: Float[Array, ""]
    offset: Float[Array, ""]
    stiffness: Float[Array, " a"]
    yield_force: Float[Array, " a"]

    def approach(self, xs):
        return _take(xs[self.chain], self.nodes)[:, 1] + self.offset - self.level

    def max_partners(self):
        return jnp.ones(()), jnp.zeros(())

    def masses(self, chain_masses):
        return chain_masses[self.chain][jnp.array(self.nodes)], jnp.full(1, jnp.inf)


def _take(x, nodes: tuple[int, ...]):
    """Rows `nodes` of x: a static slice when they are a range (no gather in the step)."""
    if nodes == tuple(range(nodes[0], nodes[-1] + 1)):
        return x[nodes[0] : nodes[-1] + 1]
    return x[jnp.array(nodes)]


def block_stiffness(modulus_ratio, slenderness, tributary, thickness, width):
    """Stiffness of one fictitious block of Fig. 8 in units of M_pr / R^2 (ring units, Eq. 1).

    The block is half of a section of thickness h under uniaxial compression over the node's
    tributary length L_t, so in SI K = E b L_t / (h/2). With the ring's scales
    (M_pr = Y b_r h_r^2 / 4, length R) and the arguments as the scene holds them,

    - `modulus_ratio` beta = E/Y, `slenderness` R/h_r,
    - `tributary` l_t = L_t/R, `width` b/b_r,
    - `thickness` h/h_r (**in units of h_r**, like every thickness of the scene: 1 for the
      ring, h_b/h_r for the beam),

    K R^2 / M_pr = 2 E b l_t R^3 / (h Y b_r h_r^2 / 4) = 8 beta (b/b_r) (R/h_r)^3 l_t / (h/h_r).

    (This once read 8 beta (R/h_r)^2 l_t / thickness, correct only for h in units of
    R, and left every contact spring R/h_r times too soft; tests/test_units.py audits it.)
    """
    return 8.0 * modulus_ratio * slenderness**3 * width * tributary / thickness


def block_yield(slenderness, tributary, width):
    """Yield force Y b L_t of one block (Eq. 18) in units of M_pr / R.

    F R / M_pr = Y b l_t R^2 / (Y b_r h_r^2 / 4) = 4 (b/b_r) (R/h_r)^2 l_t, with `tributary`
    l_t = L_t/R and `width` b/b_r.
    """
    return 4.0 * slenderness**2 * width * tributary
