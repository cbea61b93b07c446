"""The batched core: closed-form forces and the Verlet step on a `FlatScene`.

Every array ends in the batch axis B. The nodal forces are Eq. (10) in closed form, as the
numba reference writes them, not a `jax.vjp` of the kinematics (tests/test_engine.py checks
them against autodiff of the elastic energy):

- a bar b = x_{i+1} - x_i with axial force n: dU/db = n b/|b|;
- a joint theta = phi(b) - phi(a) with moment g = w m: dU/da = g (a_y, -a_x)/|a|^2 and
  dU/db = g (-b_y, b_x)/|b|^2 (a symmetric start has a = diag(1, -1) b_0; a clamped end or
  start a fixed a or b);
- nodal forces F_i = G_i - G_{i-1}, G the summed dU/d(bar);
- a contact pair with force f along d = x_a - x_b: F_a = f d/|d|, F_b = -f d/|d|.

Each collision of the batch keeps its own step and its own clock (`Clock`): the diffrax time
of a batched solve is a step counter, and a collision that has stopped is frozen (its state is
no longer updated) until the sweep refills its slot.
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from .._model.laws import contact_energy, contact_spring, elastic_plastic
from .._model.safe import atan2, safe_norm, unwrap_near
from . import peaks as _peaks
from .collapse_forces import collapse_energy, collapse_pair_force, collapse_response
from .flat import COLLAPSE_LAYOUTS, FlatScene, PairLayout
from .pruning import (
    blocked_energy,
    blocked_pairs,
    contact_blocks,
    dense_energy,
    dense_pairs,
    listed_blocks,
    listed_energy,
    listed_pairs,
    pair_geometry,
)
from .pruning import pad as _pad
from .pruning import total as _total
from .results import RESULTS

FOLD_LIMIT = float(np.pi)  # plastic joint rotation at which a run stops (bars folded through)
GRID_SPAN = 10.0  # a derived cap's grid: the former fixed cap's (`_model.cap.T_MAX_FLOOR`)
_MIRROR = np.array([1.0, -1.0])[None, :, None]  # diag(1, -1) acting on (n, 2, B) vectors


class BatchState(eqx.Module):
    """What changes during a run, for B collisions (every array ends in B).

    `k` counts the collision's completed diffrax steps and `t` is its time; `done` is 1 once it
    has stopped, with `code` its result and `t_end` its end time. Energies in units of M_pr.
    """

    x: Float[Array, "N 2 B"]
    v: Float[Array, "N 2 B"]
    a: Float[Array, "N 2 B"]
    plastic_rotation: Float[Array, "J B"]
    plastic_strain: Float[Array, "M B"]
    permanent_set: tuple[Array, ...]
    bending: Float[Array, "C B"]
    axial: Float[Array, "C B"]
    contact: Float[Array, "K B"]
    elastic: Float[Array, " B"]
    reaction: Float[Array, " B"]
    drive_work: Float[Array, " B"]
    last_dissipation: Float[Array, " B"]
    dissipation_mark: Float[Array, " B"]
    last_contact: Float[Array, " B"]
    t: Float[Array, " B"]
    k: Float[Array, " B"]
    done: Float[Array, " B"]
    code: Float[Array, " B"]
    peaks: Float[Array, "P B"] | tuple  # `peaks.PEAK_KEYS`; () if the scene tracks none


class Clock(eqx.Module):
    """Each collision's time grid: diffrax's ``ConstantStepSize`` grid of its own step.

    The first step ends at `dt0` (= substeps x dt), step k >= 2 at t_max k / n, the last at
    t_max, with n = ceil(t_max / nextafter(dt0)), as ``diffrax.ConstantStepSize`` makes it, so
    a collision run alone or in a batch takes the same steps as ``diffeqsolve`` would.
    """

    dt0: Float[Array, " B"]
    n: Float[Array, " B"]
    t_max: Float[Array, " B"]
    span: Float[Array, " B"]  # the grid's: t_max, or for a derived cap its floor (below)
    max_steps: Float[Array, " B"]  # diffrax steps allowed (Settings.max_steps)
    tolerance: Float[Array, " B"]  # settle_tolerance x K0
    k0: Float[Array, " B"]


def make_clock(flat: FlatScene, dt, settings, max_steps, t_max=None) -> Clock:
    """The clocks of a batch: `dt` (B,) the Verlet step, numbers from `settings`.

    `t_max` (B,), when given, is each collision's cap (the derived caps of
    ``Settings(t_max=None)``, `_model.cap`); otherwise ``settings.t_max`` for all. A derived
    cap keeps the grid of its floor (`span` = 10: step k ends at 10 k / n, continued past 10
    up to the cap), so a collision that stops before 10 takes exactly the steps it took with
    the former fixed cap.
    """
    dt0 = dt * settings.substeps
    derived = t_max is not None
    t_max = settings.t_max if t_max is None else t_max
    t_max = jnp.broadcast_to(jnp.asarray(t_max, float), dt0.shape)
    span = jnp.minimum(t_max, GRID_SPAN) if derived else t_max
    n = jnp.ceil(span / jnp.nextafter(dt0, jnp.inf))
    k0 = flat.initial_kinetic_energy
    return Clock(
        dt0,
        n,
        t_max,
        span,
        jnp.broadcast_to(jnp.asarray(max_steps, float), dt0.shape),
        settings.settle_tolerance * k0,
        k0,
    )


class BatchResponse(eqx.Module):
    forces: Array
    plastic_rotation: Array
    plastic_strain: Array
    permanent_set: tuple[Array, ...]
    contact_force: tuple[Array, ...]  # per contact set: the total pair force (B,)
    bending: Array
    axial: Array
    contact: Array


def _bars(x, c):
    """One chain's bar vectors (n-1, 2, B) and lengths (n-1, B)."""
    xc = x[c.node : c.node + c.n_nodes]
    bars = xc[1:] - xc[:-1]
    return bars, safe_norm(bars, axis=1)


