"""Gradient cost against the smoothed forward run: which part of the step makes the backward dear."""
import sys, time, dataclasses
import jax
jax.config.update("jax_enable_x64", True)
import jax.numpy as jnp, numpy as np, equinox as eqx, diffrax
import msfd_jax as m, optimise as o
from optimise._graded import _surrogate_grad, quantities, stored_checkpoints

mesh = m.Mesh(6, 8, 2) if "coarse" in sys.argv else m.Mesh()
hist = int(sys.argv[2]) if len(sys.argv) > 2 else 401
sub = int(sys.argv[3]) if len(sys.argv) > 3 else 8
params, scales = m.from_si(**{**m.PAPER_SI, "block_mass": 67.0})
dt = float(m.critical_step(m.ring_on_beam(params, mesh))) * m.Settings().safety
problem = o.graded_problem(params, scales, mesh, profile_points=None, settings=m.Settings(dt=dt, substeps=sub), bounds=(1.0, 5.0), history_points=hist)
n = problem.points
stored = stored_checkpoints(problem)
c = jnp.full(n, float(params.thickness_ratio))
w = {"deflection": jnp.asarray(1.0)}

@eqx.filter_jit
def smoothed(c, problem):
    return quantities(c, problem, sharp=False)[0]

def t(f, *a, rounds=5):
    jax.block_until_ready(f(*a))
    ts = []
    for _ in range(rounds):
        tick = time.perf_counter(); jax.block_until_ready(f(*a)); ts.append(time.perf_counter() - tick)
    return min(ts)
fs = t(smoothed, c, problem)
g = t(_surrogate_grad, c, w, problem, "deceleration_10ms", stored)
print(f"mesh {mesh.ring_segments} hist {hist} substeps {sub}: smoothed {fs:.4f} s, grad {g:.4f} s, ratio {g/fs:.2f}", flush=True)
from optimise._graded import reduce_surrogate
def fwd_only(c, problem):
    adjoint = diffrax.RecursiveCheckpointAdjoint(stored)
    def weighted(c):
        values, _ = quantities(c, problem, sharp=False, adjoint=adjoint)
        return values["deflection"]
    out, pb = jax.vjp(weighted, c)
    return out, pb
fo = eqx.filter_jit(lambda c, p: fwd_only(c, p)[0])
# the forward pass of the vjp alone (its residuals kept: return them to stop DCE)
fo2 = eqx.filter_jit(lambda c, p: fwd_only(c, p))
print("vjp forward (residuals returned):", round(t(fo2, c, problem), 4))
