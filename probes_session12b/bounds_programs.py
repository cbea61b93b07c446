import time, jax
jax.config.update("jax_enable_x64", True)
import jax.numpy as jnp, msfd_jax as m, optimise as o
params, scales = m.from_si(**{**m.PAPER_SI, "block_mass": 67.0})
for b in [(1.0, 5.0), (1.5, 4.0), (1.0, 5.0)]:
    P = o.graded_problem(params, scales, m.Mesh(6, 8, 2), profile_points=3, bounds=b)
    t = time.perf_counter(); o._graded._sharp(jnp.full(3, 2.5), P)[0]["deflection"].block_until_ready()
    print(b, round(time.perf_counter() - t, 2), P.settings.max_steps, float(P.settings.t_max))
