import numpy as np, jax.numpy as jnp, msfd_jax as m, optimise as o, time
from optimise._graded import _sharp, project_budget
p, scales = m.from_si(**dict(m.PAPER_SI, block_mass=67.0))
mesh = m.Mesh()
BOUNDS=(1.0,5.0); BUDGET=0.9
pr = o.graded_problem(p, scales, mesh, profile_points=10, bounds=BOUNDS)
row = pr.mass_row()
start = project_budget(np.full(10, 2.5), *BOUNDS, row, BUDGET)
def ev(c):
    v,(code,_) = _sharp(jnp.asarray(c), pr)
    return float(v["deceleration_10ms"]), float(v["deflection"]), float(row@c)
print("start", start, ev(start))
for i in range(10):
    for d in (0.25, -0.25, 0.05, -0.05):
        c = start.copy(); c[i]+=d
        print(i, d, ["%.4g"%x for x in ev(c)])
