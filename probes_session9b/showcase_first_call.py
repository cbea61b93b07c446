import jax, time
import msfd_jax as m
t=time.perf_counter(); m.run(m.CollisionParams()); print("first", time.perf_counter()-t)
