import time, sys, numpy as np, jax, jax.numpy as jnp
import msfd_jax as m, optimise as o
from optimise._front import _sharp_lanes
p, scales = m.from_si(**dict(m.PAPER_SI, block_mass=67.0))
found = np.load("/tmp/p/prof_x2_K6.npy")
d = m.Mesh()
unif = [1.855, 2.184, 2.25, 2.5]
for name, mesh in [("ring x2", m.Mesh(d.ring_segments*2, d.beam_contact_segments, d.beam_outer_segments, d.contact_region, d.collapse_contacts)),
                   ("beam x2", m.Mesh(d.ring_segments, d.beam_contact_segments*2, d.beam_outer_segments*2, d.contact_region, d.collapse_contacts))]:
    t = time.perf_counter()
    prob = o.graded_problem(p, scales, mesh, profile_points=None, bounds=(1.0, 5.0))
    n = m.beam_segments(mesh)
    fp = found if n == 50 else found[::2]
    rows = [fp] + [np.full(n, u) for u in unif]
    vals, (codes, _) = _sharp_lanes(jnp.asarray(np.array(rows)), prob)
    v = {k: np.asarray(x) for k, x in vals.items()}
    print(name, mesh, f"{time.perf_counter()-t:.0f} s", set(np.asarray(codes).tolist()))
    for i, nm in enumerate(["design2x"] + unif):
        print(f"   {nm}: defl {v['deflection'][i]:.4f} dec {v['deceleration_10ms'][i]:.1f}", flush=True)
