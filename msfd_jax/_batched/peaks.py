"""Running peaks of a ring-on-beam collision, kept by the engine at every Verlet step.

A crash test's design quantities are peaks and integrals of the motion (the beam's largest
deflection, the largest contact force, the impulse...). Read from saved history samples they
depend on the sampling: a force spike between two samples is missed, and a run saved on a
coarse grid reports a lower peak. The engine therefore updates them inside the time loop, at
every step, from the state it has just computed (`update`), for the scenes that have a ring
and a beam (`flat.Tracked`); other scenes carry an empty tuple and compile nothing for it.

All values are non-dimensional and refer to the half model (`_model.si` maps them to SI and to the
whole structure). With y the impact direction's axis:

- ``peak_deflection``: max |y_O - y_O(0)|, the beam's mid-span node O (units of R);
- ``peak_contact_force``: max of the total ring-on-beam contact force (units of M_pr / R);
- ``contact_impulse``: sum of that force x h over the steps (units of M_pr T / R);
- ``contact_time``: sum of h over the steps that end with the contact closed (units of T);
- ``peak_block_travel``: max |y_G - y_G(0)|, the block node G (units of R);
- ``peak_ring_crush``: max of |S(0) G(0)| - |S G|, the shortening of the distance from the
  ring's front node S to the block: the car's deformation (units of R);
- ``peak_block_deceleration``: max |a_y| of the block node (units of R / T^2).

Both force sums use the force at the step's new positions (the one the velocity update
uses), so impulse / contact time (the mean force while the contact is closed) never exceeds
the peak force.
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

from .flat import FlatScene

PEAK_KEYS = (
    "peak_deflection",
    "peak_contact_force",
    "contact_impulse",
    "contact_time",
    "peak_block_travel",
    "peak_ring_crush",
    "peak_block_deceleration",
)
_IS_SUM = np.asarray([k in ("contact_impulse", "contact_time") for k in PEAK_KEYS])


def initial(flat: FlatScene):
    """Zero peaks of shape (len(PEAK_KEYS), B), or () for a scene that tracks none."""
    if flat.tracked is None:
        return ()
    return jnp.zeros((len(PEAK_KEYS), flat.batch))


def _distance(x, i: int, j: int):
    return jnp.sqrt(jnp.sum((x[i] - x[j]) ** 2, axis=0))


def current(flat: FlatScene, x, a, contact_force, h):
    """This step's values in `PEAK_KEYS` order, (P, B); `contact_force` the total (B,)."""
    o, s, g = flat.tracked
    x0 = flat.x0
    return jnp.stack(
        [
            jnp.abs(x[o, 1] - x0[o, 1]),
            contact_force,
            contact_force * h,
            jnp.where(contact_force > 0, h, 0.0),
            jnp.abs(x[g, 1] - x0[g, 1]),
            _distance(x0, s, g) - _distance(x, s, g),
            jnp.abs(a[g, 1]),
        ]
    )


def update(flat: FlatScene, peaks, x, a, contact_force, h):
    """`peaks` after one step: running maxima, and running sums for impulse and time."""
    if flat.tracked is None:
        return peaks
    now = current(flat, x, a, contact_force, h)
    return jnp.where(_IS_SUM[:, None], peaks + now, jnp.maximum(peaks, now))


def as_dict(peaks) -> dict:
    """{key: (..., ) array} from a peaks array whose first axis (after any batch axes moved
    first) is `PEAK_KEYS`; {} for a scene that tracks none."""
    if isinstance(peaks, tuple):
        return {}
    return {k: peaks[..., i] for i, k in enumerate(PEAK_KEYS)}
