import time, jax, jax.numpy as jnp, numpy as np, diffrax, equinox as eqx
import msfd_jax as m, optimise as o
from optimise._graded import quantities, stored_checkpoints, _surrogate_grad
from optimise._search import _surrogate_jacobian
p, scales = m.from_si(**dict(m.PAPER_SI, block_mass=67.0))
prob = o.graded_problem(p, scales, m.Mesh(6, 8, 2), profile_points=3)
c = jnp.full(3, 2.5); names = ("deceleration_10ms", "deflection"); ck = stored_checkpoints(prob)
def t(label, f, *a):
    tick = time.perf_counter(); low = f.lower(*a) if hasattr(f, "lower") else None
    print(label, "trace+lower", round(time.perf_counter() - tick, 2), flush=True)
t("jacobian", _surrogate_jacobian, c, prob, names, ck)
w = {"deceleration_10ms": jnp.asarray(1e-3), "deflection": jnp.asarray(0.0)}
t("grad", _surrogate_grad, c, w, prob, "deceleration_10ms", ck)
adjoint = diffrax.RecursiveCheckpointAdjoint(ck)
@eqx.filter_jit
def jac_seq(controls, problem):
    def rows(c):
        values, _ = quantities(c, problem, sharp=False, adjoint=adjoint)
        return jnp.stack([values[k] for k in names])
    values, pullback = jax.vjp(rows, controls)
    return values, jnp.stack([pullback(e)[0] for e in jnp.eye(2)])
t("jac sequential", jac_seq, c, prob)
import sys
def full(label, f, *a):
    tick = time.perf_counter(); comp = f.lower(*a).compile(); tc = time.perf_counter() - tick
    out = jax.block_until_ready(f(*a)); 
    ts = []
    for _ in range(3):
        tick = time.perf_counter(); out = jax.block_until_ready(f(*a)); ts.append(time.perf_counter() - tick)
    print(f"{label}: trace+lower+compile {tc:.2f} s, run {min(ts):.3f} s", flush=True)
    return out
mesh = m.Mesh() if "paper" in sys.argv else m.Mesh(6, 8, 2)
prob = o.graded_problem(p, scales, mesh, profile_points=6 if "paper" in sys.argv else 3)
c = jnp.full(prob.points, 2.5); ck = stored_checkpoints(prob)
adjoint = diffrax.RecursiveCheckpointAdjoint(ck)
a = full("vmapped", _surrogate_jacobian, c, prob, names, ck)
b = full("sequential", jac_seq, c, prob)
print("max rel diff", float(jnp.max(jnp.abs(a[1] - b[1]) / (jnp.abs(a[1]) + 1e-300))), "values equal", bool(jnp.all(a[0] == b[0])))
