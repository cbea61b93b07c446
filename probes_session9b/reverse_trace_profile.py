import cProfile, pstats, time, jax
jax.config.update("jax_enable_x64", True)
import msfd_jax as m, optimise as o
from optimise import _gradient as g
mesh = m.Mesh(8, 10, 3)
design = o.Design(thickness_ratio=2.5)
box = o.default_box(design)
problem = o.make_problem(m.CollisionParams(), mesh, m.Settings(t_max=4.0), box)
goal = o.objective(o.TargetShare("beam", 0.45), o.ShareAtMost("ring", 0.55))
design = g.arrays(design)
sm = g.arrays((0.05, 0.01))
fr, _, _ = g._evaluate(design, problem, *sm)
val, w = g.objective_value_and_grad(goal, fr)
t = time.perf_counter()
pr = cProfile.Profile(); pr.enable()
lowered = g._reverse.__wrapped__ if hasattr(g._reverse, "__wrapped__") else None
jax.jit(lambda d, w, s1, s2: g._reverse.__wrapped__(d, w, problem, s1, s2) if False else None)
out = eqx_lower = None
import equinox as eqx
f = lambda d, w, s1, s2: g._reverse(d, w, problem, s1, s2)
jax.make_jaxpr(lambda d, w, s1, s2: jax.tree_util.tree_leaves(g._partition(d, problem, s1, s2, __import__("diffrax").RecursiveCheckpointAdjoint()))[0])  
# trace the reverse function body via make_jaxpr of the unjitted value_and_grad
import diffrax
def weighted(d, s1, s2):
    fractions, aux = g._partition(d, problem, s1, s2, diffrax.RecursiveCheckpointAdjoint(None))
    return sum(w[k] * fractions[k] for k in w)
jx = jax.make_jaxpr(jax.grad(weighted))(design, *sm)
pr.disable()
print("trace", time.perf_counter() - t)
pstats.Stats(pr).sort_stats("cumulative").print_stats(45)
