import sys, numpy as np, jax
import msfd_jax as m
from msfd_jax._sweeps import sweep as _sweep
out = {}
g1 = dict(thickness_ratio=[0.25, 5.0], axial_constraint=[0.0, 1.0], mass_ratio=[40.0])
r = m.sweep(g1, m.Mesh(6, 8, 2), _sweep.SWEEP_SETTINGS, chunk_size=2)
g2 = dict(thickness_ratio=[0.5, 1.0, 2.5, 4.0, 1.5], axial_constraint=[1.0])
r2 = m.sweep(g2, m.Mesh(), chunk_size=3)
for tag, rr in (("a", r), ("b", r2)):
    for k in rr.columns if hasattr(rr, "columns") else rr:
        v = np.asarray(rr[k])
        if v.dtype.kind in "fiub": out[f"{tag}_{k}"] = v
np.savez(sys.argv[1], **out)
print(len(out), "arrays")
