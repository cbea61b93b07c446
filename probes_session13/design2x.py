import time, sys, numpy as np, jax, jax.numpy as jnp
import msfd_jax as m, optimise as o
from optimise._front import _sharp_lanes
p, scales = m.from_si(**dict(m.PAPER_SI, block_mass=67.0))
f = int(sys.argv[1]); K = int(sys.argv[2]) if len(sys.argv) > 2 else 6
mesh = m.Mesh().refined(f)
t = time.perf_counter()
prob = o.graded_problem(p, scales, mesh, profile_points=K, bounds=(1.0, 5.0))
def prog(i, d): print(f"  [{time.perf_counter()-t:6.1f} s] {i} {d}", flush=True)
r = o.design(prob, limits={"deflection": 0.16}, max_beam_mass_ratio=0.9, steps=30, progress=prog)
print(f"mesh x{f} K={K}: {time.perf_counter()-t:.1f} s", r.status, r.evaluations)
prof = np.asarray(r.thickness_profile)
print("profile", np.round(prof, 3).tolist())
print("values", r.values if hasattr(r, "values") else r)
np.save(f"/tmp/p/prof_x{f}_K{K}.npy", prof)
