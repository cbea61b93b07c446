"""The integration methods of the work-precision study and what they measure.

`YoshidaVerlet` (fourth-order composition of the Verlet step), the elastic-viscoplastic
(Perzyna) rate form `viscoplastic_field` for diffrax's Runge-Kutta solvers, and the energy
fractions of a final state.
"""

from __future__ import annotations

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp

from ..._collision.run import FRACTION_KEYS
from ..._model.laws import ramp, ramp_energy
from ..._model.scene import Scene
from ..._model.state import State
from ..._reference.dynamics import verlet_step
from ..._reference.verlet import VelocityVerlet

DISSIPATED = FRACTION_KEYS[:5]  # beam bending/axial, ring bending/axial, contact
LUMPED_KEYS = (*DISSIPATED, "kinetic+elastic")


# ----------------------------------------------------------------------------------------------
# Fourth-order composition of the Verlet step


_W1 = 1.0 / (2.0 - 2.0 ** (1.0 / 3.0))
_W0 = 1.0 - 2.0 * _W1


class YoshidaVerlet(VelocityVerlet):
    """Yoshida's (Forest-Ruth) 4th-order composition of the Verlet step with return mapping.

    Each step of length h is three Verlet steps of w1 h, w0 h, w1 h (w0 = 1 - 2 w1 < 0, a step
    backwards in time). Fourth order for a smooth elastic problem; the return mapping and the
    contact ramp are not smooth (and the backward step is not the inverse of a plastic
    forward step), so the order is not kept once anything yields. Stable for
    omega h < ~1.57 at three force evaluations per step, against 2 at one for Verlet.
    """

    def order(self, terms):
        return 4

    def step(self, terms, t0, t1, y0, args, solver_state, made_jump):
        del solver_state, made_jump, terms
        scene, settle_tolerance = args
        h = (t1 - t0) / self.substeps

        def substep(i, y):
            t = t0 + i * h
            y = verlet_step(scene, y, t + _W1 * h, _W1 * h, settle_tolerance)
            y = verlet_step(scene, y, t + (_W1 + _W0) * h, _W0 * h, settle_tolerance)
            return verlet_step(scene, y, t + h, _W1 * h, settle_tolerance)

        y1 = jax.lax.fori_loop(0, self.substeps, substep, y0)
        return y1, None, dict(y0=y0, y1=y1), None, diffrax.RESULTS.successful


# ----------------------------------------------------------------------------------------------
# Rate form: elastic-viscoplastic (Perzyna) regularisation of the laws


class Viscoplastic(eqx.Module):
    """ODE state of the rate form: positions, velocities, plastic parts, dissipated energies."""

    x: tuple[jax.Array, ...]
    v: tuple[jax.Array, ...]
    plastic_rotation: tuple[jax.Array, ...]
    plastic_strain: tuple[jax.Array, ...]
    permanent_set: tuple[jax.Array, ...]
    bending: jax.Array
    axial: jax.Array
    contact: jax.Array


def viscoplastic_state(state: State) -> Viscoplastic:
    """The rate-form state holding the same positions, velocities and history as `state`."""
    return Viscoplastic(
        state.x,
        state.v,
        state.plastic_rotation,
        state.plastic_strain,
        state.permanent_set,
        state.bending,
        state.axial,
        state.contact,
    )


def _overstress_rate(force, yield_force, stiffness, eta):
    """Perzyna flow: dq_p/dt = sign(f) <|f| - f_y> / (k eta); dissipation rate f dq_p/dt."""
    rate = jnp.sign(force) * jnp.maximum(jnp.abs(force) - yield_force, 0.0) / (stiffness * eta)
    return rate, force * rate


