"""State, internal forces and the time step of the MS-FD model.

Internal forces are -dU_e/dx with the plastic parts held (MODEL.md Sect. 5): the generalized
deformations q(x) (joint angles, bar strains, contact approaches) are mapped to generalized
forces g by the return mappings, and the nodal forces are -J^T g, one VJP of the kinematics.
This is Eq. (10) exactly (tests/test_forces.py checks both against each other).
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.flatten_util
import jax.numpy as jnp
from jaxtyping import Array

from .._model.collapse import COLLAPSE_TYPES
from .._model.laws import capped_contact_spring, contact_energy, contact_spring, elastic_plastic
from .._model.safe import unwrap_near
from .._model.scene import Scene
from .._model.state import State, deformations


class Response(eqx.Module):
    """Result of evaluating the laws at one configuration."""

    forces: tuple[Array, ...]
    plastic_rotation: tuple[Array, ...]
    plastic_strain: tuple[Array, ...]
    permanent_set: tuple[Array, ...]
    contact_force: tuple[Array, ...]
    bending: Array
    axial: Array
    contact: Array
    elastic: Array


def respond(scene: Scene, xs, rotation_p, strain_p, permanent_set) -> Response:
    """Return-map every spring at configuration `xs`, then assemble nodal forces -J^T g."""
    (q_chains, q_contacts), pullback = jax.vjp(lambda x: deformations(scene, x), xs)
    g_chains, new_rot, new_strain, bend, axial, elastic = [], [], [], [], [], 0.0
    for c, (angle, strain), rp, sp in zip(
        scene.chains, q_chains, rotation_p, strain_p, strict=True
    ):
        stiffness, weight = c.joint_stiffness_and_weight()
        s = c.section
        angle = unwrap_near(angle, rp)  # a fold past pi: no 2 pi jump
        m, rp1, d_rot = elastic_plastic(
            angle, rp, stiffness, c.joint_plastic_moment(), scene.yield_smoothing
        )
        n, sp1, d_ax = elastic_plastic(
            strain, sp, s.axial_modulus, s.plastic_axial, scene.yield_smoothing
        )
        l0 = c.rest_length
        g_chains.append((weight * m, n * l0))
        new_rot.append(rp1)
        new_strain.append(sp1)
        bend.append(jnp.sum(weight * d_rot))
        axial.append(jnp.sum(l0 * d_ax))
        elastic = elastic + 0.5 * jnp.sum(weight * m**2 / stiffness)
        elastic = elastic + 0.5 * jnp.sum(l0 * n**2 / s.axial_modulus)
    g_contacts, new_set, contact = [], [], []
    for k, delta, ps in zip(scene.contacts, q_contacts, permanent_set, strict=True):
        if isinstance(k, COLLAPSE_TYPES):  # their sets stop at the gap (a block squashed flat)
            f, ps1, d_c = capped_contact_spring(
                delta, ps, k.stiffness, k.yield_force, scene.contact_smoothing, k.set_cap()
            )
        else:
            f, ps1, d_c = contact_spring(
                delta, ps, k.stiffness, k.yield_force, scene.contact_smoothing
            )
        g_contacts.append(f)
        new_set.append(ps1)
        contact.append(jnp.sum(d_c))
        elastic = elastic + jnp.sum(
            contact_energy(delta, ps1, k.stiffness, scene.contact_smoothing)
        )
    # U_e = sum g . dq  =>  f = -J^T g ; contact: U = k R(delta - set), dU/ddelta = f
    (forces,) = pullback((tuple(g_chains), tuple(g_contacts)))
    forces = tuple(-f for f in forces)
    return Response(
        forces,
        tuple(new_rot),
        tuple(new_strain),
        tuple(new_set),
        tuple(g_contacts),  # the pair forces are the contact generalized forces
        jnp.stack(bend),
        jnp.stack(axial),
        jnp.stack(contact) if contact else jnp.zeros(1),
        jnp.asarray(elastic),
    )


def _accelerations(scene: Scene, forces):
    return tuple(f / c.mass[:, None] * c.free for c, f in zip(scene.chains, forces, strict=True))


def _reaction(scene: Scene, forces):
    d = scene.drive
    if d is None:
        return jnp.zeros(())
    return -forces[d.chain][d.node, d.axis]


def initial_state(scene: Scene) -> State:
    """State at tau = 0: reference positions, initial velocities, no plastic deformation."""
    xs = tuple(c.reference for c in scene.chains)
    rot = tuple(jnp.zeros(c.n_joints) for c in scene.chains)
    strain = tuple(jnp.zeros(c.n_nodes - 1) for c in scene.chains)
    sets = tuple(jnp.zeros_like(k.stiffness) for k in scene.contacts)
    r = respond(scene, xs, rot, strain, sets)
    z = jnp.zeros(())
    return State(
        xs,
        tuple(
            v * c.free + _drive_velocity(scene, i)
            for i, (c, v) in enumerate(zip(scene.chains, scene.initial_velocity, strict=True))
        ),
        _accelerations(scene, r.forces),
        r.plastic_rotation,
        r.plastic_strain,
        r.permanent_set,
        r.contact_force,
        r.bending,
        r.axial,
        r.contact,
        r.elastic,
        _reaction(scene, r.forces),
        z,
        z,
        z,
        z,
    )


def _drive_velocity(scene: Scene, chain: int):
    c = scene.chains[chain]
    d = scene.drive
    if d is None or d.chain != chain:
        return jnp.zeros_like(c.reference)
    return jnp.zeros_like(c.reference).at[d.node, d.axis].set(d.velocity)


def verlet_step(scene: Scene, state: State, t1, dt, settle_tolerance) -> State:
    """One velocity-Verlet (central difference) step with return mapping at the new positions.

    v_h = v_0 + dt/2 a_0;  x_1 = x_0 + dt v_h;  return-map at x_1;  v_1 = v_h + dt/2 a_1.
    Held degrees of freedom have zero acceleration and keep their (zero or driven) velocity.
    ``last_dissipation`` is moved to t1 whenever the dissipation has grown by more than
    ``settle_tolerance`` since the last mark, and ``last_contact`` whenever a contact spring
    carries force (the stopping rule, docs/model.md).
    """
    v_half = jax.tree_util.tree_map(lambda v, a: v + 0.5 * dt * a, state.v, state.a)
    xs = jax.tree_util.tree_map(lambda x, v: x + dt * v, state.x, v_half)
    r = respond(scene, xs, state.plastic_rotation, state.plastic_strain, state.permanent_set)
    a1 = _accelerations(scene, r.forces)
    v1 = jax.tree_util.tree_map(lambda v, a: v + 0.5 * dt * a, v_half, a1)
    reaction = _reaction(scene, r.forces)
    drive_work = state.drive_work
    if scene.drive is not None:
        drive_work = drive_work + 0.5 * (state.reaction + reaction) * scene.drive.velocity * dt
    bending = state.bending + r.bending
    axial = state.axial + r.axial
    contact = state.contact + r.contact
    total = jnp.sum(bending) + jnp.sum(axial) + jnp.sum(contact)
    moved = total - state.dissipation_mark > settle_tolerance
    touching = sum((jnp.any(f > 0) for f in r.contact_force), jnp.asarray(False))
    return State(
        xs,
        v1,
        a1,
        r.plastic_rotation,
        r.plastic_strain,
        r.permanent_set,
        r.contact_force,
        bending,
        axial,
        contact,
        r.elastic,
        reaction,
        drive_work,
        jnp.where(moved, t1, state.last_dissipation),
        jnp.where(moved, total, state.dissipation_mark),
        jnp.where(touching, t1, state.last_contact),
    )
