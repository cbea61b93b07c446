import time, sys
import jax
jax.config.update("jax_enable_x64", True)
jax.config.update("jax_compilation_cache_dir", sys.argv[1])
jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.5)
import jax.numpy as jnp
import msfd_jax as m, optimise as o
from optimise._search import _surrogate_jacobian
from optimise._graded import stored_checkpoints
import logging
saved = []
jax.monitoring.register_event_duration_secs_listener(lambda e, d, **k: saved.append(d) if "saved" in e else None)
params, scales = m.from_si(**{**m.PAPER_SI, "block_mass": 67.0})
problem = o.graded_problem(params, scales, m.Mesh(6, 8, 2), profile_points=3)
c = jnp.full(3, 2.5)
t = time.perf_counter(); o._graded._sharp(c, problem)[0]["deflection"].block_until_ready(); print("sharp first", round(time.perf_counter()-t,1), "saved", round(sum(saved),1)); saved.clear()
t = time.perf_counter(); o._graded._sharp(c, problem)[0]["deflection"].block_until_ready(); print("sharp warm", round(time.perf_counter()-t,2))
st = stored_checkpoints(problem)
t = time.perf_counter(); _surrogate_jacobian(c, problem, ("deceleration_10ms", "deflection"), st)[1].block_until_ready(); print("jac first", round(time.perf_counter()-t,1), "saved", round(sum(saved),1))
t = time.perf_counter(); _surrogate_jacobian(c, problem, ("deceleration_10ms", "deflection"), st)[1].block_until_ready(); print("jac warm", round(time.perf_counter()-t,2))
