import time, sys, numpy as np, jax, jax.numpy as jnp
import msfd_jax as m, optimise as o
from optimise._front import _sharp_lanes
p, scales = m.from_si(**dict(m.PAPER_SI, block_mass=67.0))
prof = np.load(sys.argv[1]); base = int(sys.argv[2])
grid = np.linspace(1.0, 2.25, 20)
for f in [int(a) for a in sys.argv[3:]]:
    mesh = m.Mesh().refined(f); rep = f // base
    t = time.perf_counter()
    prob = o.graded_problem(p, scales, mesh, profile_points=None, bounds=(1.0, 5.0))
    rows = [np.repeat(prof, rep)] + [np.full(25 * f, u) for u in grid]
    vals, (codes, _) = _sharp_lanes(jnp.asarray(np.array(rows)), prob)
    v = {k: np.asarray(x) for k, x in vals.items()}
    ok = np.flatnonzero(v["deflection"][1:] <= 0.16)
    j = ok[np.argmin(v["deceleration_10ms"][1:][ok])]
    bu = v["deceleration_10ms"][1 + j]
    print(f"mesh x{f} ({time.perf_counter()-t:.0f} s) codes {set(np.asarray(codes).tolist())}: design defl {v['deflection'][0]:.4f} dec {v['deceleration_10ms'][0]:.1f} mass {v['beam_mass'][0]:.3f}; best uniform h {grid[j]:.3f} defl {v['deflection'][1+j]:.4f} dec {bu:.1f}; gain {100*(1-v['deceleration_10ms'][0]/bu):.1f} %", flush=True)