def _joints(flat: FlatScene, c, bars):
    """The joints' incoming a and outgoing b bar vectors (J_c, 2, B) and relative angles."""
    incoming, outgoing = [bars[:-1]], [bars[1:]]
    index = flat.chains.index(c)
    if c.start == "symmetric":
        incoming.insert(0, bars[:1] * _MIRROR)
        outgoing.insert(0, bars[:1])
    elif c.start == "clamped":
        incoming.insert(0, flat.start_direction[index][None])
        outgoing.insert(0, bars[:1])
    if c.end == "clamped":
        incoming.append(bars[-1:])
        outgoing.append(flat.end_direction[index][None])
    a, b = jnp.concatenate(incoming), jnp.concatenate(outgoing)  # (J_c, 2, B)
    ax, ay, bx, by = a[:, 0], a[:, 1], b[:, 0], b[:, 1]
    sl_j = slice(c.joint, c.joint + c.n_joints)
    angle = atan2(ax * by - ay * bx, ax * bx + ay * by) - flat.reference_angle[sl_j]
    return (ax, ay, bx, by), angle


def _yield_width(flat: FlatScene):
    # (1, B): the laws see arrays of one rank; None: the sharp law alone (static: a scene whose
    # width is known to be zero compiles no softplus)
    return flat.yield_smoothing[None] if flat.smooth_yield else None


def _contact_width(flat: FlatScene, rank: int):
    if not flat.smooth_contact:
        return None
    return jnp.reshape(flat.contact_smoothing, (1,) * rank + flat.contact_smoothing.shape)


