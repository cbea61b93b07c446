"""The paper's Appendix: an end-constrained half ring quasi-statically pressed by a rigid plate.

Rigid-perfectly-plastic load-deformation curve p(y_r) of Fig. 17(c) (Fig. 25-27, Eq. A.1-A.16),
in the package's units: load p on the whole half ring in M_pr / R, plate displacement y_r in R,
M_p = 1 (the ring's fully plastic moment). The half model's reaction is p / 2.

How the printed Appendix reads, and what is implemented
--------------------------------------------------------
Quarter ring from the crown A (on the symmetry axis) to the support B (clamped to the block);
C is the mid-point of the arc AB. The OCR keeps the geometry of Phase I legible:
|BC| = 2R sin(pi/8) (A.1); the chord BC, at 3 pi/8 to the horizontal, turns about B by
theta_I; phi_I = arccos((R - |BC| cos(3 pi/8 + theta_I)) / |BC|) is the inclination of the
chord AC (A.2); Y_r = R - |BC| (sin(3 pi/8 + theta_I) + sin phi_I) (A.5); Phase I ends when
A and C are level, theta_I = arccos((R - |BC|)/|BC|) - 3 pi/8 (A.8). The load formulas (A.4),
(A.6), (A.7) (a "line of resultant force" at distance x_r from B and C, P = 2 M_pr sin(varphi)
/ x_r) and the whole of Phase II/III (A.9-A.16, a step-by-step travelling hinge after Reddy and
Reid) are too garbled to transcribe with confidence. So:

- `paper_phase_one` is the printed Phase I kinematics (chords, plate on the crown A) with the
  load from virtual work: (P/2) dY = M_p (|d phi| + |d phi - d alpha| + |d alpha|) over the
  hinges A (half of its relative rotation 2 d phi belongs to the quarter), C and B. At Y = 0
  it gives the collapse load p_0 = 4 (1 + sqrt 2) = 9.657 (`initial_collapse_load`, which is
  also the equilibrium value: the only line of thrust at the same distance M_p / F from A, C
  and B runs through the mid-points of the chords AC and CB). Taken literally (contact kept at
  A) the load then *falls*, to 5.25 at the end of Phase I (Y = 0.27): the printed mechanism
  ignores that the rigid arc AC, turning about A, lifts its own material above A, so the
  plate touches the arc's highest point, not A. The MS-FD run shows the contact leaving A at
  once (node 1 at y_r = 0.05, paper mesh).
- `half_ring_plate_curve` is the rigid-plastic solution derived afresh (the brief allows it
  where the printing is garbled): incremental limit analysis of the current (deformed) shape.
  The quarter ring is a chain of `segments` rigid bars (every joint a possible hinge, m_p = 1);
  the plate presses its highest node K. Equilibrium of the quarter is fixed by three numbers,
  the load P, the horizontal thrust H and the moment M_A at the crown section (no shear there by
  symmetry), so the bending moment at every joint s is linear in them:

      M_s = M_A - H (y_A - y_s) + (P/2) (x_s - x_K) [s beyond K].

  The lower-bound theorem gives the collapse load of the current shape as the linear programme
  max P s.t. |M_s| <= m_p; its dual variables are the hinge rotations of the collapse mechanism
  (the upper bound: virtual work P dY = 2 sum m_p |d theta_s| is checked at every step). The
  shape is advanced along that mechanism by a small plate step and the programme solved
  again. Hinges may thus sit anywhere and travel; nothing about the phases is imposed.

What comes out is the Appendix's three phases (hinge positions from the dual; Fig. 25-27):

- **Phase I** (0 <= y_r <= 0.195): stationary hinges at A, C and B, with C exactly at the
  mid-point of the arc (the programme picks pi/4 among all joints, as the paper assumed). The
  plate contact slides from A along the rigid arc AC. p ~ 9.5-10. It ends as in (A.8) when the
  chord AC is level (with the contact at the arc's top: y_r = 0.195 instead of 0.27).
- **Phase II** (to y_r = 0.32): hinge C travels down towards B, the hinge at B idles, the
  contact runs to the mid-point M of the quarter; p hardens to ~16. Ends when the plate meets M
  ("Phase II ends ... in contact with the mid-point of the quarter of the ring, M").
- **Phase III** (to y_r = 0.44): the contact stays at M, the travelling hinge runs on towards B
  and p falls to ~9 (the paper: the ring hardens while y does not exceed 0.32, then softens).
  It ends when the travelling hinge stops (at 85 deg of the 90 deg arc, just short of B);
  `phase` 4 marks the mechanism after that, beyond the Appendix.

Rigid-plastic: no elasticity, no contact flattening, the ring's centre line touches the plate
(the offset h_r / 2 of the MS-FD contact is a rigid shift of both the load point and the plate,
so y_r is unchanged while the contact normal is vertical).
"""

