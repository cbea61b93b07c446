import sys, time
import jax, jax.numpy as jnp, numpy as np
jax.config.update("jax_enable_x64", True)
import msfd_jax as m, optimise as o
from optimise._graded import _sharp, _surrogate_grad, quantities
import equinox as eqx

@eqx.filter_jit
def _smoothed(c, problem):
    return quantities(c, problem, sharp=False)[0]

def timed(f, *a):
    t = time.perf_counter(); out = jax.block_until_ready(f(*a)); return out, time.perf_counter() - t

p, scales = m.from_si(**dict(m.PAPER_SI, block_mass=67.0))
mesh = m.Mesh()
dt = float(m.critical_step(m.ring_on_beam(p, mesh))) * m.Settings().safety
problem = o.graded_problem(p, scales, mesh, profile_points=None, settings=m.Settings(dt=dt), bounds=(1.0, 5.0))
n = problem.points
ms = int(problem.settings.max_steps)
print("max_steps", ms, "points", n, flush=True)
c = jnp.asarray(np.full(n, float(p.thickness_ratio)))
w = {"deflection": jnp.asarray(1.0, jnp.float64)}
progs = {"sharp": lambda: _sharp(c, problem), "smooth": lambda: _smoothed(c, problem),
         "rev_None": lambda: _surrogate_grad(c, w, problem, "deceleration_10ms", None),
         "rev_max": lambda: _surrogate_grad(c, w, problem, "deceleration_10ms", ms)}
for k, f in progs.items():
    _, t = timed(f); print(k, "first", round(t, 1), flush=True)
ts = {k: [] for k in progs}
for r in range(3):
    for k, f in progs.items():
        ts[k].append(timed(f)[1])
med = {k: sorted(v)[1] for k, v in ts.items()}
print({k: round(v, 3) for k, v in med.items()})
print("ratios vs smooth", {k: round(v / med["smooth"], 2) for k, v in med.items()})
g1 = np.asarray(progs["rev_None"]()[1]); g2 = np.asarray(progs["rev_max"]()[1])
print("grad diff", np.max(np.abs(g1 - g2)) / np.max(np.abs(g1)))
