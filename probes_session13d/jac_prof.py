import cProfile, pstats, time, jax, jax.numpy as jnp
import msfd_jax as m, optimise as o
from optimise._graded import stored_checkpoints
from optimise._search import _surrogate_jacobian
p, scales = m.from_si(**dict(m.PAPER_SI, block_mass=67.0))
prob = o.graded_problem(p, scales, m.Mesh(6, 8, 2), profile_points=3)
c = jnp.full(3, 2.5); names = ("deceleration_10ms", "deflection"); ck = stored_checkpoints(prob)
pr = cProfile.Profile(); pr.enable()
_surrogate_jacobian.lower(c, prob, names, ck)
pr.disable()
st = pstats.Stats(pr); st.sort_stats("cumulative").print_stats(45)
