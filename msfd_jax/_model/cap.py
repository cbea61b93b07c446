"""The default time cap from the mechanics: how long the block takes to stop.

With ``Settings(t_max=None)`` (the default) each collision's cap is

    t_cap = clip(CAP_FACTOR * t_stop + CAP_MARGIN, T_MAX_FLOOR, T_MAX_CEILING),

t_stop the time in which the half model's momentum M v0 (M = g + the quarter ring's mass) is
taken up by the rigid-plastic resistances of the two structures, which act in series:

- the ring crushes at half the half ring's collapse load, p_0 / 2 = 2 (1 + sqrt 2) m_pr
  (Appendix, `studies/references/appendix.py`), over a stroke of at most R (the quarter ring's
  height): it slows the block from v0 to v1 = sqrt(max(v0^2 - p_0 R / M, 0)) in
  t_ring = M (v0 - v1) / (p_0 / 2);
- the beam then stops the block from v1: in bending at half the three-hinge load of a simply
  supported beam, m_pb / L_b, in t_bend = M v1 / (m_pb / L_b); a held beam (axial constraint)
  also as a plastic string (force n_pb w / L_b grows with the deflection w: the block is
  stopped in a quarter period, t_string = pi/2 sqrt(M L_b / n_pb)), taking the shorter time;
- a beam weaker than the ring goes first and alone: t_beam(v0).

t_stop = max(t_ring + t_beam(v1), t_beam(v0)). The floor is the former fixed cap (10): a design
whose cap is the floor runs exactly as before (same clock, steps and histories; the
showcase's t_stop is 1.96 and it ends at 3.28); one with a larger cap keeps the floor's step
grid (`_batched.engine.make_clock`), so if it stops before 10 it takes the same steps, only its
history samples spread over [0, cap]. CAP_FACTOR and CAP_MARGIN are set from the
reliability benchmark: with the former fixed cap, 99 % of the settled designs ended by
3.25 t_stop + 2 (results/reliability_before.json at ee23c14^); with this cap none of 300
designs reached it (benchmarks/results/reliability.md). The estimate is pessimistic for free
thin beams (t_stop in the thousands where runs settled by tau = 37), hence the ceiling; it
also bounds the cost of designs whose beam cannot stop the block (a free thin beam under a
heavy block bends on until it would pass its supports, which the model does not represent):
they report "time limit".
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np

from .scene import Scene

T_MAX_FLOOR = 10.0  # the former fixed default cap
T_MAX_CEILING = 100.0
CAP_FACTOR = 3.0
CAP_MARGIN = 2.0
RING_COLLAPSE = 4.0 * (1.0 + math.sqrt(2.0))  # p_0 / m_pr of the half ring (Appendix)
RING_STROKE = 1.0  # R: the quarter ring's height, the most it can be crushed


def stopping_time(scene: Scene, xp=jnp):
    """t_stop of a ring-on-beam scene (see the module docstring); jit/vmap-compatible.

    `xp` is the array module: jax.numpy (traced or eager), or numpy for a scene of host
    arrays (`concrete_time_cap`: one concrete cap without eager jax ops).
    """
    ring = scene.chains[scene.chain_index("ring")]
    beam = scene.chains[scene.chain_index("beam")]
    v_ring = scene.initial_velocity[scene.chain_index("ring")]
    mass = xp.sum(ring.mass)  # g + the quarter ring
    v0 = xp.abs(xp.sum(ring.mass * v_ring[:, 1])) / mass
    p_ring = 0.5 * RING_COLLAPSE * ring.section.plastic_moment
    v1 = xp.sqrt(xp.maximum(v0**2 - 2.0 * p_ring * RING_STROKE / mass, 0.0))
    t_ring = mass * (v0 - v1) / p_ring
    span = beam.reference[-1, 0]
    # a graded beam: its weakest section (the longest stop, so the cap covers the run)
    p_bend = xp.min(beam.section.plastic_moment) / span
    t_string = 0.5 * math.pi * xp.sqrt(mass * span / xp.min(beam.section.plastic_axial))
    held = beam.free[-1, 0] < 0.5

    def t_beam(v):
        t_bend = mass * v / p_bend
        return xp.where(v > 0, xp.where(held, xp.minimum(t_bend, t_string), t_bend), 0.0)

    return xp.maximum(t_ring + t_beam(v1), t_beam(v0))


def time_cap(scene: Scene, xp=jnp):
    """The default cap on tau for `scene` (``Settings(t_max=None)``); jit/vmap-compatible.

    A scene without both a ring and a beam (plate, cantilever, driven beam) gets the floor.
    `xp` as in `stopping_time`.
    """
    if scene.chain_index("ring") is None or scene.chain_index("beam") is None:
        return xp.asarray(T_MAX_FLOOR)
    cap = CAP_FACTOR * stopping_time(scene, xp) + CAP_MARGIN
    return xp.clip(cap, T_MAX_FLOOR, T_MAX_CEILING)


def concrete_time_cap(scene: Scene) -> float:
    """`time_cap` of a concrete scene as a float, the same value as eager jax ops give.

    Each eager jax op of `time_cap` loads its own small program (26 of them: ~0.35 s of a new
    process). numpy on the host gives the same cap wherever it is clipped to the floor or the
    ceiling with room to spare (the showcase, and most designs); numpy's sums may differ from
    XLA's in the last bits, so a cap in between is computed with jax as before.
    """
    host = jax.tree_util.tree_map(np.asarray, scene)
    if scene.chain_index("ring") is not None and scene.chain_index("beam") is not None:
        unclipped = CAP_FACTOR * float(stopping_time(host, np)) + CAP_MARGIN
        if unclipped < T_MAX_FLOOR * (1.0 - 1e-9):
            return T_MAX_FLOOR
        if unclipped > T_MAX_CEILING * (1.0 + 1e-9):
            return T_MAX_CEILING
    else:
        return T_MAX_FLOOR
    return float(time_cap(scene))


def expected_duration(scene: Scene):
    """A rough guess of how long `scene` runs: the derived cap without its floor (the floor
    for a scene without ring and beam). It orders a sweep's queue longest first, so that the
    longest collisions do not start last and run alone in the tail; jit/vmap-compatible."""
    if scene.chain_index("ring") is None or scene.chain_index("beam") is None:
        return jnp.asarray(T_MAX_FLOOR)
    return jnp.minimum(CAP_FACTOR * stopping_time(scene) + CAP_MARGIN, T_MAX_CEILING)
