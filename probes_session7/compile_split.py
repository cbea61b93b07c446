import time, sys, os
import jax
jax.config.update("jax_enable_x64", True)
import msfd_jax as m
from msfd_jax._batched.simulate import _simulate, prepare
for name, mesh in [("small", m.Mesh(6, 8, 2))]:
    scene = m.ring_on_beam(m.CollisionParams(), mesh)
    args = prepare(scene, m.Settings())
    t0 = time.perf_counter(); low = _simulate.lower(*args); t1 = time.perf_counter()
    txt = low.as_text(); 
    comp = low.compile(); t2 = time.perf_counter()
    c = getattr(comp, "_compiled", None) or getattr(comp, "compiled", None); opt = c.as_text() if c is not None else ""
    print(name, os.environ.get("XLA_FLAGS"), "lower", round(t1-t0,2), "compile", round(t2-t1,2), "stablehlo lines", txt.count("\n"), "opt hlo lines", opt.count("\n"), "fusions", opt.count(" fusion("), "whiles", opt.count(" while("), flush=True)
