import time, sys, numpy as np, jax, jax.numpy as jnp
import msfd_jax as m, optimise as o
from optimise._front import _sharp_lanes
p, scales = m.from_si(**dict(m.PAPER_SI, block_mass=67.0))
found = [3.284, 3.134, 2.984, 2.834, 2.685, 2.535, 2.385, 2.234, 2.083, 1.933, 1.782, 1.631, 1.610, 1.717, 1.825, 1.932, 2.040, 2.147, 2.200, 2.197, 2.192, 2.187, 2.210, 2.262, 2.314]
unif = [1.855, 2.053, 2.184, 2.25, 2.5]
for f in [int(a) for a in sys.argv[1:]]:
    mesh = m.Mesh().refined(f)
    t = time.perf_counter()
    prob = o.graded_problem(p, scales, mesh, profile_points=None, bounds=(1.0, 5.0))
    rows = [np.repeat(found, f)] + [np.full(25 * f, u) for u in unif]
    vals, (codes, _) = _sharp_lanes(jnp.asarray(np.array(rows)), prob)
    vals = {k: np.asarray(v) for k, v in vals.items()}
    print(f"mesh x{f} ({time.perf_counter()-t:.1f} s) codes {np.asarray(codes)}")
    for i, name in enumerate(["found"] + [f"u{u}" for u in unif]):
        print(f"  {name:8s} defl {vals['deflection'][i]:.4f}  dec {vals['deceleration_10ms'][i]:7.1f}  mass {vals['beam_mass'][i]:.3f}  Fc {vals['contact_force'][i]:.4g}", flush=True)
