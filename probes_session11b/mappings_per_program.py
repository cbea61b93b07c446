"""Memory mappings a compiled collision program holds (run with the suite's XLA flag:
XLA_FLAGS=--xla_cpu_use_fusion_emitters=false)."""

import msfd_jax as m
from msfd_jax._runtime import mappings

print("start", mappings.usage())
mesh = m.Mesh(6, 8, 2)
for i, t in enumerate([1.0, 1.5, 2.0, 2.5]):  # four distinct programs (history_points differ)
    m.run(settings=m.Settings(t_max=t, history_points=2 + i, shape_times=()), mesh=mesh)
    print(i, mappings.usage())
