import sys, time
import jax
jax.config.update("jax_enable_x64", True)
jax.config.update("jax_compilation_cache_dir", sys.argv[1])
jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.5)
from msfd_jax._sweeps import queue as q
orig = q._SweepQueue.programs_for
def pf(self, size, state):
    t = time.perf_counter(); r = orig(self, size, state)
    print("  programs_for", size, "mesh", self.mesh.ring_segments, "took", round(time.perf_counter()-t,2), "make_times", [round(x,2) for x in self.make_times], flush=True)
    return r
q._SweepQueue.programs_for = pf
from msfd_jax.studies.reproduce import load
import tempfile; from pathlib import Path
d = Path(tempfile.mkdtemp())
for name in ["fig10", "fig13_14", "fig16", "fig17"]:
    t = time.perf_counter(); load(name)(True, d); print(name, round(time.perf_counter() - t, 1), flush=True)
