"""A chain: one MS-FD structure (Fig. 1, 6, 7): lumped masses joined by massless bars with
elastic-plastic angular springs at the joints.

The chain is the *model* (what does not change during a run); positions and plastic parts are
state. Joint kinematics: the relative angle of the outgoing bar to the incoming one (Eq. 7),
Delta = atan2(a x b, a . b), which never wraps as long as the joint turns by less than pi.

Boundary joints (static choice per end):
- ``"free"``: no spring (a simple support, Eq. 23, or a free tip);
- ``"clamped"``: a spring of stiffness 4 EI / l (Eq. 16) between the end bar and its initial
  direction (the ring end clamped to the rigid block; a cantilever root);
- ``"symmetric"``: the node sits on the symmetry plane x = 0 (Eq. 21); the joint couples the
  first bar with its mirror image, so the relative angle is the full structure's. Its stiffness
  is the full joint's, 2 EI / (l + l), and its energy and dissipation are weighted by 1/2 so
  the half model carries exactly half of the full structure (docs/model.md).
"""

from __future__ import annotations

from typing import Literal

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, Float

from .safe import safe_norm

JointKind = Literal["free", "clamped", "symmetric"]
_KINDS = ("free", "clamped", "symmetric")


class Section(eqx.Module):
    """Non-dimensional section properties (Sect. 2 of MODEL.md): each a scalar for a uniform
    chain, or one value per bar for a graded one (MODEL.md section 10)."""

    mass_per_length: Float[Array, ""]
    plastic_moment: Float[Array, ""]  # m_p
    plastic_axial: Float[Array, ""]  # n_p
    bending_rigidity: Float[Array, ""]  # EI / (M_pr R)
    axial_modulus: Float[Array, ""]  # kappa = E b h R / M_pr


def rectangular_section(thickness, width, modulus_ratio, slenderness) -> Section:
    """Section of thickness h/h_r = `thickness`, width b/b_r = `width`, in ring units (Eq. 1)."""
    h, w = thickness, width
    return Section(
        mass_per_length=w * h,
        plastic_moment=w * h**2,
        plastic_axial=4.0 * slenderness * w * h,
        bending_rigidity=modulus_ratio / 3.0 / slenderness * w * h**3,
        axial_modulus=4.0 * modulus_ratio * slenderness * w * h,
    )


