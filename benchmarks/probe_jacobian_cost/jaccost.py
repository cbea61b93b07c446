import time, jax, jax.numpy as jnp, numpy as np, msfd_jax as m, optimise as o
from optimise._graded import _surrogate_grad, stored_checkpoints, _sharp
from optimise._search import _surrogate_jacobian
p, scales = m.from_si(**dict(m.PAPER_SI, block_mass=67.0))
pr = o.graded_problem(p, scales, m.Mesh(), bounds=(1.0, 5.0))
print("max_steps", pr.settings.max_steps, "dt", pr.settings.dt)
c = jnp.asarray([3.359, 2.460, 1.556, 2.201, 2.184, 2.340])
st = stored_checkpoints(pr)
w = {"deceleration_10ms": jnp.asarray(1e-3), "deflection": jnp.asarray(1.0)}
names = ("deceleration_10ms", "deflection")
fs = {"sharp": lambda: _sharp(c, pr), "grad": lambda: _surrogate_grad(c, w, pr, "deceleration_10ms", st),
      "jac": lambda: _surrogate_jacobian(c, pr, names, st)}
for k, f in fs.items():
    t = time.perf_counter(); jax.block_until_ready(f()); print(k, "first", round(time.perf_counter() - t, 1), flush=True)
for r in range(3):
    for k, f in fs.items():
        t = time.perf_counter(); jax.block_until_ready(f()); print(k, round(time.perf_counter() - t, 3), flush=True)
