import sys, time, numpy as np, jax
import msfd_jax as m
from jax._src import monitoring
from msfd_jax._sweeps import queue as q
tot = {"n": 0, "s": 0.0}
def lis(event, duration, **kw):
    if "backend_compile" in event:
        tot["n"] += 1; tot["s"] += duration; print(f"   {kw.get('fun_name')} {duration:.2f}")
monitoring.register_event_duration_secs_listener(lis)
grid = dict(thickness_ratio=list(np.linspace(0.5, 4.0, 20)), velocity=[0.6, 0.82])
t = time.perf_counter()
r = m.sweep(grid, m.Mesh(), chunk_size=16)
print(f"wall {time.perf_counter()-t:.1f} s, compiles {tot['n']} ({tot['s']:.1f} s)")
out = {k: np.asarray(r[k]) for k in r.columns if np.asarray(r[k]).dtype.kind in "fiub" and k != "wall_time_s"} if hasattr(r, "columns") else {k: np.asarray(r[k]) for k in r if np.asarray(r[k]).dtype.kind in "fiub" and k != "wall_time_s"}
np.savez(sys.argv[1], **out)
