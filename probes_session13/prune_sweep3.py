import time, sys, jax, logging
import msfd_jax as m
from msfd_jax._sweeps import sweep as _sweep
from jax._src import monitoring
tot = {}
def lis(event, duration, **kw):
    if "compil" in event or "trac" in event or "lower" in event:
        tot[event] = tot.get(event, 0) + duration
        if duration > 0.5: print(f"  {event} {duration:.2f}", kw, flush=True)
monitoring.register_event_duration_secs_listener(lis)
SMALL_MESH = m.Mesh(6, 8, 2)
GRID = dict(thickness_ratio=[0.25, 5.0], axial_constraint=[0.0, 1.0], mass_ratio=[40.0])
t = time.perf_counter()
r = m.sweep(GRID, SMALL_MESH, _sweep.SWEEP_SETTINGS, chunk_size=2)
print(round(time.perf_counter() - t, 1)); print({k: round(v, 1) for k, v in tot.items()})