def _viscoplastic_response(scene: Scene, y: Viscoplastic, eta):
    """Generalized forces (no clipping: the overstress relaxes at rate 1/eta), flow rates."""
    from ..._model.state import deformations

    (q_chains, q_contacts), pullback = jax.vjp(lambda x: deformations(scene, x), y.x)
    g_chains, rot_rates, strain_rates, bend, axial, elastic = [], [], [], [], [], 0.0
    for c, (angle, strain), rp, sp in zip(
        scene.chains, q_chains, y.plastic_rotation, y.plastic_strain, strict=True
    ):
        stiffness, weight = c.joint_stiffness_and_weight()
        s = c.section
        moment = stiffness * (angle - rp)
        normal = s.axial_modulus * (strain - sp)
        rot_rate, bend_power = _overstress_rate(moment, c.joint_plastic_moment(), stiffness, eta)
        strain_rate, axial_power = _overstress_rate(normal, s.plastic_axial, s.axial_modulus, eta)
        l0 = c.rest_length
        g_chains.append((weight * moment, normal * l0))
        rot_rates.append(rot_rate)
        strain_rates.append(strain_rate)
        bend.append(jnp.sum(weight * bend_power))
        axial.append(jnp.sum(l0 * axial_power))
        elastic = elastic + 0.5 * jnp.sum(weight * moment**2 / stiffness)
        elastic = elastic + 0.5 * jnp.sum(l0 * normal**2 / s.axial_modulus)
    g_contacts, set_rates, contact = [], [], []
    width = scene.contact_smoothing
    for k, delta, ps in zip(scene.contacts, q_contacts, y.permanent_set, strict=True):
        force = k.stiffness * ramp(delta - ps, width)
        over = jnp.maximum(force - k.yield_force, 0.0)
        rate = over / (k.stiffness * eta)
        g_contacts.append(force)
        set_rates.append(rate)
        contact.append(jnp.sum(force * rate))
        elastic = elastic + jnp.sum(k.stiffness * ramp_energy(delta - ps, width))
    (forces,) = pullback((tuple(g_chains), tuple(g_contacts)))
    accelerations = tuple(
        -f / c.mass[:, None] * c.free for c, f in zip(scene.chains, forces, strict=True)
    )
    rates = (
        tuple(rot_rates),
        tuple(strain_rates),
        tuple(set_rates),
        jnp.stack(bend),
        jnp.stack(axial),
        jnp.stack(contact) if contact else jnp.zeros(1),
    )
    return accelerations, rates, jnp.asarray(elastic)


def viscoplastic_field(t, y: Viscoplastic, args) -> Viscoplastic:
    """dy/dt of the elastic-viscoplastic rate form; ``args = (scene, eta)``.

    dx/dt = v, dv/dt = M^-1 f(x, plastic parts) (the elastic forces -dU_e/dx with the plastic
    parts held, as in the Verlet step), d(plastic part)/dt = <overstress> / (stiffness eta)
    for every joint, bar and contact spring, d(dissipated)/dt = force x plastic rate.
    K + U_e + D is conserved exactly; as eta -> 0 the overstress vanishes and the solution
    tends to the rate-independent one of the return mapping. ``eta`` is a relaxation time
    (non-dimensional), not a property of the paper's material: its bias is measured.
    The scene's drive (if any) is not modelled here: ring_on_beam has none.
    """
    scene, eta = args
    accelerations, (rot, strain, sets, bend, axial, contact), _ = _viscoplastic_response(
        scene, y, eta
    )
    return Viscoplastic(y.v, accelerations, rot, strain, sets, bend, axial, contact)


def viscoplastic_elastic(scene: Scene, y: Viscoplastic):
    """Elastic energy U_e of a rate-form state (units of M_pr)."""
    return _viscoplastic_response(scene, y, 1.0)[2]


# ----------------------------------------------------------------------------------------------
# Fractions from a final state


def _kinetic(scene: Scene, vs):
    return sum(0.5 * jnp.sum(c.mass[:, None] * v**2) for c, v in zip(scene.chains, vs, strict=True))


def state_fractions(scene: Scene, y, elastic) -> dict[str, jax.Array]:
    """The seven energy fractions of K0 (FRACTION_KEYS) of a Verlet or rate-form state."""
    k0 = scene.initial_kinetic_energy
    out = {}
    for name in ("beam", "ring"):
        i = scene.chain_index(name)
        out[f"{name}_bending"] = y.bending[i] / k0
        out[f"{name}_axial"] = y.axial[i] / k0
    out["contact"] = jnp.sum(y.contact) / k0
    out["kinetic"] = _kinetic(scene, y.v) / k0
    out["elastic"] = elastic / k0
    return out


def lumped(fractions: dict[str, float]) -> dict[str, float]:
    """Dissipated fractions and K + U together (the at-stop comparison)."""
    out = {k: fractions[k] for k in DISSIPATED}
    out["kinetic+elastic"] = fractions["kinetic"] + fractions["elastic"]
    return out


def max_error(values: dict[str, float], reference: dict[str, float]) -> float:
    """max over components |value - reference| (fractions: units of K0)."""
    return max(abs(values[k] - reference[k]) for k in reference)
