"""Is the gradient's cost over the smoothed forward run in the inner Verlet loop (substeps)?"""
import time, sys
import numpy as np, jax, jax.numpy as jnp, equinox as eqx
import msfd_jax as m, optimise as o
from optimise._graded import _surrogate_grad, quantities, stored_checkpoints

@eqx.filter_jit
def smoothed(c, problem):
    return quantities(c, problem, sharp=False)

def warm(f, *a, n=3):
    jax.block_until_ready(f(*a))
    ts = []
    for _ in range(n):
        t = time.perf_counter(); jax.block_until_ready(f(*a)); ts.append(time.perf_counter() - t)
    return float(np.median(ts))

p, scales = m.from_si(**dict(m.PAPER_SI, block_mass=67.0))
for sub in (8, 1):
    problem = o.graded_problem(p, scales, m.Mesh(), bounds=(1.0, 5.0), settings=m.Settings(substeps=sub))
    c = jnp.full(problem.points, 2.5)
    w = {"deceleration_10ms": jnp.asarray(1e-3, jnp.float64), "deflection": jnp.asarray(1.0, jnp.float64)}
    tf = warm(smoothed, c, problem)
    tg = warm(_surrogate_grad, c, w, problem, "deceleration_10ms", stored_checkpoints(problem))
    print(f"substeps {sub}: max_steps {problem.settings.max_steps}, smoothed forward {tf:.3f} s, gradient {tg:.3f} s, ratio {tg/tf:.2f}", flush=True)
