"""Probe: SLSQP, then Adam from SLSQP's design with the points left of 30 (the hybrid), on the
paper's SI case; compare with each method alone (benchmarks/probe_design_methods, 3cef5dd)."""
import json, sys, time, numpy as np, msfd_jax as m, optimise as o
p, scales = m.from_si(**dict(m.PAPER_SI, block_mass=67.0))
rows = []
for K in (6, 10):
    pr = o.graded_problem(p, scales, m.Mesh(), profile_points=K, bounds=(1.0, 5.0))
    for lim in (0.14, 0.16, 0.20):
        kw = dict(limits={"deflection": lim}, max_beam_mass_ratio=0.9, thickness_bounds=(1.0, 5.0))
        t = time.perf_counter()
        a = o.design(pr, steps=30, **kw)
        left = max(1, 30 - a.iterations)
        b = o.design(pr, steps=left, method="adam", start=a.controls, **kw)
        best = min([r for r in (a, b) if r.status != "infeasible"] or [a], key=lambda r: r.values["deceleration_10ms"])
        row = dict(K=K, limit=lim, slsqp=a.values["deceleration_10ms"], slsqp_points=a.iterations,
                   slsqp_status=a.status, adam_after=b.values["deceleration_10ms"], adam_status=b.status,
                   adam_points=b.iterations, hybrid=best.values["deceleration_10ms"],
                   hybrid_deflection=best.values["deflection"], wall=round(time.perf_counter() - t, 1))
        print(json.dumps(row), flush=True)
        rows.append(row)
json.dump(rows, open(sys.argv[1], "w"), indent=1)
