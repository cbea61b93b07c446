import time, sys, jax, jax.numpy as jnp, diffrax, equinox as eqx
import msfd_jax as m, optimise as o
from optimise._graded import quantities, stored_checkpoints, _surrogate_grad
from optimise._search import _surrogate_jacobian
p, scales = m.from_si(**dict(m.PAPER_SI, block_mass=67.0))
prob = o.graded_problem(p, scales, m.Mesh(6, 8, 2), profile_points=3)
c = jnp.full(3, 2.5); names = ("deceleration_10ms", "deflection"); ck = stored_checkpoints(prob)
w = {"deceleration_10ms": jnp.asarray(1e-3), "deflection": jnp.asarray(0.0)}
def t(label, f, *a):
    tick = time.perf_counter(); f.lower(*a); print(label, "trace+lower", round(time.perf_counter() - tick, 2), flush=True)
order = sys.argv[1:]
for k in order:
    if k == "grad": t("grad", _surrogate_grad, c, w, prob, "deceleration_10ms", ck)
    else: t("jacobian", _surrogate_jacobian, c, prob, names, ck)