def _chain_response(flat: FlatScene, c, x, rotation_p, strain_p):
    """One chain's springs at x: (forces (n, 2, B), new plastic parts, dissipation)."""
    n = c.n_nodes
    bars, length = _bars(x, c)
    ys = _yield_width(flat)
    sl_b = slice(c.bar, c.bar + n - 1)
    l0, kappa = flat.rest_length[sl_b], flat.axial_modulus[sl_b]
    strain = (length - l0) / l0
    axial_force, strain1, d_axial = elastic_plastic(
        strain, strain_p[sl_b], kappa, flat.plastic_axial[sl_b], ys
    )
    safe_length = jnp.where(length > 0, length, 1.0)
    grad_bar = (axial_force / safe_length)[:, None] * bars  # dU/d(bar)
    axial = jnp.sum(l0 * d_axial, axis=0)
    if c.n_joints == 0:
        return _nodal(grad_bar), rotation_p[c.joint : c.joint], strain1, 0.0, axial
    (ax, ay, bx, by), angle = _joints(flat, c, bars)
    sl_j = slice(c.joint, c.joint + c.n_joints)
    angle = unwrap_near(angle, rotation_p[sl_j])  # a fold past pi: no 2 pi jump
    k, w = flat.joint_stiffness[sl_j], flat.joint_weight[sl_j]
    moment, rotation1, d_rot = elastic_plastic(
        angle, rotation_p[sl_j], k, flat.plastic_moment[sl_j], ys
    )
    g = w * moment
    a2, b2 = ax * ax + ay * ay, bx * bx + by * by
    grad_a = jnp.stack([g * ay / a2, -g * ax / a2], axis=1)  # dU/da
    grad_b = jnp.stack([-g * by / b2, g * bx / b2], axis=1)  # dU/db
    first = int(c.start != "free")
    interior = slice(first, first + n - 2)
    grad_bar = grad_bar + _pad(grad_a[interior], 0, 1) + _pad(grad_b[interior], 1, 0)
    if c.start == "symmetric":
        grad_bar = grad_bar + _pad(grad_a[:1] * _MIRROR + grad_b[:1], 0, n - 2)
    elif c.start == "clamped":
        grad_bar = grad_bar + _pad(grad_b[:1], 0, n - 2)
    if c.end == "clamped":
        grad_bar = grad_bar + _pad(grad_a[-1:], n - 2, 0)
    bending = jnp.sum(w * d_rot, axis=0)
    return _nodal(grad_bar), rotation1, strain1, bending, axial


def _nodal(grad_bar):
    """F_i = G_i - G_{i-1} for G = dU/d(bar_i), bar_i = x_{i+1} - x_i."""
    return _pad(grad_bar, 0, 1) - _pad(grad_bar, 1, 0)


def _approach(p, x, gap):
    """A contact set's approaches delta (pairs..., B), and for node-to-node pairs the
    separation (dx, dy) and its length (the double where keeps reverse mode finite at 0)."""
    xa = x[p.a : p.a + p.n_a]
    if not isinstance(p, PairLayout):
        return xa[:, 1] + gap[None], None
    return pair_geometry(xa, x[p.b : p.b + p.n_b], gap)


def _plane_forces(p, f, n_nodes):
    """Nodal forces (N, 2, B) of a node-to-plane set's forces f: the plane pushes along -y."""
    fa = jnp.stack([jnp.zeros_like(f), -f], axis=1)
    return _pad(fa, p.a, n_nodes - p.a - p.n_a)


def _contact_loop(loop: str):
    """(pairs, energy, block shape) functions of a node-to-node set for
    ``Settings.contact_loop`` `loop` ("blocks", "listed" or "dense"; `pruning`)."""
    if loop == "listed":
        return listed_pairs, listed_energy, listed_blocks
    if loop == "dense":
        return dense_pairs, dense_energy, contact_blocks
    return blocked_pairs, blocked_energy, contact_blocks


