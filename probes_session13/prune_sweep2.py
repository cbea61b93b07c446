import time, sys, jax
import msfd_jax as m
from msfd_jax._sweeps import sweep as _sweep
SMALL_MESH = m.Mesh(6, 8, 2)
for g in [float(a) for a in sys.argv[1:]]:
    GRID = dict(thickness_ratio=[0.25, 5.0], axial_constraint=[0.0, 1.0], mass_ratio=[g])
    t = time.perf_counter()
    r = m.sweep(GRID, SMALL_MESH, _sweep.SWEEP_SETTINGS, chunk_size=2)
    print(g, round(time.perf_counter() - t, 1), list(map(int, r["steps"])), list(map(int, r["retries"])), [s[:60] for s in r["message"]], flush=True)
