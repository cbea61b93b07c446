"""Probe: optimise.design's two methods (SLSQP on the surrogate, Adam augmented Lagrangian) on the
paper's SI design problem, K x deflection limit, same start, sharp values. One core."""
import json, sys, time, numpy as np, msfd_jax as m, optimise as o
p, scales = m.from_si(**dict(m.PAPER_SI, block_mass=67.0))
rows = []
for K in (6, 10):
    pr = o.graded_problem(p, scales, m.Mesh(), profile_points=K, bounds=(1.0, 5.0))
    for lim in (0.14, 0.16, 0.20):
        for method in ("slsqp", "adam"):
            t = time.perf_counter()
            r = o.design(pr, limits={"deflection": lim}, max_beam_mass_ratio=0.9,
                         thickness_bounds=(1.0, 5.0), steps=30, method=method)
            row = dict(K=K, limit=lim, method=method, status=r.status, points=r.iterations,
                       evaluations=r.evaluations, wall=round(time.perf_counter() - t, 1),
                       decel=r.values["deceleration_10ms"], defl=r.values["deflection"],
                       mass=r.values["beam_mass"])
            print(json.dumps(row), flush=True)
            rows.append(row)
json.dump(rows, open(sys.argv[1], "w"), indent=1)
