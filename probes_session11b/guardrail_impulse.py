"""The guardrail notebook's collision: the engine's impulse (sum of |pair force| x h) against
the ring and block's change of momentum in the impact direction (tests/test_si.py's check)."""

import math
import os

import numpy as np

import msfd_jax as m

steel = dict(youngs_modulus=210e9, yield_stress=355e6, density=7850.0)
ring = dict(radius=0.6, width=0.3, ring_thickness=0.03)
ring_mass = math.pi * ring["radius"] * steel["density"] * ring["width"] * ring["ring_thickness"]
RAIL = dict(**steel, **ring, beam_thickness=0.10, beam_width=0.30, beam_half_span=2.0,
            impact_speed=100 / 3.6, block_mass=1500.0 - ring_mass)  # notebooks/guardrail.py
mesh = m.Mesh(6, 8, 2) if os.environ.get("MSFD_GUARDRAIL_FULL") != "1" else m.Mesh()
collision = m.run_si(mesh, m.Settings(t_max=6.0, history_points=301, shape_times=(1.0,)), **RAIL)
sol, scene, sc, si = collision.solution, collision.scene, collision.scales, collision.si
i = scene.chain_index("ring")
v0 = np.asarray(scene.initial_velocity[i])[:, 1]
v1 = np.asarray(sol.final.v[i])[:, 1]
momentum = 2 * abs(float(np.sum(np.asarray(scene.chains[i].mass) * (v1 - v0)))) * sc.force * sc.time
impulse = si["mean_contact_force_N"] * si["contact_duration_s"]
for k in ("peak_contact_force_N", "mean_contact_force_N", "contact_duration_s", "duration_s"):
    print(f"{k:<24} {si[k]:.4g}")
print(f"impulse {impulse:.4g} N s, momentum change {momentum:.4g} N s, ratio {impulse / momentum:.3f}")
print(f"whole-collision average force 1500 kg x v0 / duration: {1500 * RAIL['impact_speed'] / si['duration_s']:.3g} N")
print(collision.message[:300])
