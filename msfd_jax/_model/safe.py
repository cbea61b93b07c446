"""Reverse-mode-safe maths (the double-where pattern, as jax-md's ``safe_mask``)."""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp


def safe_norm(v, axis=-1):
    """Euclidean norm along `axis` with a finite (zero) gradient where the vector vanishes."""
    sq = jnp.sum(v * v, axis=axis)
    positive = sq > 0
    safe_sq = jnp.where(positive, sq, 1.0)
    return jnp.where(positive, jnp.sqrt(safe_sq), 0.0)


# Cephes' atan (S. L. Moshier, atan.c): range reduction to |x| <= tan(pi/8) and a rational
# approximation, <= 2 ulp from libm's atan2 over 2e6 random pairs and <= 1 ulp at joint angles
# (tests/test_engine.py). XLA:CPU calls libm for atan2, one element at a time
# (11 ns each, not vectorised); this is plain arithmetic that XLA vectorises.
_ATAN_P = (
    -8.750608600031904122785e-1,
    -1.615753718733365076637e1,
    -7.500855792314704667340e1,
    -1.228866684490136173410e2,
    -6.485021904942025371773e1,
)
_ATAN_Q = (
    2.485846490142306297962e1,
    1.650270098316988542046e2,
    4.328810604912902668951e2,
    4.853903996359136964868e2,
    1.945506571482613964425e2,
)
_MOREBITS = 6.123233995736765886130e-17


def _atan(x):
    ax = jnp.abs(x)
    big = ax > 2.414213562373095  # tan(3 pi / 8)
    mid = (ax > 0.66) & ~big
    safe = jnp.where(big, ax, 1.0)
    xr = jnp.where(big, -1.0 / safe, jnp.where(mid, (ax - 1.0) / (ax + 1.0), ax))
    y0 = jnp.where(big, math.pi / 2, jnp.where(mid, math.pi / 4, 0.0))
    more = jnp.where(big, _MOREBITS, jnp.where(mid, 0.5 * _MOREBITS, 0.0))
    z = xr * xr
    p, q = _ATAN_P, _ATAN_Q
    num = (((p[0] * z + p[1]) * z + p[2]) * z + p[3]) * z + p[4]
    den = ((((z + q[0]) * z + q[1]) * z + q[2]) * z + q[3]) * z + q[4]
    r = y0 + ((xr * z * num / den + xr) + more)
    return jnp.where(x < 0, -r, r)


@jax.custom_jvp
def atan2(y, x):
    """atan2(y, x) in vectorisable arithmetic (see above); 0 at y = x = 0, like libm.

    Its derivative is the exact one, d atan2 = (x dy - y dx) / (x^2 + y^2) (0 at the origin),
    not the derivative of the rational approximation: a few operations instead of the
    quotient rule through every branch, in each joint of every substep of a `jax.jvp` or
    `jax.grad` of a run; the two agree to rounding (tests/test_engine.py).
    """
    safe_x = jnp.where(x == 0, 1.0, x)
    t = _atan(y / safe_x)
    t = jnp.where(x < 0, jnp.where(y >= 0, t + math.pi, t - math.pi), t)
    axis = jnp.where(y > 0, math.pi / 2, jnp.where(y < 0, -math.pi / 2, 0.0))
    return jnp.where(x == 0, axis, t)


@atan2.defjvp
def _atan2_jvp(primals, tangents):
    y, x = primals
    dy, dx = tangents
    r2 = x * x + y * y
    positive = r2 > 0
    rate = (x * dy - y * dx) / jnp.where(positive, r2, 1.0)
    return atan2(y, x), jnp.where(positive, rate, 0.0)


def unwrap_near(angle, centre):
    """`angle` shifted by the multiple of 2 pi that brings it within pi of `centre`.

    A joint angle is atan2 of its bars, in (-pi, pi]: a joint that folds past pi would jump by
    -2 pi, and its return mapping would book a plastic rotation (and a dissipation m_p 2 pi)
    that never happened. Measured from its plastic rotation, whose elastic
    difference stays below m_p / k << pi, the angle is continuous. Where no shift is needed the
    angle is returned unchanged to the bit (a zero is subtracted), so results that never fold
    that far are unchanged.
    """
    turns = jnp.round((angle - centre) / (2.0 * jnp.pi))
    return angle - (2.0 * jnp.pi) * jax.lax.stop_gradient(turns)