def batch_response(
    flat: FlatScene, x, rotation_p, strain_p, permanent_set, loop: str = "blocks"
) -> BatchResponse:
    """Return-map every spring at `x` and assemble the nodal forces in closed form (Eq. 10).

    The elastic energy is not computed here (the step does not need it): `elastic_energy`
    evaluates it from the state once per diffrax step. `loop` (static,
    ``Settings.contact_loop``): how node-to-node sets skip their far blocks: a conditional
    per block ("blocks"), a while loop over the near blocks ("listed", forward mode only) or
    not at all ("dense"); see `msfd_jax._batched.pruning`.
    """
    forces, rot, strain, bend, axial = [], [], [], [], []
    for c in flat.chains:
        f, r1, s1, b, a = _chain_response(flat, c, x, rotation_p, strain_p)
        forces.append(f)
        rot.append(r1)
        strain.append(s1)
        bend.append(jnp.broadcast_to(b, x.shape[-1:]))
        axial.append(a)
    force = jnp.concatenate(forces)
    n_nodes = force.shape[0]
    new_set, pair_force, dissipated = [], [], []
    for p, gap, k, fy, ps in zip(
        flat.pairs, flat.gap, flat.stiffness, flat.yield_force, permanent_set, strict=True
    ):
        if isinstance(p, COLLAPSE_LAYOUTS):  # only in scenes that have them: others run as before
            fc, ps1, f, dc, _ = collapse_response(flat, p, x, gap, k, fy, ps)
            force = force + fc
            new_set.append(ps1)
            pair_force.append(_total(f))
            dissipated.append(dc)
            continue
        if isinstance(p, PairLayout):
            pairs, _, shape = _contact_loop(loop)
            blocks = shape(p.n_a, p.n_b, x.shape[-1])
            fc, ps1, total_force, dc = pairs(p, x, gap, k, fy, ps, blocks, _contact_width(flat, 2))
            force = force + fc
            new_set.append(ps1)
            pair_force.append(total_force)
            dissipated.append(dc)
            continue
        delta, _ = _approach(p, x, gap)  # a node-to-plane set (node-to-node ones: above)
        f, ps1, dc = contact_spring(delta, ps, k, fy, _contact_width(flat, delta.ndim - 1))
        force = force + _plane_forces(p, f, n_nodes)
        new_set.append(ps1)
        pair_force.append(_total(f))
        dissipated.append(_total(dc))
    batch = x.shape[-1:]
    return BatchResponse(
        force,
        jnp.concatenate(rot),
        jnp.concatenate(strain),
        tuple(new_set),
        tuple(pair_force),
        jnp.stack(bend),
        jnp.stack(axial),
        jnp.stack(dissipated) if dissipated else jnp.zeros((1, *batch)),
    )


def elastic_energy(
    flat: FlatScene, x, rotation_p, strain_p, permanent_set, loop: str = "blocks"
) -> Float[Array, " B"]:
    """Elastic energy stored at `x` with the plastic parts after the return mapping.

    The mapped force is k (q - q_p) for the sharp and the smoothed law alike, so the energy
    is sum k (q - q_p)^2 / 2 (bars l0 kappa (eps - eps_p)^2 / 2, joints w c (theta - theta_p)^2
    / 2) plus the contact springs' k ramp_energy(delta - delta_p).
    """
    energy = jnp.zeros(x.shape[-1:])
    for c in flat.chains:
        bars, length = _bars(x, c)
        sl_b = slice(c.bar, c.bar + c.n_nodes - 1)
        l0 = flat.rest_length[sl_b]
        strain = (length - l0) / l0 - strain_p[sl_b]
        energy = energy + 0.5 * jnp.sum(l0 * flat.axial_modulus[sl_b] * strain**2, axis=0)
        if c.n_joints:
            _, angle = _joints(flat, c, bars)
            sl_j = slice(c.joint, c.joint + c.n_joints)
            angle = unwrap_near(angle, rotation_p[sl_j])
            k, w = flat.joint_stiffness[sl_j], flat.joint_weight[sl_j]
            energy = energy + 0.5 * jnp.sum(w * k * (angle - rotation_p[sl_j]) ** 2, axis=0)
    for p, gap, k, ps in zip(flat.pairs, flat.gap, flat.stiffness, permanent_set, strict=True):
        if isinstance(p, COLLAPSE_LAYOUTS):
            energy = energy + collapse_energy(flat, p, x, gap, k, ps)
            continue
        if isinstance(p, PairLayout):
            _, stored, shape = _contact_loop(loop)
            blocks = shape(p.n_a, p.n_b, x.shape[-1])
            energy = energy + stored(p, x, gap, k, ps, blocks, _contact_width(flat, 2))
            continue
        delta, _ = _approach(p, x, gap)
        pairs = tuple(range(delta.ndim - 1))
        width = _contact_width(flat, len(pairs))
        energy = energy + jnp.sum(contact_energy(delta, ps, k, width), axis=pairs)
    return energy


