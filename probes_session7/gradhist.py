import sys, time
import jax, jax.numpy as jnp, numpy as np
jax.config.update("jax_enable_x64", True)
import msfd_jax as m, optimise as o
from optimise._graded import _surrogate_grad, quantities
import equinox as eqx
@eqx.filter_jit
def _smoothed(c, problem):
    return quantities(c, problem, sharp=False)[0]
def timed(f):
    t = time.perf_counter(); jax.block_until_ready(f()); return time.perf_counter() - t
p, scales = m.from_si(**dict(m.PAPER_SI, block_mass=67.0))
mesh = m.Mesh()
dt = float(m.critical_step(m.ring_on_beam(p, mesh))) * m.Settings().safety
for hp in [int(a) for a in sys.argv[1:]]:
    problem = o.graded_problem(p, scales, mesh, profile_points=None, settings=m.Settings(dt=dt), bounds=(1.0, 5.0), history_points=hp)
    ms = int(problem.settings.max_steps)
    c = jnp.asarray(np.full(problem.points, 2.5))
    w = {"deflection": jnp.asarray(1.0, jnp.float64)}
    f_s = lambda: _smoothed(c, problem); f_g = lambda: _surrogate_grad(c, w, problem, "deceleration_10ms", ms)
    timed(f_s); timed(f_g)
    s = sorted(timed(f_s) for _ in range(3))[1]; g = sorted(timed(f_g) for _ in range(3))[1]
    print("history_points", hp, "smooth", round(s, 3), "grad", round(g, 3), "ratio", round(g / s, 2), flush=True)
