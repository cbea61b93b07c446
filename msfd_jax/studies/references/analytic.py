"""Rigid-perfectly-plastic closed forms the MS-FD model must approach (MODEL.md Sect. 8, 9).

- `beam_central_load`: the quasi-static load-deflection curve of a simply supported beam under
  a central load, with axial constraint (the paper's Eq. 25, Fig. 12) or without.
- `parkes_cantilever`: Parkes' (1955) travelling-hinge solution for a cantilever struck at its
  tip by a mass that sticks (Jones, *Structural Impact*, Sect. 3.8; Hou et al. used it to
  validate MS-FD).

Both are rigid-perfectly plastic: they neglect elasticity, so an elastic-plastic MS-FD run
reaches them only once the elastic range is passed (beam) or when the initial kinetic energy is
large against the elastic energy capacity (cantilever). The Appendix's three-phase ring solution
is elsewhere.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import jax.numpy as jnp
import numpy as np


def beam_central_load(y, plastic_moment, plastic_axial, half_span, *, axial_constraint=True):
    """Central load p(y) of a rigid-perfectly-plastic simply supported beam (Eq. 25, Fig. 12).

    Mechanism: two rigid halves of the span 2 l_b, one central hinge at the fully plastic moment
    m_p, independent (square) yield criterion (Eq. 4), so the moment and the axial force are
    both at yield. Virtual work with the central deflection y as the only coordinate:

    - **axially constrained** (supports held in x): each half rotates by theta = atan(y / l_b)
      and stretches to s = sqrt(l_b^2 + y^2) at the fully plastic axial force n_p, so
      p dy = m_p d(2 theta) + 2 n_p ds, i.e.

          p = 2 m_p l_b / (l_b^2 + y^2) + 2 n_p y / sqrt(l_b^2 + y^2).

      The same follows from equilibrium of a half (moment about the support, axial force along
      the chord). The printed Eq. 25 is garbled in the OCR; this form gives p = 16.3 at
      y / l_b = 0.2 for n_p = 40, m_p = 1, l_b = 3, the value read off Fig. 12(b).
    - **no axial constraint** (a support free to slide): the axial force vanishes, each rigid half
      of length l_b turns by theta = asin(y / l_b), and p dy = m_p d(2 theta) gives

          p = 2 m_p / sqrt(l_b^2 - y^2) = (2 m_p / l_b) (1 + y^2 / (2 l_b^2) + ...),

      the small-deflection collapse load 2 m_p / l_b with its large-deflection (shortening
      lever arm) factor. `plastic_axial` is unused in this case.

    **Arguments:**
    - `y`: central deflection (units of R in the paper's ring units, or any length unit).
    - `plastic_moment`: m_p of the beam (ring units: lambda^2).
    - `plastic_axial`: n_p of the beam (ring units: 4 (R/h_r) lambda).
    - `half_span`: l_b = L_b / R.
    - `axial_constraint`: True for Eq. 25, False for the sliding support.

    **Returns:** p, the load on the whole beam (the half model's reaction is p/2).
    """
    y = jnp.asarray(y, dtype=float)
    lb = half_span
    if axial_constraint:
        chord2 = lb**2 + y**2
        return 2.0 * plastic_moment * lb / chord2 + 2.0 * plastic_axial * y / jnp.sqrt(chord2)
    return 2.0 * plastic_moment / jnp.sqrt(lb**2 - y**2)


def elastic_membrane_load(y, plastic_moment, axial_modulus, half_span):
    """Eq. 25 with the axial force still elastic: n = kappa (s/l_b - 1) instead of n_p.

    p = 2 m_p l_b / (l_b^2 + y^2) + 2 n(y) y / s, s = sqrt(l_b^2 + y^2). With the independent
    yield of the MS-FD bars (Eq. 3) the axial force reaches n_p only at the strain
    n_p / kappa = 1 / (E/Y), i.e. y / l_b = sqrt(2 Y / E) for small y: below that the elastic
    beam follows this curve (bending elasticity neglected), above it Eq. 25. Use
    min(this, Eq. 25) as the elastic-plastic estimate of the approach to Eq. 25.

    **Arguments:** as `beam_central_load`; `axial_modulus` kappa = E b h R / M_pr.
    """
    y = jnp.asarray(y, dtype=float)
    lb = half_span
    chord = jnp.sqrt(lb**2 + y**2)
    axial = axial_modulus * (chord / lb - 1.0)
    return 2.0 * plastic_moment * lb / chord**2 + 2.0 * axial * y / chord


class ParkesSolution(NamedTuple):
    """Parkes' cantilever solution in the beam's own units (L = 1, m = 1, M0 = 1).

    Scalars are floats; the `hinge_*` arrays sample phase I at `hinge_time`.
    """

    final_tip_deflection: float  # W_f / L
    phase_one_tip_deflection: float  # W_1 / L, at the end of phase I
    phase_one_duration: float  # t_1 sqrt(M0 / (m L^3))
    phase_two_duration: float
    root_rotation: float  # theta_f, rad, final rotation at the root hinge
    initial_kinetic_energy: float  # G V0^2 / 2, units M0
    root_energy_fraction: float  # fraction of the initial kinetic energy dissipated at the root
    hinge_time: np.ndarray  # t during phase I
    hinge_position: np.ndarray  # xi / L, hinge distance from the tip
    hinge_tip_velocity: np.ndarray  # W'(t) / (V0 units)
    hinge_tip_deflection: np.ndarray  # W(t) / L


def _phase_one_integral(gamma):
    """I(gamma) = int_0^1 u (2 gamma + u/2) / (gamma + u/2)^3 du, closed form.

    With s = gamma + u/2: I = 4 int_gamma^{gamma+1/2} (1/s - gamma^2/s^3) ds
    = 4 ln(1 + 1/(2 gamma)) + 2 gamma^2 / (gamma + 1/2)^2 - 2. For gamma > 1000 its series
    e^2 - 5 e^3 / 6 + 9 e^4 / 16 - 7 e^5 / 20 + 5 e^6 / 24 (e = 1/gamma) avoids the cancellation.
    """
    if gamma > 1.0e3:
        e = 1.0 / gamma
        return e**2 - 5.0 / 6.0 * e**3 + 9.0 / 16.0 * e**4 - 7.0 / 20.0 * e**5 + 5.0 / 24.0 * e**6
    return 4.0 * math.log1p(0.5 / gamma) + 2.0 * gamma**2 / (gamma + 0.5) ** 2 - 2.0


def parkes_cantilever(mass_ratio, velocity, *, samples: int = 201) -> ParkesSolution:
    """Parkes' rigid-perfectly-plastic, small-deflection cantilever struck at its tip by a mass.

    A cantilever (length L, mass per length m, fully plastic moment M0, root clamped) is struck
    at its free tip by a mass G moving at V0, which sticks. Units: L = m = M0 = 1, so
    ``mass_ratio`` gamma = G / (m L) and ``velocity`` v = V0 sqrt(m L / M0).

    **Phase I** (travelling hinge at distance xi from the tip). The segment tip-hinge rotates
    about the hinge with velocity W' (1 - x/xi) (x from the tip); the rest is at rest. The
    shear force vanishes at the hinge (the moment is a maximum there), so the transverse
    momentum and the angular momentum about the (fixed) point where the hinge is are balanced:

        (G + m xi / 2) W' = G V0,                                  (momentum)
        d/dt (m W' xi^2 / 6) = M0  =>  m xi^2 W' = 6 M0 t.        (angular momentum)

    Hence t(xi) = m G V0 xi^2 / (6 M0 (G + m xi / 2)); the phase ends when xi = L, at
    t_1 = gamma v / (6 (gamma + 1/2)). The tip deflection W_1 = int W' dt = int W' (dt/dxi) dxi:

        W_1 / L = gamma^2 v^2 I(gamma) / 6,
        I(gamma) = 4 ln(1 + 1/(2 gamma)) + 2 gamma^2 / (gamma + 1/2)^2 - 2.

    **Phase II** (rigid rotation about the root hinge). The velocity profile at the end of
    phase I is linear, W'_1 (1 - x/L) with W'_1 = gamma v / (gamma + 1/2) (x now from the root
    end reversed), i.e. a rigid rotation about the root. Its kinetic energy
    T_1 = (G + m L / 3) W'_1^2 / 2 is dissipated by M0 at the root: M0 theta_f = T_1, and the
    tip moves a further L theta_f (small rotations), in t_2 = (G L^2 + m L^3 / 3) W'_1 / (L M0).

    **Result:**

        W_f / L = gamma^2 v^2 [ I(gamma) / 6 + (gamma + 1/3) / (2 (gamma + 1/2)^2) ],

    with the fraction T_1 / K_0 = gamma (gamma + 1/3) / (gamma + 1/2)^2 of K_0 = gamma v^2 / 2
    dissipated at the root (the rest by the travelling hinge). Limits: heavy striker
    (gamma >> 1), W_f -> G V0^2 L / (2 M0) with all of K_0 at the root; light striker
    (gamma -> 0), W_f / L -> (2/3) gamma^2 v^2 (ln(1 / (2 gamma)) + 1/2). This is the solution
    of Jones, Structural Impact, Sect. 3.8 (his mass ratio is m L / G = 1 / gamma), here
    derived afresh; the tests check it against direct quadrature of the phase-I equations and
    against the energy balance (travelling-hinge dissipation int M0 W' / xi dt plus T_1 = K_0).

    **Arguments:**
    - `mass_ratio`: gamma = G / (m L) > 0.
    - `velocity`: v = V0 sqrt(m L / M0) > 0.
    - `samples`: points of the phase-I hinge history.

    **Returns:** a `ParkesSolution`.
    """
    gamma, v = float(mass_ratio), float(velocity)
    if not (gamma > 0 and math.isfinite(gamma)) or not (v > 0 and math.isfinite(v)):
        raise ValueError(
            f"mass_ratio and velocity must be positive and finite, got {mass_ratio!r}, {velocity!r}"
        )
    k0 = 0.5 * gamma * v**2
    w1 = gamma**2 * v**2 * _phase_one_integral(gamma) / 6.0
    tip_velocity_1 = gamma * v / (gamma + 0.5)
    t1_energy = 0.5 * (gamma + 1.0 / 3.0) * tip_velocity_1**2
    theta = t1_energy  # M0 = 1
    t1 = gamma * v / (6.0 * (gamma + 0.5))
    t2 = (gamma + 1.0 / 3.0) * tip_velocity_1
    xi = np.linspace(0.0, 1.0, samples)
    hinge_time = gamma * v * xi**2 / (6.0 * (gamma + 0.5 * xi))
    tip_velocity = gamma * v / (gamma + 0.5 * xi)
    # W(xi) = gamma^2 v^2 / 6 * 4 int_gamma^s (r^2 - gamma^2) / r^3 dr, s = gamma + xi / 2
    s = gamma + 0.5 * xi
    tip_deflection = (
        gamma**2
        * v**2
        / 6.0
        * (4.0 * np.log(s / gamma) + 2.0 * gamma**2 * (1.0 / s**2 - 1.0 / gamma**2))
    )
    return ParkesSolution(
        final_tip_deflection=w1 + theta,
        phase_one_tip_deflection=w1,
        phase_one_duration=t1,
        phase_two_duration=t2,
        root_rotation=theta,
        initial_kinetic_energy=k0,
        root_energy_fraction=t1_energy / k0,
        hinge_time=hinge_time,
        hinge_position=xi,
        hinge_tip_velocity=tip_velocity,
        hinge_tip_deflection=tip_deflection,
    )