def pair_forces(flat: FlatScene, x, permanent_set) -> tuple[Array, ...]:
    """The contact pair forces at `x` with the permanent sets after the return mapping.

    Not carried in the state (the step's carry stays small); recomputed for histories.
    After a yield the set puts the pair exactly at its yield approach, so this equals the
    step's force to rounding.
    """
    out = []
    for p, gap, k, fy, ps in zip(
        flat.pairs, flat.gap, flat.stiffness, flat.yield_force, permanent_set, strict=True
    ):
        if isinstance(p, COLLAPSE_LAYOUTS):
            out.append(collapse_pair_force(flat, p, x, gap, k, fy, ps))
            continue
        delta, _ = _approach(p, x, gap)
        f, _, _ = contact_spring(delta, ps, k, fy, _contact_width(flat, delta.ndim - 1))
        out.append(f)
    return tuple(out)


def _accelerations(flat: FlatScene, force):
    return force / flat.mass[:, None] * flat.free


def _reaction(flat: FlatScene, force):
    if flat.drive is None:
        return jnp.zeros(force.shape[-1:])
    node, axis = flat.drive
    return -force[node, axis]


def kinetic(flat: FlatScene, v) -> Float[Array, "C B"]:
    """Kinetic energy per chain, sum of m v^2 / 2 over its nodes."""
    e = 0.5 * jnp.sum(flat.mass[:, None] * v**2, axis=1)
    return jnp.stack([jnp.sum(e[flat.chain_slice(c)], axis=0) for c in flat.chains])


def batch_initial_state(flat: FlatScene) -> BatchState:
    """Reference positions, initial velocities, no plastic deformation; nothing stopped."""
    x = flat.x0
    nj, nm = flat.joint_stiffness.shape[0], flat.rest_length.shape[0]
    batch = flat.mass.shape[-1:]
    sets = tuple(jnp.zeros_like(k) for k in flat.stiffness)
    r = batch_response(flat, x, jnp.zeros((nj, *batch)), jnp.zeros((nm, *batch)), sets)
    elastic = elastic_energy(flat, x, r.plastic_rotation, r.plastic_strain, r.permanent_set)
    z = jnp.zeros(batch)
    return BatchState(
        x, flat.v0, _accelerations(flat, r.forces), r.plastic_rotation, r.plastic_strain,
        r.permanent_set, r.bending, r.axial, r.contact, elastic,
        _reaction(flat, r.forces), z, z, z, z, z, z, z, z, _peaks.initial(flat),
    )  # fmt: skip


def verlet_substep(
    flat: FlatScene, s: BatchState, t1, h, tolerance, loop: str = "blocks"
) -> BatchState:
    """One velocity-Verlet step of length h (B,) with return mapping at the new positions.

    The state's elastic energy is left as it was: `advance` updates it once per diffrax step
    (it enters only the energy balance and the stopping rule, checked there). `loop`: see
    `batch_response`."""
    hb = h[None, None]  # (1, 1, B) against (N, 2, B)
    v_half = s.v + 0.5 * hb * s.a
    x = s.x + hb * v_half
    r = batch_response(flat, x, s.plastic_rotation, s.plastic_strain, s.permanent_set, loop)
    a1 = _accelerations(flat, r.forces)
    v1 = v_half + 0.5 * hb * a1
    reaction = _reaction(flat, r.forces)
    drive_work = s.drive_work
    if flat.drive is not None:
        drive_work = drive_work + 0.5 * (s.reaction + reaction) * flat.drive_velocity * h
    bending, axial, contact = s.bending + r.bending, s.axial + r.axial, s.contact + r.contact
    total = jnp.sum(bending, 0) + jnp.sum(axial, 0) + jnp.sum(contact, 0)
    moved = total - s.dissipation_mark > tolerance
    force = jnp.zeros(h.shape)
    for p, f in zip(flat.pairs, r.contact_force, strict=True):
        if isinstance(p, COLLAPSE_LAYOUTS):
            continue  # "apart" is ring and beam apart; a folded ring may stay closed on itself
        force = force + jnp.sum(f, axis=tuple(range(f.ndim - 1)))
    touching = force > 0  # every pair force is >= 0: a positive total is a closed contact
    peaks = _peaks.update(flat, s.peaks, x, a1, force, h)
    return eqx.tree_at(
        lambda q: (
            q.x, q.v, q.a, q.plastic_rotation, q.plastic_strain, q.permanent_set, q.bending,
            q.axial, q.contact, q.reaction, q.drive_work,
            q.last_dissipation, q.dissipation_mark, q.last_contact, q.peaks,
        ),
        s,
        (
            x, v1, a1, r.plastic_rotation, r.plastic_strain, r.permanent_set, bending, axial,
            contact, reaction, drive_work,
            jnp.where(moved, t1, s.last_dissipation), jnp.where(moved, total, s.dissipation_mark),
            jnp.where(touching, t1, s.last_contact), peaks,
        ),
    )  # fmt: skip


