import time, sys, numpy as np, msfd_jax as m, optimise as o
p, scales = m.from_si(**dict(m.PAPER_SI, block_mass=67.0))
K = int(sys.argv[1]); pat = int(sys.argv[2]); o._graded.PEAK_WIDTH = float(sys.argv[3])
pr = o.graded_problem(p, scales, m.Mesh(), profile_points=K, bounds=(1.0, 5.0))
t = time.perf_counter()
r = o.design(pr, limits={"deflection": 0.16}, max_beam_mass_ratio=0.9, thickness_bounds=(1.0, 5.0), steps=40, patience=pat)
print(K, r.status, r.iterations, r.evaluations, round(time.perf_counter()-t,1), r.values["deceleration_10ms"], r.values["deflection"], r.values["beam_mass"], flush=True)
f = lambda v: round(v, 4) if np.isfinite(v) else "fail"
print("  objs", [(round(h["objective"]) if np.isfinite(h["objective"]) else "F", f(h["violation"])) for h in r.history])