from __future__ import annotations

import functools
import math
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

CHORD = 2.0 * math.sin(math.pi / 8.0)  # |AC| = |BC| = 2 R sin(pi/8), Eq. A.1 (R = 1)


def initial_collapse_load() -> float:
    """p_0 = 4 (1 + sqrt 2) = 9.657 M_p / R: the half ring's rigid-plastic collapse load.

    Hand calculation (equilibrium): hinges at A (crown), C (pi/4) and B (support) at M_p with
    alternating signs put the quarter's line of thrust at the same distance M_p / F from all
    three, i.e. through the mid-points (0.354, 0.854) and (0.854, 0.354) of the chords AC and
    CB: a line at 45 deg, x + y = 1.207, at distance d = (1.207 - 1) / sqrt 2 = 0.146 from B.
    The vertical component F sin 45 = (M_p / d) / sqrt 2 = 4.83 is the quarter's share P / 2.
    """
    return 4.0 * (1.0 + math.sqrt(2.0))


def _phase_one_geometry(theta):
    """(Y_r, phi, alpha) of the printed Phase I (Eq. A.1-A.5) at the rotation theta of BC."""
    alpha = 3.0 * jnp.pi / 8.0 + theta
    cx = 1.0 - CHORD * jnp.cos(alpha)  # |A'C|, the distance of C from the axis
    phi = jnp.arccos(cx / CHORD)
    y = 1.0 - CHORD * (jnp.sin(alpha) + jnp.sin(phi))
    return y, phi, alpha


PAPER_PHASE_ONE_END = math.acos((1.0 - CHORD) / CHORD) - 3.0 * math.pi / 8.0  # Eq. A.8


def paper_phase_one(theta):
    """The printed Phase I (contact kept at the crown A): (y_r, p) at rotations `theta` of BC.

    Load from virtual work over the hinges A, C, B (see the module docstring), differentiated
    with `jax.jacfwd`. `theta` in [0, PAPER_PHASE_ONE_END); p -> 4 / |BC| = 5.23 at the end.
    """
    theta = jnp.asarray(theta, dtype=float)

    def one(t):
        y, phi, alpha = _phase_one_geometry(t)
        dy, dphi, dalpha = jax.jacfwd(_phase_one_geometry)(t)
        work = jnp.abs(dphi) + jnp.abs(dphi - dalpha) + jnp.abs(dalpha)
        return y, 2.0 * work / dy

    return jax.vmap(one)(theta.reshape(-1)) if theta.ndim else one(theta)


class PlateCurve(NamedTuple):
    """The rigid-plastic half ring under a plate, sampled along the plate displacement."""

    y: np.ndarray  # plate displacement y_r (R)
    p: np.ndarray  # load on the half ring (M_pr / R), from the limit-analysis programme
    p_work: np.ndarray  # the same from virtual work 2 sum |d theta| / dY (must equal p)
    phase: np.ndarray  # 1, 2, 3 (the Appendix's phases) or 4 (after Phase III)
    contact_angle: np.ndarray  # material angle of the contact node from the crown A (rad)
    hinge_angles: tuple  # per sample, material angles of the active hinges (rad)
    boundaries: tuple  # (y at the end of Phase I, of Phase II, of Phase III)
    segments: int


def _collapse(r):
    """Limit-analysis programme of the current shape r (N+1, 2): (P, hinge rotations, K)."""
    from scipy.optimize import linprog

    n = r.shape[0]
    k = int(np.argmax(r[:, 1]))
    beyond = np.arange(n) >= k
    g = np.stack([0.5 * (r[:, 0] - r[k, 0]) * beyond, r[:, 1] - r[0, 1], np.ones(n)], axis=1)
    res = linprog(
        [-1.0, 0.0, 0.0],
        A_ub=np.vstack([g, -g]),
        b_ub=np.ones(2 * n),
        bounds=[(0.0, None), (None, None), (None, None)],
        method="highs",
    )
    if res.status != 0:
        raise RuntimeError(f"limit analysis failed: {res.message}")
    mu = res.ineqlin.marginals
    return float(res.x[0]), -(mu[:n] - mu[n:]), k


