"""A hand-written numba implementation of exactly the msfd_jax discrete model: the speed reference.

Same model and step as ``msfd_jax.simulate`` for a ring-on-beam scene:
- node layout, nodal masses, held degrees of freedom, joint stiffnesses and weights, bar rest
  lengths, section constants and contact constants are read from a msfd_jax ``Scene`` (converted
  to numpy once), so both use bit-identical constants;
- joint angles atan2(a x b, a . b) minus their reference values (symmetric start joint: the
  mirrored first bar, weight 1/2; clamped end: the last bar against its initial direction; free
  end: no spring), bar strains (l - l0)/l0, contact approach gap - |x_I - x_J| over every ring
  node x every beam node of OC;
- sharp elastic-perfectly plastic return mappings (Eq. 2, 3) and the compression-only contact
  spring with permanent set (Eq. 18), exactly as ``msfd_jax.elastic_plastic`` and
  ``msfd_jax.contact_spring`` with zero smoothing;
- nodal forces by hand: the analytic gradient of the elastic energy (d atan2 / d bar vectors,
  d |b| / d b), i.e. Eq. (10);
- velocity Verlet with the return mapping at the new positions, on diffrax's time grid for a
  ``ConstantStepSize`` (t_1 = dt, t_k = t_max k / N with N = ceil(t_max / nextafter(dt)), which
  is what ``diffeqsolve`` does), and the same stopping rule (dissipation quiet for the settle
  window after t_min, energy guard, t_max).

Only the constants come from JAX; the time loop and the forces are pure numba.

Run ``python benchmarks/_numba_reference.py`` to compare with msfd_jax on the showcase.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import time

import numba
import numpy as np
from numba import njit

FREE, CLAMPED, SYMMETRIC = 0, 1, 2
_KIND = {"free": FREE, "clamped": CLAMPED, "symmetric": SYMMETRIC}


@njit(cache=False, fastmath=False, inline="always")
def _return_map(trial, yield_force, stiffness):
    """Sharp elastic-perfectly plastic return map: (force, plastic increment, dissipated)."""
    excess = max(abs(trial) - yield_force, 0.0)
    direction = 1.0 if trial > 0.0 else (-1.0 if trial < 0.0 else 0.0)
    force = trial - direction * excess
    increment = excess / stiffness
    return force, direction * increment, abs(force) * increment


@njit(inline="always")
def _joint_vectors(x, j, n, start, end, ref_first, ref_last):
    """Incoming and outgoing bar vectors (ax, ay, bx, by) of joint j (msfd_jax joint order)."""
    if start != FREE:
        k = j  # joint 0 is the start node, joint k the interior node k
    else:
        k = j + 1
    if k == 0:
        bx = x[1, 0] - x[0, 0]
        by = x[1, 1] - x[0, 1]
        if start == SYMMETRIC:
            return bx, -by, bx, by
        return ref_first[0], ref_first[1], bx, by
    if k == n - 1:  # clamped end: the last bar against its initial direction
        return x[n - 1, 0] - x[n - 2, 0], x[n - 1, 1] - x[n - 2, 1], ref_last[0], ref_last[1]
    return (
        x[k, 0] - x[k - 1, 0],
        x[k, 1] - x[k - 1, 1],
        x[k + 1, 0] - x[k, 0],
        x[k + 1, 1] - x[k, 1],
    )


@njit
def joint_angles(x, n_joints, start, end, ref_first, ref_last):
    """Relative angle of outgoing to incoming bar at every joint (Eq. 7)."""
    n = x.shape[0]
    out = np.empty(n_joints)
    for j in range(n_joints):
        ax, ay, bx, by = _joint_vectors(x, j, n, start, end, ref_first, ref_last)
        out[j] = math.atan2(ax * by - ay * bx, ax * bx + ay * by)
    return out


@njit
def chain_response(x, f, c, p, rot_p, strain_p):
    """Return-map one chain's springs at x; add -dU/dx into f; update plastic parts in place.

    ``c`` holds the chain constants (see `chain_constants`), ``p`` the static layout
    (start kind, end kind, number of joints). Returns (bending, axial, elastic) increments.
    """
    (l0, stiffness, weight, theta0, ref_first, ref_last, m_p, n_p, kappa) = c
    start, end, n_joints = p
    n = x.shape[0]
    bending = 0.0
    axial = 0.0
    elastic = 0.0
    # bars: axial spring, U = 1/2 kappa l0 (eps - eps_p)^2, dU/db = n b / |b|
    for i in range(n - 1):
        bx = x[i + 1, 0] - x[i, 0]
        by = x[i + 1, 1] - x[i, 1]
        length = math.sqrt(bx * bx + by * by)
        strain = (length - l0[i]) / l0[i]
        force, dp, dissipated = _return_map(kappa * (strain - strain_p[i]), n_p, kappa)
        strain_p[i] += dp
        axial += l0[i] * dissipated
        elastic += 0.5 * l0[i] * force * force / kappa
        gx = force * bx / length
        gy = force * by / length
        f[i + 1, 0] -= gx
        f[i + 1, 1] -= gy
        f[i, 0] += gx
        f[i, 1] += gy
    # joints: U = 1/2 w c (theta - theta0 - theta_p)^2; d theta/da = (a_y, -a_x)/|a|^2,
    # d theta/db = (-b_y, b_x)/|b|^2 (theta = phi_b - phi_a)
    offset = 0 if start != FREE else 1
    for j in range(n_joints):
        ax, ay, bx, by = _joint_vectors(x, j, n, start, end, ref_first, ref_last)
        angle = math.atan2(ax * by - ay * bx, ax * bx + ay * by) - theta0[j]
        k = stiffness[j]
        moment, dp, dissipated = _return_map(k * (angle - rot_p[j]), m_p, k)
        rot_p[j] += dp
        bending += weight[j] * dissipated
        elastic += 0.5 * weight[j] * moment * moment / k
        g = weight[j] * moment
        node = j + offset
        if node == 0:
            b2 = bx * bx + by * by
            # symmetric: a = M b0 with M = diag(1, -1), so dtheta/db0 = 2 (-b_y, b_x)/|b|^2
            scale = 2.0 if start == SYMMETRIC else 1.0
            gx = scale * g * (-by) / b2
            gy = scale * g * bx / b2
            f[1, 0] -= gx
            f[1, 1] -= gy
            f[0, 0] += gx
            f[0, 1] += gy
        elif node == n - 1:
            a2 = ax * ax + ay * ay
            gx = g * ay / a2
            gy = -g * ax / a2
            f[n - 1, 0] -= gx
            f[n - 1, 1] -= gy
            f[n - 2, 0] += gx
            f[n - 2, 1] += gy
        else:
            a2 = ax * ax + ay * ay
            b2 = bx * bx + by * by
            gax = g * ay / a2  # dU/da, a = x[node] - x[node-1]
            gay = -g * ax / a2
            gbx = -g * by / b2  # dU/db, b = x[node+1] - x[node]
            gby = g * bx / b2
            f[node - 1, 0] += gax
            f[node - 1, 1] += gay
            f[node, 0] -= gax - gbx
            f[node, 1] -= gay - gby
            f[node + 1, 0] -= gbx
            f[node + 1, 1] -= gby
    return bending, axial, elastic


@njit
def contact_response(xa, xb, fa, fb, n_b, gap, stiffness, yield_force, permanent_set):
    """Every node of xa against nodes 0..n_b-1 of xb (Eq. 18); forces along the joining line.

    Returns (dissipated, elastic, total pair force).
    """
    dissipated = 0.0
    elastic = 0.0
    total = 0.0
    # permanent sets only grow from 0, so a pair farther apart than the gap carries no force:
    # skip it before the square root (a conservative margin keeps the result bit-identical)
    far = gap * gap * (1.0 + 1e-9)
    for i in range(xa.shape[0]):
        for j in range(n_b):
            dx = xa[i, 0] - xb[j, 0]
            dy = xa[i, 1] - xb[j, 1]
            d2 = dx * dx + dy * dy
            if d2 > far:
                continue
            dist = math.sqrt(d2)
            approach = gap - dist
            s = approach - permanent_set[i, j]
            if s <= 0.0:
                continue  # separated: no force, no change (the sharp ramp is zero)
            k = stiffness[i, j]
            fy = yield_force[i, j]
            force = k * s
            if force > fy:
                new_set = approach - fy / k
                dissipated += fy * (new_set - permanent_set[i, j])
                permanent_set[i, j] = new_set
                force = fy
            s1 = approach - permanent_set[i, j]
            if s1 > 0.0:
                elastic += 0.5 * k * s1 * s1
            total += force
            # U = k R(delta - set), d delta / d xa = -(xa - xb)/|xa - xb|
            gx = force * dx / dist
            gy = force * dy / dist
            fa[i, 0] += gx
            fa[i, 1] += gy
            fb[j, 0] -= gx
            fb[j, 1] -= gy
    return dissipated, elastic, total


@njit
def _respond(xr, xb, fr, fb, cr, pr, cb, pb, rot_r, str_r, rot_b, str_b, contact_c, pset, out):
    fr[:] = 0.0
    fb[:] = 0.0
    out[0], out[2], el_r = chain_response(xr, fr, cr, pr, rot_r, str_r)
    out[1], out[3], el_b = chain_response(xb, fb, cb, pb, rot_b, str_b)
    n_b, gap, k, fy = contact_c
    out[4], el_c, out[6] = contact_response(xr, xb, fr, fb, n_b, gap, k, fy, pset)
    # same summation order as msfd_jax: ring, beam, then contact
    out[5] = el_r + el_b + el_c


@njit
def simulate_arrays(
    xr, vr, mr, free_r, cr, pr,
    xb, vb, mb, free_b, cb, pb,
    contact_c,
    dt0, t_max, n_grid, max_steps, substeps,
    t_min, settle_window, settle_tolerance, energy_guard,
):  # fmt: skip
    """Integrate until settled. Arrays xr, vr, xb, vb are copied, not modified.

    Returns (steps, t_end, code, energies) with energies = [ring bending, beam bending,
    ring axial, beam axial, contact, elastic, kinetic ring, kinetic beam, k0] and code
    0 settled, 1 time limit, 2 non-finite, 3 energy balance, 4 max steps.
    """
    xr = xr.copy()
    xb = xb.copy()
    vr = vr * free_r
    vb = vb * free_b
    n_r, n_bn = xr.shape[0], xb.shape[0]
    ar = np.zeros((n_r, 2))
    ab = np.zeros((n_bn, 2))
    fr = np.zeros((n_r, 2))
    fb = np.zeros((n_bn, 2))
    rot_r = np.zeros(pr[2])
    rot_b = np.zeros(pb[2])
    str_r = np.zeros(n_r - 1)
    str_b = np.zeros(n_bn - 1)
    pset = np.zeros(contact_c[2].shape)
    out = np.zeros(7)
    k0 = 0.0
    for i in range(n_r):
        for d in range(2):
            k0 += 0.5 * mr[i] * free_r[i, d] * vr[i, d] ** 2
    for i in range(n_bn):
        for d in range(2):
            k0 += 0.5 * mb[i] * free_b[i, d] * vb[i, d] ** 2
    _respond(xr, xb, fr, fb, cr, pr, cb, pb, rot_r, str_r, rot_b, str_b, contact_c, pset, out)
    for i in range(n_r):
        for d in range(2):
            ar[i, d] = fr[i, d] / mr[i] * free_r[i, d]
    for i in range(n_bn):
        for d in range(2):
            ab[i, d] = fb[i, d] / mb[i] * free_b[i, d]
    bend_r = out[0]
    bend_b = out[1]
    ax_r = out[2]
    ax_b = out[3]
    contact = out[4]
    elastic = out[5]
    tolerance = settle_tolerance * k0
    last = 0.0
    mark = 0.0
    t = 0.0
    steps = 0
    code = 4
    kin_r = 0.0
    kin_b = 0.0
    while steps < max_steps:
        steps += 1
        t_macro = dt0 if steps == 1 else t_max * (steps / n_grid)
        if steps == n_grid:
            t_macro = t_max
        # msfd_jax makes `substeps` equal Verlet steps inside each diffrax step
        t_start = t
        h = (t_macro - t_start) / substeps
        for sub in range(substeps):
            t_next = t_start + (sub + 1) * h
            half = 0.5 * h
            for i in range(n_r):
                for d in range(2):
                    vr[i, d] = vr[i, d] + half * ar[i, d]
                    xr[i, d] = xr[i, d] + h * vr[i, d]
            for i in range(n_bn):
                for d in range(2):
                    vb[i, d] = vb[i, d] + half * ab[i, d]
                    xb[i, d] = xb[i, d] + h * vb[i, d]
            _respond(
                xr, xb, fr, fb, cr, pr, cb, pb, rot_r, str_r, rot_b, str_b, contact_c, pset, out
            )
            kin_r = 0.0
            kin_b = 0.0
            for i in range(n_r):
                for d in range(2):
                    ar[i, d] = fr[i, d] / mr[i] * free_r[i, d]
                    vr[i, d] = vr[i, d] + half * ar[i, d]
                    kin_r += mr[i] * vr[i, d] ** 2
            for i in range(n_bn):
                for d in range(2):
                    ab[i, d] = fb[i, d] / mb[i] * free_b[i, d]
                    vb[i, d] = vb[i, d] + half * ab[i, d]
                    kin_b += mb[i] * vb[i, d] ** 2
            kin_r *= 0.5
            kin_b *= 0.5
            bend_r += out[0]
            bend_b += out[1]
            ax_r += out[2]
            ax_b += out[3]
            contact += out[4]
            elastic = out[5]
            t = t_next
            total = (bend_r + bend_b) + (ax_r + ax_b) + contact
            if total - mark > tolerance:
                last = t
                mark = total
        t = t_macro
        err = ((kin_r + kin_b) + elastic + total - k0) / (k0 if k0 > 0 else 1.0)
        if not math.isfinite(err):
            code = 2
            break
        if abs(err) > energy_guard:
            code = 3
            break
        if t - last > settle_window and t >= t_min:
            code = 0
            break
        if t >= t_max:
            code = 1
            break
    energies = np.array([bend_r, bend_b, ax_r, ax_b, contact, elastic, kin_r, kin_b, k0])
    return steps, t, code, energies


def chain_constants(chain):
    """numpy copies of one msfd_jax Chain's constants, and its static layout."""
    from msfd_jax import Chain

    assert isinstance(chain, Chain)
    start, end = _KIND[chain.start], _KIND[chain.end]
    if end == SYMMETRIC:
        raise ValueError("symmetric end joints are not supported")
    stiffness, weight = (
        np.asarray(a, dtype=np.float64) for a in chain.joint_stiffness_and_weight()
    )
    ref = np.asarray(chain.reference, dtype=np.float64)
    ref_first = ref[1] - ref[0]
    ref_last = ref[-1] - ref[-2]
    n_joints = chain.n_joints
    layout = (start, end, n_joints)
    theta0 = joint_angles(ref, n_joints, start, end, ref_first, ref_last)
    s = chain.section
    constants = (
        np.asarray(chain.rest_length, dtype=np.float64),
        stiffness,
        weight,
        theta0,
        ref_first,
        ref_last,
        float(s.plastic_moment),
        float(s.plastic_axial),
        float(s.axial_modulus),
    )
    return constants, layout


