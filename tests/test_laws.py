"""Constitutive laws: return mapping (Eq. 2, 3) and the contact spring (Eq. 18)."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import msfd_jax as m
from msfd_jax._model.laws import ramp_energy

K, FY = 50.0, 2.0  # stiffness and yield value; yield strain q_y = 0.04
QY = FY / K


def _drive(path, smoothing=0.0):
    """Drive one spring along a strain path; return forces, plastic parts, total dissipation."""

    def body(carry, q):
        p, d = carry
        f, p1, dd = m.elastic_plastic(q, p, K, FY, smoothing)
        return (p1, d + dd), (f, p1)

    (p, d), (f, ps) = jax.lax.scan(body, (0.0, 0.0), path)
    return f, ps, d


def test_cycle_dissipates_theory():
    # 0 -> A -> -A in small increments: plastic travel (A - q_y) + (2A - 2 q_y)
    a = 0.3
    path = jnp.concatenate([jnp.linspace(0, a, 400), jnp.linspace(a, -a, 800)])
    f, _, d = _drive(path)
    assert float(d) == pytest.approx(3 * FY * (a - QY), rel=1e-12)
    assert float(jnp.max(jnp.abs(f))) == pytest.approx(FY, rel=1e-12)


def test_plastic_step_lands_on_yield_surface_and_unloading_is_elastic():
    f, p, _ = _drive(jnp.array([0.2, 0.2 - 0.5 * QY, 0.2 - QY]))
    assert float(f[0]) == pytest.approx(FY)
    assert float(p[0]) == pytest.approx(0.2 - QY)
    # unloading by less than 2 q_y: no change of the plastic part, force falls by k dq
    assert float(p[1]) == float(p[0]) and float(p[2]) == float(p[0])
    assert float(f[1]) == pytest.approx(FY - 0.5 * QY * K)
    assert float(f[2]) == pytest.approx(0.0, abs=1e-12)


def test_elastic_below_yield():
    f, p, d = _drive(jnp.linspace(-0.9 * QY, 0.9 * QY, 50))
    assert float(d) == 0.0 and float(jnp.max(jnp.abs(p))) == 0.0
    np.testing.assert_allclose(f, K * jnp.linspace(-0.9 * QY, 0.9 * QY, 50))


def test_yield_smoothing_tends_to_sharp_and_is_differentiable():
    path = jnp.concatenate([jnp.linspace(0, 0.2, 200), jnp.linspace(0.2, -0.1, 200)])
    _, _, sharp = _drive(path)
    errors = [abs(float(_drive(path, s)[2]) - float(sharp)) for s in (0.1, 0.01, 0.001)]
    assert errors[0] > errors[1] > errors[2] and errors[2] < 1e-3 * float(sharp)
    g = jax.grad(lambda q: m.elastic_plastic(q, 0.0, K, FY, 0.05)[0])(QY)
    assert np.isfinite(g) and 0 < g < K


def test_contact_compression_only_with_permanent_set():
    k, fy = 100.0, 1.0
    f, s, d = m.contact_spring(-0.1, 0.0, k, fy)  # apart: no force, no tension
    assert float(f) == 0.0 and float(s) == 0.0 and float(d) == 0.0
    f, s, d = m.contact_spring(0.005, 0.0, k, fy)  # elastic
    assert float(f) == pytest.approx(0.5) and float(s) == 0.0
    f, s, d = m.contact_spring(0.03, 0.0, k, fy)  # yields: set = 0.03 - 0.01
    assert float(f) == pytest.approx(fy) and float(s) == pytest.approx(0.02)
    assert float(d) == pytest.approx(fy * 0.02)
    f2, s2, _ = m.contact_spring(0.025, s, k, fy)  # unloads elastically from the set
    assert float(f2) == pytest.approx(0.5) and float(s2) == float(s)
    f3, _, _ = m.contact_spring(0.015, s, k, fy)  # below the set: separated
    assert float(f3) == 0.0


def test_contact_smoothing_is_c1_and_converges():
    s = jnp.linspace(-0.02, 0.05, 2001)
    for w in (0.0, 0.01):
        r = m.ramp(s, w)
        e = ramp_energy(s, w)
        # the energy's derivative is the force law (finite differences)
        de = np.gradient(np.asarray(e), np.asarray(s))
        np.testing.assert_allclose(de[1:-1], np.asarray(r)[1:-1], atol=2e-5)
    dr = jax.vmap(jax.grad(lambda x: m.ramp(x, 0.01)))(s)
    assert float(jnp.max(jnp.abs(jnp.diff(dr)))) < 0.01  # continuous slope
    gaps = [float(jnp.max(jnp.abs(m.ramp(s, w) - m.ramp(s, 0.0)))) for w in (1e-2, 1e-3)]
    assert gaps[1] == pytest.approx(gaps[0] / 10, rel=1e-6)  # bias = w/2, linear in w


def test_laws_vmap_and_finite_gradients_at_rest():
    q = jnp.zeros(5)
    f, p, d = jax.vmap(m.elastic_plastic, (0, 0, None, None))(q, q, K, FY)
    assert f.shape == (5,) and float(jnp.sum(d)) == 0.0
    for fn in (
        lambda x: m.elastic_plastic(x, 0.0, K, FY)[0],
        lambda x: m.contact_spring(x, 0.0, K, FY)[0],
        lambda x: m.contact_spring(x, 0.0, K, FY, 0.01)[0],
    ):
        assert np.isfinite(float(jax.grad(fn)(0.0)))


@pytest.mark.parametrize("width", [1e-4, 1e-3, 1e-2])
def test_smoothed_contact_yields_at_f_y_with_a_growing_set_when_f_y_over_k_is_below_the_width(
    width,
):
    # the paper section's contact springs (issue 9): k ~ 1.5e5 M_pr/R^2, f_y = 40 M_pr/R, so
    # f_y/k = 2.7e-4 R lies below w/2 for w = 1e-3 and 1e-2: yield on the quadratic onset.
    # Loading monotonically, the force rises continuously to f_y and stays there, the set
    # only grows and the dissipation f_y * d(set) is never negative (it once was: the yield
    # approach assumed the linear branch and moved the set backwards, creating energy)
    k, f_y = 1.5e5, 40.0
    approach = jnp.linspace(0.0, 20.0 * f_y / k + 2.0 * width, 4001)
    force, sets, dissipated = [], [0.0], []
    for delta in approach:
        f, s, d = m.contact_spring(delta, sets[-1], k, f_y, width)
        force.append(float(f))
        sets.append(float(s))
        dissipated.append(float(d))
    force = np.array(force)
    assert force.max() == pytest.approx(f_y, rel=1e-12)
    assert np.all(np.diff(sets) >= 0.0) and sets[-1] > 0.0
    assert min(dissipated) >= 0.0
    assert np.max(np.abs(np.diff(force))) < 0.05 * f_y  # no jump where yielding begins
