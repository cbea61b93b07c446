import time, jax
jax.config.update("jax_enable_x64", True)
import jax.numpy as jnp, numpy as np, msfd_jax as m, optimise as o
from optimise._search import _surrogate_jacobian
from optimise._graded import stored_checkpoints
params, scales = m.from_si(**{**m.PAPER_SI, "block_mass": 67.0})
P = o.graded_problem(params, scales, m.Mesh(6, 8, 2), profile_points=3)
c = jnp.full(3, 2.5)
t = time.perf_counter(); s = o._graded._sharp(c, P)[0]; jax.block_until_ready(s); ts = time.perf_counter() - t
t = time.perf_counter(); v, J = _surrogate_jacobian(c, P, ("deceleration_10ms", "deflection"), stored_checkpoints(P)); jax.block_until_ready(J); tj = time.perf_counter() - t
t = time.perf_counter(); jax.block_until_ready(_surrogate_jacobian(c, P, ("deceleration_10ms", "deflection"), stored_checkpoints(P))); tw = time.perf_counter() - t
r = m.run(m.CollisionParams(), m.Mesh(6, 8, 2), m.Settings(t_max=2.0))
print(f"sharp first {ts:.1f} s, jac first {tj:.1f} s, jac warm {tw:.3f} s")
print("sharp", {k: float(x) for k, x in s.items()})
print("J", np.asarray(J).tolist())
print("run", r.fractions, int(r.solution.steps))
