"""The model's state, its generalized deformations and the stability limit of its step.

Both pipelines share these: the per-chain reference (`_reference.dynamics`) differentiates
`deformations` for its forces, the batched core (`_batched`) returns its final state as a
`State`, and both take their step from `critical_step`.
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.flatten_util
import jax.numpy as jnp
from jaxtyping import Array, Float

from .scene import Scene


class State(eqx.Module):
    """What changes during a run. Tuples are per chain / per contact of the scene.

    Dissipated energies are accumulated per chain (bending, axial) and per contact set, in
    units of M_pr. ``elastic`` is the elastic energy at ``x``; ``reaction`` the drive force.
    """

    x: tuple[Float[Array, "nodes 2"], ...]
    v: tuple[Float[Array, "nodes 2"], ...]
    a: tuple[Float[Array, "nodes 2"], ...]
    plastic_rotation: tuple[Float[Array, " joints"], ...]
    plastic_strain: tuple[Float[Array, " bars"], ...]
    permanent_set: tuple[Array, ...]
    contact_force: tuple[Array, ...]
    bending: Float[Array, " chains"]
    axial: Float[Array, " chains"]
    contact: Float[Array, " contacts"]
    elastic: Float[Array, ""]
    reaction: Float[Array, ""]
    drive_work: Float[Array, ""]
    last_dissipation: Float[Array, ""]
    dissipation_mark: Float[Array, ""]
    last_contact: Float[Array, ""]

    @property
    def dissipated(self):
        return jnp.sum(self.bending) + jnp.sum(self.axial) + jnp.sum(self.contact)

    def kinetic(self, scene: Scene):
        """Kinetic energy per chain, sum of m v^2 / 2 over moving degrees of freedom."""
        return jnp.stack(
            [
                0.5 * jnp.sum(c.mass[:, None] * v**2)
                for c, v in zip(scene.chains, self.v, strict=True)
            ]
        )


def deformations(scene: Scene, xs):
    """Generalized deformations: per chain (joint angle change, bar strain); contact approaches."""
    chains = tuple(
        (c.joint_angles(x) - c.joint_angles(c.reference), c.axial_strain(x))
        for c, x in zip(scene.chains, xs, strict=True)
    )
    contacts = tuple(k.approach(xs) for k in scene.contacts)
    return chains, contacts


def _elastic_energy(scene: Scene, xs):
    """Elastic energy with no plastic deformation (for the stiffness at the reference state)."""
    (q_chains, _) = deformations(scene, xs)
    total = 0.0
    for c, (angle, strain) in zip(scene.chains, q_chains, strict=True):
        stiffness, weight = c.joint_stiffness_and_weight()
        total = total + 0.5 * jnp.sum(weight * stiffness * angle**2)
        total = total + 0.5 * jnp.sum(c.rest_length * c.section.axial_modulus * strain**2)
    return total


def max_frequency(scene: Scene):
    """Upper estimate of the highest circular frequency omega_max of the scene.

    Structure: exact, the largest eigenvalue of M^{-1/2} K M^{-1/2} over the moving degrees of
    freedom at the reference state (K the Hessian of the elastic energy). Contact: a Gershgorin
    bound with every node loading as many contact springs as can be closer than the gap.
    The two are added (lambda_max(A + B) <= lambda_max(A) + lambda_max(B)).
    """
    xs = tuple(c.reference for c in scene.chains)
    flat, unravel = jax.flatten_util.ravel_pytree(xs)
    hessian = jax.hessian(lambda z: _elastic_energy(scene, unravel(z)))(flat)
    mass = jnp.concatenate([jnp.repeat(c.mass, 2) for c in scene.chains])
    free = jnp.concatenate([c.free.reshape(-1) for c in scene.chains])
    scale = free / jnp.sqrt(mass)
    k_scaled = hessian * scale[:, None] * scale[None, :]
    lam = jnp.max(jnp.linalg.eigvalsh(k_scaled))
    masses = tuple(c.mass for c in scene.chains)
    for k in scene.contacts:
        m_a, m_b = k.masses(masses)
        n_a, n_b = k.max_partners()
        k_max = jnp.max(k.stiffness)
        lam = lam + k_max * (n_a / jnp.min(m_a) + n_b / jnp.min(m_b))
    return jnp.sqrt(lam)


def critical_step(scene: Scene):
    """Stability limit of the central-difference step, dt_crit = 2 / omega_max."""
    return 2.0 / max_frequency(scene)
