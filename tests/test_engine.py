"""The batched core (issue 11): closed-form forces, slots, and batched forward-mode derivatives.

The core's forces are Eq. (10) in closed form (`engine.batch_response`); they must equal autodiff:
the VJP of the kinematics in `_dynamics.respond` and minus the gradient of the elastic energy.
A batch of N collisions must give what N single runs give (`test_sweep.py` checks the sweep's
slot refill against single runs); here a collision's result must not depend on its slot.
"""

import diffrax
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from conftest import SMALL_MESH

import msfd_jax as m
from msfd_jax._batched import engine as _engine
from msfd_jax._batched.flat import flatten
from msfd_jax._reference import dynamics as _dynamics
from msfd_jax._sweeps.queue import solve_batch
from msfd_jax._sweeps.sweep import sweep_step_bound


def _scenes():
    return {
        "ring_on_beam": m.ring_on_beam(m.CollisionParams(), SMALL_MESH),
        "free_beam": m.ring_on_beam(
            m.CollisionParams(thickness_ratio=0.5, axial_constraint=0.0), SMALL_MESH
        ),
        "cantilever": m.cantilever_tip_mass(segments=6),
        "ring_on_plate": m.ring_on_plate(m.CollisionParams(), SMALL_MESH),
    }


def _perturbed(scene, scale, seed=0):
    key = jax.random.PRNGKey(seed)
    return tuple(
        c.reference + scale * jax.random.normal(jax.random.fold_in(key, i), c.reference.shape)
        for i, c in enumerate(scene.chains)
    )


def _both(scene, xs, plastic_scale=0.0):
    flat = flatten(scene)
    key = jax.random.PRNGKey(7)
    rot = tuple(
        plastic_scale * jax.random.normal(jax.random.fold_in(key, i), (c.n_joints,))
        for i, c in enumerate(scene.chains)
    )
    strain = tuple(
        plastic_scale * 1e-2 * jax.random.normal(jax.random.fold_in(key, 9 + i), (c.n_nodes - 1,))
        for i, c in enumerate(scene.chains)
    )
    sets = tuple(jnp.zeros_like(k.stiffness) for k in scene.contacts)
    old = _dynamics.respond(scene, xs, rot, strain, sets)
    x = jnp.concatenate(xs)[..., None]
    new = _engine.batch_response(
        flat, x, jnp.concatenate(rot)[:, None], jnp.concatenate(strain)[:, None],
        tuple(s[..., None] for s in sets),
    )  # fmt: skip
    # the engine's elastic energy is evaluated apart, from the mapped plastic parts
    elastic = _engine.elastic_energy(flat, x, new.plastic_rotation, new.plastic_strain,
                                     new.permanent_set)  # fmt: skip
    return old, new, elastic