@functools.cache
def _critical_step():
    """`msfd_jax.critical_step` jitted, as `simulate` computes the stability limit (once)."""
    import equinox as eqx

    from msfd_jax import critical_step

    return eqx.filter_jit(critical_step)


class Reference:
    """The numba model of one ring-on-beam scene and settings (constants from msfd_jax)."""

    def __init__(self, scene, settings):
        from msfd_jax import NodeToNodeContact

        # how `simulate` resolves a run's cap and step bound (no public API): the reference
        # runs the same time grid to the same bound
        from msfd_jax._batched.simulate import max_steps_for
        from msfd_jax._model.cap import concrete_time_cap

        if float(scene.contact_smoothing) != 0.0 or float(scene.yield_smoothing) != 0.0:
            raise ValueError("the numba reference implements the sharp laws only")
        ring, beam = scene.chains
        (contact,) = scene.contacts
        assert isinstance(contact, NodeToNodeContact)
        assert contact.chain_a == 0 and contact.chain_b == 1
        assert contact.nodes_a == tuple(range(ring.n_nodes))
        assert contact.nodes_b == tuple(range(len(contact.nodes_b)))
        self.cr, self.pr = chain_constants(ring)
        self.cb, self.pb = chain_constants(beam)
        self.contact = (
            len(contact.nodes_b),
            float(contact.gap),
            np.asarray(contact.stiffness, dtype=np.float64),
            np.asarray(contact.yield_force, dtype=np.float64),
        )
        self.xr = np.asarray(ring.reference, dtype=np.float64)
        self.xb = np.asarray(beam.reference, dtype=np.float64)
        self.vr = np.asarray(scene.initial_velocity[0], dtype=np.float64)
        self.vb = np.asarray(scene.initial_velocity[1], dtype=np.float64)
        self.mr = np.asarray(ring.mass, dtype=np.float64)
        self.mb = np.asarray(beam.mass, dtype=np.float64)
        self.free_r = np.asarray(ring.free, dtype=np.float64)
        self.free_b = np.asarray(beam.free, dtype=np.float64)
        if settings.t_max is None:
            # the derived cap (issue 12) keeps the grid of the former fixed cap 10 and only
            # extends it; the reference runs that grid with the cap resolved for this scene
            settings = dataclasses.replace(settings, t_max=concrete_time_cap(scene))
        dt_crit = float(_critical_step()(scene))
        self.dt = dt_crit * float(settings.safety) if settings.dt is None else float(settings.dt)
        self.dt_critical = dt_crit
        self.t_max = float(settings.t_max)
        # diffrax's ConstantStepSize grid (diffrax/_step_size_controller/constant.py)
        self.substeps = int(settings.substeps)
        self.dt_macro = self.dt * self.substeps
        self.n_grid = int(np.ceil(self.t_max / np.nextafter(self.dt_macro, np.inf)))
        self.max_steps = int(max_steps_for(scene, settings))
        self.rule = tuple(
            float(v)
            for v in (
                settings.t_min,
                settings.settle_window,
                settings.settle_tolerance,
                settings.energy_guard,
            )
        )

    def __call__(self, max_steps: int | None = None):
        """Run; returns dict(steps, t_end, code, energies, fractions)."""
        steps, t_end, code, e = simulate_arrays(
            self.xr,
            self.vr,
            self.mr,
            self.free_r,
            self.cr,
            self.pr,
            self.xb,
            self.vb,
            self.mb,
            self.free_b,
            self.cb,
            self.pb,
            self.contact,
            self.dt_macro,
            self.t_max,
            self.n_grid,
            self.max_steps if max_steps is None else max_steps,
            self.substeps,
            *self.rule,
        )
        k0 = e[8]
        fractions = dict(
            beam_bending=e[1] / k0,
            beam_axial=e[3] / k0,
            ring_bending=e[0] / k0,
            ring_axial=e[2] / k0,
            contact=e[4] / k0,
            kinetic=(e[6] + e[7]) / k0,
            elastic=e[5] / k0,
        )
        return dict(
            steps=int(steps) * self.substeps,
            t_end=float(t_end),
            code=int(code),
            k0=k0,
            fractions=fractions,
        )

    def compile(self):
        """Compile (one step); returns the compile time in seconds."""
        start = time.perf_counter()
        self(max_steps=1)
        return time.perf_counter() - start


def compare(scene=None, settings=None, repeats: int = 3):
    """Run numba and msfd_jax on the same scene; return (numba result, jax fractions, diff)."""
    import jax

    import msfd_jax as m

    scene = m.ring_on_beam() if scene is None else scene
    settings = m.Settings() if settings is None else settings
    ref = Reference(scene, settings)
    compile_s = ref.compile()
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        out = ref()
        times.append(time.perf_counter() - start)
    sol = jax.block_until_ready(m.simulate(scene, settings))
    jf = {k: float(v) for k, v in m.fractions(sol, scene).items()}
    diff = {k: out["fractions"][k] - jf[k] for k in m.FRACTION_KEYS}
    return dict(
        numba=out,
        numba_compile_s=compile_s,
        numba_run_s=min(times),
        jax_fractions={k: jf[k] for k in m.FRACTION_KEYS},
        jax_steps=int(sol.steps),
        jax_t_end=float(sol.t_end),
        jax_k0=float(sol.k0),
        difference=diff,
        max_abs_difference=max(abs(v) for v in diff.values()),
    )


def main():
    import json

    result = compare()
    print(json.dumps(result, indent=2))
    print(f"numba threads: {numba.get_num_threads()} (the loop is serial)")


if __name__ == "__main__":
    main()