def _advance(r, w, k, dy):
    """Move the chain along the mechanism w (hinge rotations) until the contact node drops dy."""
    omega = np.concatenate([np.cumsum(w[::-1])[::-1][1:], [0.0]])[:-1]  # bar j: sum of w[j+1:]
    d = r[:-1] - r[1:]
    # node velocities from the clamped end B: v_j = v_{j+1} + omega_j x (r_j - r_{j+1})
    dv = omega[:, None] * np.stack([-d[:, 1], d[:, 0]], axis=1)
    v = np.concatenate([np.cumsum(dv[::-1], axis=0)[::-1], np.zeros((1, 2))])
    rate = -v[k, 1]
    if rate < 0.0:
        w, omega, rate = -w, -omega, -rate
    dt = dy / rate
    c, s = np.cos(omega * dt), np.sin(omega * dt)
    d = np.stack([c * d[:, 0] - s * d[:, 1], s * d[:, 0] + c * d[:, 1]], axis=1)
    r_new = np.concatenate([np.cumsum(d[::-1], axis=0)[::-1] + r[-1], r[-1:]])
    return r_new, 2.0 * np.sum(np.abs(w)) / rate


@functools.lru_cache(maxsize=8)
def half_ring_plate_curve(segments: int = 240, step: float = 1.0e-3, y_max: float = 0.7):
    """The rigid-plastic p(y_r) of the half ring under a plate (module docstring), cached.

    **Arguments:**
    - `segments`: bars of the quarter ring (hinge sites); 240 puts the curve within ~3 % of
      its limit except at the sharp peak (120 vs 240: 16.4 vs 15.9).
    - `step`: plate displacement per step (R).
    - `y_max`: last plate displacement.

    **Returns:** a `PlateCurve`. Phases: I while the hinges are the stationary A, C = pi/4, B;
    II until the contact reaches the quarter's mid-point M; III until a hinge reappears between
    A and M (the travelling hinge has stopped near B); then 4.
    """
    n = int(segments)
    if n < 4 or n % 2:
        raise ValueError(f"segments must be even and >= 4, got {segments!r}")
    s = np.linspace(0.0, 0.5 * np.pi, n + 1)
    r = np.stack([np.sin(s), np.cos(s)], axis=1)
    ys = np.arange(0.0, y_max + 0.5 * step, step)
    p, pw, phase, contact, hinges = [], [], [], [], []
    current = 1
    for _ in ys:
        load, w, k = _collapse(r)
        active = np.nonzero(np.abs(w) > 1e-9 * max(1.0, np.abs(w).max()))[0]
        if current == 1 and set(active.tolist()) != {0, n // 2, n}:
            current = 2
        if current == 2 and k >= n // 2:
            current = 3
        if current == 3 and np.any((active > 0) & (active <= n // 2)):
            current = 4
        r, work_load = _advance(r, w, k, step)
        p.append(load)
        pw.append(work_load)
        phase.append(current)
        contact.append(s[k])
        hinges.append(tuple(s[active]))
    phase = np.asarray(phase)
    ends = tuple(
        float(ys[np.argmax(phase > i)]) if np.any(phase > i) else float("nan") for i in (1, 2, 3)
    )
    return PlateCurve(
        ys, np.asarray(p), np.asarray(pw), phase, np.asarray(contact), tuple(hinges), ends, n
    )


def half_ring_plate_load(y, *, segments: int = 240, step: float = 1.0e-3):
    """p(y_r) and the phase of the Appendix's half ring pressed by a rigid plate.

    **Arguments:** `y`: plate displacement(s) y_r = Y_r / R, 0 <= y <= 0.7; `segments`, `step`:
    as `half_ring_plate_curve`.

    **Returns:** (p, phase): the load on the half ring in M_pr / R (the half model's reaction
    is p / 2), linearly interpolated, and the phase (1, 2, 3, or 4 beyond Phase III).
    The phase boundaries are `half_ring_plate_curve(...).boundaries`.
    """
    y = np.asarray(y, dtype=float)
    if np.any(y < 0.0) or np.any(y > 0.7):
        raise ValueError("y must lie in [0, 0.7]")
    curve = half_ring_plate_curve(segments, step, 0.7)
    p = np.interp(y, curve.y, curve.p)
    index = np.clip(np.searchsorted(curve.y, y, side="right") - 1, 0, curve.y.size - 1)
    return p, curve.phase[index]
