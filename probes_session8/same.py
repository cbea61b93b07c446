import sys, json
if sys.argv[1] == "old":
    sys.path.insert(0, "/tmp/probe/old_opt")
import jax.numpy as jnp, numpy as np
import msfd_jax as m, optimise as o
print(o.__file__, file=sys.stderr)
MESH = m.Mesh(6, 8, 2)
params, scales = m.from_si(**{**m.PAPER_SI, "block_mass": 67.0})
problem = o.graded_problem(params, scales, MESH, profile_points=3)
start, _ = o._graded._sharp(jnp.full(3, 2.5), problem)
limit = 1.02 * float(start["deflection"])
r = o.design(problem, limits={"deflection": limit}, max_beam_mass_ratio=1.0, thickness_bounds=(1.5, 4.0), steps=3)
out = {"status": r.status, "controls": r.controls.tolist(), "values": r.values, "evaluations": r.evaluations,
       "iterations": r.iterations, "objs": [h["objective"] for h in r.history], "ctrl_hist": [h["controls"] for h in r.history],
       "constraints": r.constraints, "start": r.start}
json.dump(out, open(f"/tmp/probe/same_{sys.argv[1]}.json", "w"), indent=1)