def energy_error(flat: FlatScene, s: BatchState, k0):
    """(K + U + D - K0 - W_drive) / K0 per collision."""
    dissipated = jnp.sum(s.bending, 0) + jnp.sum(s.axial, 0) + jnp.sum(s.contact, 0)
    total = jnp.sum(kinetic(flat, s.v), 0) + s.elastic + dissipated
    return (total - k0 - s.drive_work) / jnp.where(k0 > 0, k0, 1.0)


def advance(flat: FlatScene, clock: Clock, s: BatchState, substeps: int, rule) -> BatchState:
    """One diffrax step of every collision not yet stopped: `substeps` Verlet steps on its own
    grid, then its stopping rule (`rule`: the Settings numbers). Stopped ones stay frozen."""
    k = s.k + 1.0
    t_next = jnp.where(k == 1.0, clock.dt0, clock.span * (k / clock.n))
    # the cap: the grid's end (as diffrax's), or a derived cap past its floor's grid
    capped = jnp.where(clock.span < clock.t_max, t_next >= clock.t_max, k >= clock.n)
    t_next = jnp.where(capped, clock.t_max, t_next)
    t0 = s.t
    h = (t_next - t0) / substeps
    loop = rule.contact_loop or "blocks"

    def body(i, y):
        return verlet_substep(flat, y, t0 + (i + 1) * h, h, clock.tolerance, loop)

    y = body(0, s) if substeps == 1 else jax.lax.fori_loop(0, substeps, body, s)
    sets = y.permanent_set
    elastic = elastic_energy(flat, y.x, y.plastic_rotation, y.plastic_strain, sets, loop)
    y = eqx.tree_at(lambda q: q.elastic, y, elastic)
    err = energy_error(flat, y, clock.k0)
    non_finite = ~jnp.isfinite(err)
    # a joint folded past pi: its bars pass through each other, which the paper's model (no
    # contact of the ring with itself, the block or the symmetry plane, nor of the beam with
    # its mirror half) cannot follow, nor a scene whose collapse contacts failed to stop it;
    # stopped as a broken run
    folded = jnp.any(jnp.abs(y.plastic_rotation) > FOLD_LIMIT, axis=0)
    broken = non_finite | (jnp.abs(err) > rule.energy_guard) | folded
    settled = jnp.zeros_like(broken)
    if rule.stop_when_settled:
        t = t_next
        quiet = (t - y.last_dissipation > rule.settle_window) & (t >= rule.t_min)
        apart = t - y.last_contact > rule.settle_window
        spent = jnp.sum(kinetic(flat, y.v), 0) + y.elastic <= rule.settle_residual * clock.k0
        settled = quiet & (apart | spent)
    out_of_steps = k >= clock.max_steps
    stop = broken | settled | capped | out_of_steps
    ended = settled | capped  # folded: the fold guard stopped it, the balance holds
    code = jnp.select(
        [non_finite, jnp.abs(err) > rule.energy_guard, folded, ended & (t_next < clock.t_max)],
        [RESULTS.non_finite, RESULTS.energy_balance_broken, RESULTS.folded, RESULTS.settled],
        jnp.where(ended, RESULTS.time_limit, RESULTS.max_steps),
    ).astype(float)
    y = eqx.tree_at(
        lambda q: (q.t, q.k, q.done, q.code),
        y,
        (t_next, k, jnp.where(stop, 1.0, 0.0), code),
    )
    # stopped before this step: keep the old state (the work done on it is discarded)
    frozen = s.done > 0

    def keep(old, new):
        return jnp.where(jnp.reshape(frozen, (1,) * (old.ndim - 1) + frozen.shape), old, new)

    return jax.tree_util.tree_map(keep, s, y)
