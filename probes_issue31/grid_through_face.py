import sys, numpy as np, msfd_jax as m
sys.path.insert(0, 'benchmarks')
import _bench
GRID = {"thickness_ratio": np.linspace(0.25, 5.0, 16), "axial_constraint": [0.0, 1.0], "mass_ratio": [5.0, 10.0]}
rows=_bench.grid_rows(GRID)
off=m.sweep(rows, m.Mesh(), _bench.sweep_settings(), chunk_size=32, progress=False)
for i,r in enumerate(rows):
    if 'past the block' in off['message'][i]: print({k: round(float(v),3) for k,v in r.items()}, off['message'][i][-330:-200])
print('flagged', sum('past the block' in s for s in off['message']), 'of', len(rows))
from msfd_jax.studies.scripts.regression_baseline import SINGLES
for name, p in SINGLES.items():
    c=m.run(m.CollisionParams(**p), m.Mesh(), check=False)
    print(name, 'past the block' in c.message, c.message[-200:])
