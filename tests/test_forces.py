"""Internal forces: -dU_e/dx (what the solver uses) equals the paper's Eq. (10) assembly."""

import jax
import jax.numpy as jnp
import numpy as np

import msfd_jax as m
from msfd_jax._model.chain import lumped_masses


def _free_chain(n=7, seed=0):
    """A free-free ring arc (no supports, no boundary joints), slightly perturbed."""
    theta = np.linspace(0.0, np.pi / 2, n)
    ref = jnp.stack([jnp.sin(theta), jnp.cos(theta)], -1)
    section = m.rectangular_section(1.0, 1.0, 500.0, 10.0)
    chain = m.Chain(
        "ring", "free", "free", ref, lumped_masses(ref, 1.0), jnp.ones_like(ref), section
    )
    noise = 5e-5 * jax.random.normal(jax.random.PRNGKey(seed), ref.shape)
    return chain, ref + noise


def _respond(scene, xs):
    zeros = tuple(jnp.zeros(c.n_joints) for c in scene.chains)
    strains = tuple(jnp.zeros(c.n_nodes - 1) for c in scene.chains)
    return m.respond(scene, xs, zeros, strains, ())


def test_forces_match_eq10():
    chain, x = _free_chain()
    scene = m.Scene((chain,), (), (jnp.zeros_like(x),))
    r = _respond(scene, (x,))
    forces = r.forces[0]
    assert float(jnp.sum(r.bending) + jnp.sum(r.axial)) == 0.0  # elastic: no clipping
    # Eq. (10): bar j from I to K, f = (-n cos w - (m_K - m_I)/l sin w, -n sin w + ... cos w);
    # the start node receives -f, the end node +f (Eq. 5); m = c (Delta - Delta0) (Eq. 2, 7)
    stiffness, _ = chain.joint_stiffness_and_weight()
    moment = stiffness * (chain.joint_angles(x) - chain.joint_angles(chain.reference))
    moment = jnp.concatenate([jnp.zeros(1), moment, jnp.zeros(1)])  # free ends
    bars = x[1:] - x[:-1]
    length = jnp.linalg.norm(bars, axis=-1)
    omega = jnp.arctan2(bars[:, 1], bars[:, 0])
    n = chain.section.axial_modulus * (length - chain.rest_length) / chain.rest_length
    shear = (moment[1:] - moment[:-1]) / length
    f = jnp.stack(
        [
            -n * jnp.cos(omega) - shear * jnp.sin(omega),
            -n * jnp.sin(omega) + shear * jnp.cos(omega),
        ],
        -1,
    )
    eq10 = jnp.zeros_like(x).at[:-1].add(-f).at[1:].add(f)
    scale = float(jnp.max(jnp.abs(eq10)))
    assert scale > 1.0  # the configuration is really loaded
    np.testing.assert_allclose(forces, eq10, atol=1e-9 * scale)


def test_forces_are_minus_energy_gradient_by_finite_differences(small_mesh):
    """On the full ring-on-beam scene (boundary joints, contact in compression), elastic."""
    scene = m.ring_on_beam(m.CollisionParams(), small_mesh)
    x0 = tuple(c.reference for c in scene.chains)
    key = jax.random.PRNGKey(1)
    x = tuple(
        xi + 1e-5 * jax.random.normal(k, xi.shape) * c.free
        for xi, c, k in zip(x0, scene.chains, jax.random.split(key, 2), strict=True)
    )
    # push the ring into contact, within the elastic range of the contact springs (since
    # issue 9 they are 10x stiffer: 2e-3 R now yields them, 2e-4 R loads them to 29 of 50)
    x = (x[0].at[:, 1].add(2e-4), x[1])
    zero_sets = tuple(jnp.zeros_like(k.stiffness) for k in scene.contacts)
    rot = tuple(jnp.zeros(c.n_joints) for c in scene.chains)
    strain = tuple(jnp.zeros(c.n_nodes - 1) for c in scene.chains)

    @jax.jit
    def energy(flat):
        xs = unravel(flat)
        return m.respond(scene, xs, rot, strain, zero_sets).elastic

    flat, unravel = jax.flatten_util.ravel_pytree(x)
    r = m.respond(scene, x, rot, strain, zero_sets)
    assert float(jnp.sum(r.contact_force[0])) > 0  # contact is engaged
    assert float(jnp.sum(r.bending) + jnp.sum(r.axial) + jnp.sum(r.contact)) == 0.0  # elastic
    forces, _ = jax.flatten_util.ravel_pytree(r.forces)
    h = 1e-7
    rows = np.random.default_rng(0).choice(flat.size, 24, replace=False)
    for i in rows:
        e = jnp.zeros_like(flat).at[i].set(h)
        fd = -(energy(flat + e) - energy(flat - e)) / (2 * h)
        assert abs(float(fd) - float(forces[i])) < 1e-5 * (1 + abs(float(forces[i])))