class Chain(eqx.Module):
    """One structure of the MS-FD model: node layout, masses, springs and supports.

    **Arguments:**
    - `name`: "ring" or "beam" (used in outputs and messages).
    - `start`, `end`: the boundary joint kinds at node 0 and node n-1 (see module docstring).
    - `reference`: initial node positions, shape (n, 2).
    - `mass`: lumped nodal masses (Eq. 11, 15, 17), shape (n,).
    - `free`: 1.0 where a degree of freedom moves, 0.0 where it is held (Eq. 19-22), (n, 2).
    - `section`: the section properties (uniform chain).
    - `attached_mass`: rigid mass lumped at the last node (the half block g, or Parkes' striker),
      already included in `mass`; kept apart to report the block's kinetic energy.
    """

    name: str = eqx.field(static=True)
    start: JointKind = eqx.field(static=True)
    end: JointKind = eqx.field(static=True)
    reference: Float[Array, "nodes 2"]
    mass: Float[Array, " nodes"]
    free: Float[Array, "nodes 2"]
    section: Section
    attached_mass: Float[Array, ""] = eqx.field(default_factory=lambda: jnp.zeros(()))

    def __check_init__(self):
        if self.start not in _KINDS or self.end not in _KINDS:
            raise ValueError(f"joint kinds must be one of {_KINDS}, got {self.start}, {self.end}")
        if self.end == "symmetric":
            raise ValueError("a symmetric joint is supported at the start of a chain only")

    @property
    def n_nodes(self) -> int:
        return self.reference.shape[0]

    @property
    def n_joints(self) -> int:
        return self.n_nodes - 2 + (self.start != "free") + (self.end != "free")

    @property
    def rest_length(self) -> Float[Array, " bars"]:
        return safe_norm(self.reference[1:] - self.reference[:-1])

    @property
    def joint_nodes(self) -> list[int]:
        """Node index of every joint, in the order of `joint_angles` (static)."""
        n = self.n_nodes
        nodes = list(range(1, n - 1))
        if self.start != "free":
            nodes = [0, *nodes]
        if self.end != "free":
            nodes = [*nodes, n - 1]
        return nodes

    def joint_angles(
        self, x: Float[Array, "nodes 2"], atan2=jnp.arctan2
    ) -> Float[Array, " joints"]:
        """Relative angle of outgoing to incoming bar at every joint (Eq. 7), radians.

        `atan2`: the function used (the batched core passes its vectorisable one, so that its
        reference angles are computed exactly as its angles during the run).
        """
        bars = x[1:] - x[:-1]
        incoming, outgoing = [bars[:-1]], [bars[1:]]
        if self.start == "symmetric":
            # the mirror image of bar 0 in x = 0, traversed towards the symmetry node
            incoming.insert(0, bars[:1] * jnp.array([[1.0, -1.0]]))
            outgoing.insert(0, bars[:1])
        elif self.start == "clamped":
            initial = self.reference[1] - self.reference[0]
            incoming.insert(0, initial[None])
            outgoing.insert(0, bars[:1])
        if self.end == "clamped":
            initial = self.reference[-1] - self.reference[-2]
            incoming.append(bars[-1:])
            outgoing.append(initial[None])
        a = jnp.concatenate(incoming)
        b = jnp.concatenate(outgoing)
        cross = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
        dot = jnp.sum(a * b, axis=-1)
        return atan2(cross, dot)

    def axial_strain(self, x: Float[Array, "nodes 2"]) -> Float[Array, " bars"]:
        """Engineering strain of every bar, (l - l0)/l0 (Eq. 3)."""
        l0 = self.rest_length
        return (safe_norm(x[1:] - x[:-1]) - l0) / l0

    @property
    def graded(self) -> bool:
        """True when the section varies along the chain (one value per bar, static)."""
        return jnp.ndim(self.section.bending_rigidity) > 0

    def joint_stiffness_and_weight(self):
        """Angular spring constants c_K (Eq. 13, 16) and energy weights of every joint.

        Graded (MODEL.md section 10): an interior joint is its two half-bars' flexibilities in
        series, c = 2 / (l_a/EI_a + l_b/EI_b) (Eq. 13 when EI_a = EI_b); a boundary joint
        takes its end bar's section."""
        l0 = self.rest_length
        ei = self.section.bending_rigidity
        if self.graded:
            return self._graded_joints(l0, ei)
        stiffness = [2.0 * ei / (l0[:-1] + l0[1:])]
        weight = [jnp.ones(self.n_nodes - 2)]
        if self.start == "symmetric":
            stiffness.insert(0, (ei / l0[0])[None])
            weight.insert(0, jnp.array([0.5]))
        elif self.start == "clamped":
            stiffness.insert(0, (4.0 * ei / l0[0])[None])
            weight.insert(0, jnp.array([1.0]))
        if self.end == "clamped":
            stiffness.append((4.0 * ei / l0[-1])[None])
            weight.append(jnp.array([1.0]))
        return jnp.concatenate(stiffness), jnp.concatenate(weight)

    def _graded_joints(self, l0, ei):
        # 2 / (l_a/EI_a + l_b/EI_b) written as 2 EI_a / (l_a + l_b EI_a/EI_b): the uniform
        # chain's 2 EI / (l_a + l_b) bit for bit where EI_a == EI_b (an equal profile is
        # the uniform beam to rounding), and the same function (and derivative) elsewhere
        stiffness = [2.0 * ei[:-1] / (l0[:-1] + l0[1:] * (ei[:-1] / ei[1:]))]
        weight = [jnp.ones(self.n_nodes - 2)]
        if self.start == "symmetric":
            stiffness.insert(0, (ei[0] / l0[0])[None])
            weight.insert(0, jnp.array([0.5]))
        elif self.start == "clamped":
            stiffness.insert(0, (4.0 * ei[0] / l0[0])[None])
            weight.insert(0, jnp.array([1.0]))
        if self.end == "clamped":
            stiffness.append((4.0 * ei[-1] / l0[-1])[None])
            weight.append(jnp.array([1.0]))
        return jnp.concatenate(stiffness), jnp.concatenate(weight)

    def joint_plastic_moment(self):
        """Yield moment m_p of every joint: the section's (a scalar) for a uniform chain;
        graded, the weaker adjacent section's, min(m_p,a, m_p,b), and a boundary joint its
        end bar's (MODEL.md section 10)."""
        mp = self.section.plastic_moment
        if not self.graded:
            return mp
        parts = [jnp.minimum(mp[:-1], mp[1:])]
        if self.start != "free":
            parts.insert(0, mp[:1])
        if self.end != "free":
            parts.append(mp[-1:])
        return jnp.concatenate(parts)

    def tributary_length(self) -> Float[Array, " nodes"]:
        """Length of structure each node represents, (l_i + l_j)/2 or l_i/2 at ends (Eq. 11)."""
        l0 = self.rest_length
        pad = jnp.zeros(1)
        return 0.5 * (jnp.concatenate([pad, l0]) + jnp.concatenate([l0, pad]))


def lumped_masses(reference, mass_per_length) -> Float[Array, " nodes"]:
    """Nodal masses mu (l_i + l_j)/2, mu l_i/2 at the ends (Eq. 11, 15); with one mass per
    length per bar (a graded chain), half of each adjacent bar's mass, (mu_i l_i + mu_j l_j)/2."""
    l0 = safe_norm(reference[1:] - reference[:-1])
    pad = jnp.zeros(1)
    if jnp.ndim(mass_per_length) > 0:  # (mu_L l_L + mu_R l_R)/2 as mu_L (l_L + l_R mu_R/mu_L)/2
        left, right = side_values(mass_per_length)  # the uniform formula where mu_L == mu_R
        return (
            0.5 * left * (jnp.concatenate([pad, l0]) + jnp.concatenate([l0, pad]) * (right / left))
        )
    return 0.5 * mass_per_length * (jnp.concatenate([pad, l0]) + jnp.concatenate([l0, pad]))


def side_values(per_bar):
    """Per node, the values of the bar on its left and on its right (an end node's missing
    bar takes its one bar's value): for a graded chain's nodal sums."""
    return (
        jnp.concatenate([per_bar[:1], per_bar]),
        jnp.concatenate([per_bar, per_bar[-1:]]),
    )
