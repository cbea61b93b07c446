import jax.numpy as jnp, numpy as np, time
import msfd_jax as m, optimise as o
MESH = m.Mesh(6, 8, 2)
params, scales = m.from_si(**{**m.PAPER_SI, "block_mass": 67.0})
problem = o.graded_problem(params, scales, MESH, profile_points=3)
start, _ = o._graded._sharp(jnp.full(3, 2.5), problem)
limit = 1.02 * float(start["deflection"])
kw = dict(max_beam_mass_ratio=1.0, thickness_bounds=(1.5, 4.0), steps=3)
single = o.design(problem, limits={"deflection": limit}, **kw)
front = o.design_front(problem, "deflection", [limit, 1.25 * limit], **kw)
s = front[0]
print("controls rel", np.max(np.abs(s.controls - single.controls) / np.abs(single.controls)))
for k in ("deceleration_10ms", "deflection", "beam_mass"):
    print(k, abs(s.values[k] / single.values[k] - 1))
print([d.status for d in front], [d.iterations for d in front], [d.values["deceleration_10ms"] for d in front])
