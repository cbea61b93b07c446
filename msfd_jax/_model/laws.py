"""Elastic-perfectly plastic laws as return mappings, each written for one spring.

All are pure functions ``law(deformation, plastic, ...) -> (force, new_plastic, dissipated)``,
vmapped (or broadcast) outside. They are the discrete form of Eq. (2), (3) and (18): an elastic
trial from total deformation minus the plastic part, clipped to the yield value, the plastic
part absorbing the excess.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp


def _excess(overshoot, scale, smoothing):
    """max(overshoot, 0), or its softplus with width smoothing*scale (0 gives the sharp law).

    ``smoothing=None`` is the sharp law known ahead (a static choice: no softplus compiled).
    """
    if smoothing is None:
        return jnp.maximum(overshoot, 0.0)
    width = smoothing * scale
    safe_width = jnp.where(width > 0, width, 1.0)
    soft = safe_width * jax.nn.softplus(overshoot / safe_width)
    return jnp.where(width > 0, soft, jnp.maximum(overshoot, 0.0))


def elastic_plastic(deformation, plastic, stiffness, yield_force, smoothing=0.0):
    """Return mapping of a symmetric elastic-perfectly plastic spring (Eq. 2, 3).

    trial = k (q - q_p); if |trial| > f_y the plastic part grows by (|trial| - f_y)/k and the
    force is +-f_y. With ``smoothing = s > 0`` the excess is softplus((|trial| - f_y)/(s f_y))
    times s f_y: smooth in the inputs, slightly more plastic flow (a bias measured in docs).

    **Arguments:**
    - `deformation`: total generalized strain q (relative angle change, or axial strain).
    - `plastic`: plastic part q_p before the step.
    - `stiffness`: k > 0.  `yield_force`: f_y > 0 (m_p or n_p).
    - `smoothing`: yield smoothing width as a fraction of f_y (0 = sharp).

    **Returns:** (force, new_plastic, dissipated) with dissipated = |force| |delta q_p| >= 0.
    """
    trial = stiffness * (deformation - plastic)
    excess = _excess(jnp.abs(trial) - yield_force, yield_force, smoothing)
    direction = jnp.sign(trial)
    force = trial - direction * excess
    increment = excess / stiffness
    return force, plastic + direction * increment, jnp.abs(force) * increment


def ramp(s, width):
    """C1 ramp max(s, 0) with a quadratic onset over [0, width]; ``width = 0`` is the sharp ramp.

    r(s) = 0 (s <= 0), s^2/(2w) (0 < s < w), s - w/2 (s >= w). ``width=None``: sharp, static.
    """
    if width is None:
        return jnp.maximum(s, 0.0)
    safe_w = jnp.where(width > 0, width, 1.0)
    quadratic = jnp.where(s > 0, s, 0.0) ** 2 / (2.0 * safe_w)
    smooth = jnp.where(s >= width, s - 0.5 * width, quadratic)
    return jnp.where(width > 0, smooth, jnp.maximum(s, 0.0))


def ramp_energy(s, width):
    """Integral of `ramp` from -inf to s (so the contact energy is k * ramp_energy)."""
    if width is None:
        return 0.5 * jnp.where(s > 0, s, 0.0) ** 2
    safe_w = jnp.where(width > 0, width, 1.0)
    pos = jnp.where(s > 0, s, 0.0)
    cubic = pos**3 / (6.0 * safe_w)
    upper = 0.5 * s**2 - 0.5 * width * s + width**2 / 6.0
    smooth = jnp.where(s >= width, upper, cubic)
    return jnp.where(width > 0, smooth, 0.5 * pos**2)


def _yield_approach(elastic_limit, width):
    """The elastic approach s at which r(s) = f_y/k (`elastic_limit`), the inverse of `ramp`.

    On the linear branch (f_y/k >= w/2) s = f_y/k + w/2; on the quadratic onset
    (f_y/k < w/2) s = sqrt(2 w f_y/k). The second case is not an edge case: with the contact
    stiffness of Eq. 18 (`contact.block_stiffness`) f_y/k is 2-4e-4 R on the paper's section,
    below the smoothing widths that tuning starts from (w = 1e-2), and taking the linear branch
    there moved the permanent set backwards (negative contact dissipation, energy created).
    """
    if width is None:
        return elastic_limit
    linear = elastic_limit + 0.5 * width
    # double where: no NaN gradient from the sqrt where the quadratic branch is not taken
    on_onset = elastic_limit < 0.5 * width
    safe = jnp.where(on_onset, 2.0 * width * elastic_limit, 1.0)
    return jnp.where(on_onset, jnp.sqrt(safe), linear)


def contact_spring(approach, permanent_set, stiffness, yield_force, width=0.0):
    """Compression-only elastic-perfectly plastic contact spring with permanent set (Eq. 18).

    Elastic approach s = delta - delta_p; force k r(s) (r the smoothed ramp of width `width`,
    the sharp law at 0); when the force would pass f_y the permanent set grows so that it equals
    f_y; no force once delta falls below the set (separation, Fig. 9). ``width=None`` is the
    sharp law chosen statically (equal to ``width=0``, without the ramp's branches).

    **Returns:** (force >= 0, new_permanent_set, dissipated).
    """
    s = approach - permanent_set
    trial = stiffness * ramp(s, width)
    yielding = trial > yield_force
    s_yield = _yield_approach(yield_force / stiffness, width)
    new_set = jnp.where(yielding, approach - s_yield, permanent_set)
    force = jnp.where(yielding, yield_force, trial)
    return force, new_set, yield_force * (new_set - permanent_set)


def capped_contact_spring(approach, permanent_set, stiffness, yield_force, width, cap):
    """`contact_spring` whose permanent set stops at `cap` (a collapse contact's gap: a block
    squashed to no thickness, not through itself); past it the spring is elastic. The
    paper's contact never gets there; a collapse drives a node through a yielding block
    without it. **Returns:** (force, new_permanent_set, dissipated)."""
    f, new_set, dc = contact_spring(approach, permanent_set, stiffness, yield_force, width)
    capped = new_set > cap
    new_set = jnp.where(capped, cap, new_set)
    f = jnp.where(capped, stiffness * ramp(approach - cap, width), f)
    dc = jnp.where(capped, yield_force * (cap - permanent_set), dc)
    return f, new_set, dc


def contact_energy(approach, permanent_set, stiffness, width=0.0):
    """Elastic energy stored in a contact spring, k * ramp_energy(delta - delta_p)."""
    return stiffness * ramp_energy(approach - permanent_set, width)
