import numpy as np
import msfd_jax as m
import optimise as o

params, scales = m.from_si(**{**m.PAPER_SI, "block_mass": 67.0})
cond = o.Conditions(velocity=[0.8, 0.9], mass_ratio=[10.0, 10.0])
problem = o.graded_problem(params, scales, m.Mesh(6, 8, 2), profile_points=3, conditions=cond)
front = o.design_front(problem, "beam_mass", [0.9, 1.0], limits={"deflection": 0.2},
                       thickness_bounds=(1.5, 4.0), steps=1)
for d in front:
    print(d.status, d.iterations, d.values["deceleration_10ms"], d.constraints["beam_mass"], d.samples["deflection"])
single = o.design(problem, limits={"deflection": 0.2}, max_beam_mass_ratio=0.9, thickness_bounds=(1.5, 4.0), steps=1)
print("single", single.values["deceleration_10ms"], np.max(np.abs(single.controls - front[0].controls)))