@pytest.mark.parametrize("name", list(_scenes()))
@pytest.mark.parametrize("scale", [1e-3, 5e-2])
def test_closed_form_forces_equal_the_autodiff_pullback(name, scale):
    """Against J^T g by jax.vjp, with yielding (scale 5e-2) and plastic parts present."""
    scene = _scenes()[name]
    xs = _perturbed(scene, scale)
    old, new, elastic = _both(scene, xs, plastic_scale=0.05)
    flat, x = flatten(scene), jnp.concatenate(xs)[..., None]
    f_old = jnp.concatenate(old.forces)
    f_new = new.forces[..., 0]
    np.testing.assert_allclose(f_new, f_old, rtol=1e-10, atol=1e-10 * float(jnp.max(abs(f_old))))
    assert float(elastic[0]) == pytest.approx(float(old.elastic), rel=1e-12)
    np.testing.assert_allclose(new.bending[:, 0], old.bending, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(new.axial[:, 0], old.axial, rtol=1e-12, atol=1e-15)
    # the engine's response carries each set's total pair force; the pairs are recomputed
    # from the mapped state (as histories take them), to rounding
    pairs = _engine.pair_forces(flat, x, new.permanent_set)
    for a, total, b in zip(pairs, new.contact_force, old.contact_force, strict=True):
        np.testing.assert_allclose(a[..., 0], b, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(total[0], jnp.sum(b), rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("name", list(_scenes()))
def test_closed_form_forces_are_minus_the_elastic_energy_gradient(name):
    """In the elastic range the nodal forces are -dU/dx, U the engine's own elastic energy."""
    scene = _scenes()[name]
    flat = flatten(scene)
    x0 = jnp.concatenate(_perturbed(scene, 1e-6, seed=3))[..., None]  # below every yield
    nj, nm = flat.joint_stiffness.shape[0], flat.rest_length.shape[0]
    zeros = (
        jnp.zeros((nj, 1)),
        jnp.zeros((nm, 1)),
        tuple(jnp.zeros_like(k) for k in flat.stiffness),
    )

    def energy(x):
        return _engine.elastic_energy(flat, x, *zeros)[0]

    r = _engine.batch_response(flat, x0, *zeros)
    assert float(jnp.sum(r.bending) + jnp.sum(r.axial) + jnp.sum(r.contact)) == 0.0  # elastic
    scale = float(jnp.max(jnp.abs(r.forces)))
    assert scale > 0
    np.testing.assert_allclose(r.forces, -jax.grad(energy)(x0), rtol=1e-8, atol=1e-8 * scale)


def test_a_collision_does_not_depend_on_its_slot():
    """The same collision in every slot of a batch, and next to other collisions: identical."""
    params = m.CollisionParams(
        thickness_ratio=jnp.array([2.5, 1.0, 2.5, 4.0]),
        axial_constraint=jnp.array([1.0, 0.0, 1.0, 1.0]),
        mass_ratio=jnp.full(4, 10.0),
        velocity=jnp.full(4, 0.82),
        modulus_ratio=jnp.full(4, 500.0),
        slenderness=jnp.full(4, 30.0),
        span_ratio=jnp.full(4, 5.0),
        width_ratio=jnp.ones(4),
    )
    out = _batch(params)
    for key in ("beam_bending", "ring_bending", "contact", "steps"):
        assert float(out[key][0]) == float(out[key][2]), key


def _critical(params):
    one = jax.vmap(lambda p: m.critical_step(m.ring_on_beam(p, SMALL_MESH)))
    return jax.jit(one)(params)


SETTINGS = m.Settings(t_max=0.3, history_points=2, shape_times=(), t_min=0.3)


def _batch(params, adjoint=None):
    dt_crit = _critical(params)
    bound = sweep_step_bound(np.asarray(dt_crit), SETTINGS)
    return jax.jit(
        lambda p: solve_batch(p, SMALL_MESH, SETTINGS, dt_crit, max_steps=bound, adjoint=adjoint)
    )(params)


def test_batched_forward_mode_gives_every_collision_its_own_derivative():
    """One jvp of a batch of 3 (tangent ones) gives each collision its own derivative: the
    middle collision's reverse-mode row (a vjp) has the tangent's entry on the diagonal and
    exact zeros off it (independent collisions); and central differences where the response
    is smooth at the difference's scale (h_b/h_r = 2; on this coarse mesh the thinner and
    thicker beams' contact makes it rough below eps ~ 1e-4, measured). The differences are
    of the jvp program's own primal values (one program fewer to compile)."""
    h = jnp.array([1.0, 2.0, 3.0])
    base = dict(
        axial_constraint=jnp.ones(3), mass_ratio=jnp.full(3, 10.0), velocity=jnp.full(3, 0.82),
        modulus_ratio=jnp.full(3, 500.0), slenderness=jnp.full(3, 30.0),
        span_ratio=jnp.full(3, 5.0), width_ratio=jnp.ones(3),
    )  # fmt: skip
    dt_crit = _critical(m.CollisionParams(thickness_ratio=h, **base))
    bound = sweep_step_bound(np.asarray(dt_crit), SETTINGS)

    def beam_share(thickness, adjoint):
        p = m.CollisionParams(thickness_ratio=thickness, **base)
        out = solve_batch(
            p, SMALL_MESH, SETTINGS, dt_crit, max_steps=bound, contact_smoothing=1e-2,
            yield_smoothing=0.1, adjoint=adjoint,
        )  # fmt: skip
        return out["beam_bending"] + out["beam_axial"]

    forward = diffrax.ForwardMode()
    jvp = jax.jit(lambda x, t: jax.jvp(lambda y: beam_share(y, forward), (x,), (t,)))
    ones = jnp.ones(3)
    value, tangent = jvp(h, ones)
    middle = jnp.array([0.0, 1.0, 0.0])
    stored = diffrax.RecursiveCheckpointAdjoint(int(bound))  # every step: as `optimise.design`
    row = jax.jit(lambda x: jax.vjp(lambda y: beam_share(y, stored), x)[1](middle)[0])(h)
    assert float(row[1]) == pytest.approx(float(tangent[1]), rel=1e-8)
    assert float(row[0]) == 0.0 and float(row[2]) == 0.0
    eps = 1e-6
    e = jnp.array([0.0, eps, 0.0])
    fd = (jvp(h + e, ones)[0][1] - jvp(h - e, ones)[0][1]) / (2 * eps)
    assert float(tangent[1]) == pytest.approx(float(fd), rel=1e-3)
    assert np.all(np.asarray(value) > 0)


def test_vectorisable_atan2_is_within_two_ulp_of_libm():
    from msfd_jax._model.safe import atan2

    rng = np.random.default_rng(0)
    y = rng.normal(size=200_000) * 10.0 ** rng.uniform(-8, 3, 200_000)
    x = rng.normal(size=200_000)
    y = np.concatenate([y, [0.0, 1.0, -1.0, 0.0, 2.0, -2.0]])
    x = np.concatenate([x, [0.0, 0.0, 0.0, -1.0, -3.0, -3.0]])
    ref = np.arctan2(y, x)
    got = np.asarray(jax.jit(atan2)(jnp.asarray(y), jnp.asarray(x)))
    ulp = np.abs(got - ref) / np.spacing(np.maximum(np.abs(ref), np.finfo(float).tiny))
    assert ulp.max() <= 2.0


def test_atan2_derivative_is_the_exact_one():
    """`_safe.atan2`'s jvp and gradient are (x dy - y dx) / (x^2 + y^2), as jnp.arctan2's
    (libm's derivative), over many magnitudes, and finite (0) at 0. The bound is rounding's:
    a few ulp of the terms (|x dy| + |y dx|) / r^2, since x dy - y dx can cancel (the two
    group the products differently: 1.5e-14 relative was seen at such a point)."""
    from msfd_jax._model.safe import atan2

    rng = np.random.default_rng(1)
    y = jnp.asarray(rng.normal(size=2000) * 10.0 ** rng.uniform(-6, 3, 2000))
    x = jnp.asarray(rng.normal(size=2000))
    dy, dx = jnp.asarray(rng.normal(size=2000)), jnp.asarray(rng.normal(size=2000))
    _, got = jax.jvp(atan2, (y, x), (dy, dx))
    _, ref = jax.jvp(jnp.arctan2, (y, x), (dy, dx))
    terms = (jnp.abs(x * dy) + jnp.abs(y * dx)) / (x * x + y * y)
    assert bool(jnp.all(jnp.abs(got - ref) <= 8 * np.finfo(float).eps * terms))
    gy, gx = jax.grad(lambda a, b: jnp.sum(atan2(a, b)), argnums=(0, 1))(y, x)
    ry, rx = jax.grad(lambda a, b: jnp.sum(jnp.arctan2(a, b)), argnums=(0, 1))(y, x)
    np.testing.assert_allclose(gy, ry, rtol=1e-14, atol=0)
    np.testing.assert_allclose(gx, rx, rtol=1e-14, atol=0)
    zero = jax.grad(lambda a: atan2(a, 0.0 * a))(0.0)
    assert float(zero) == 0.0
