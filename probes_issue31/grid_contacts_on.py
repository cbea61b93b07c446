import sys, numpy as np, msfd_jax as m
sys.path.insert(0, 'benchmarks')
import _bench
GRID = {"thickness_ratio": np.linspace(0.25, 5.0, 16), "axial_constraint": [0.0, 1.0], "mass_ratio": [5.0, 10.0]}
rows=_bench.grid_rows(GRID)
S=_bench.sweep_settings()
off=m.sweep(rows, m.Mesh(collapse_contacts=False), S, chunk_size=32, progress=False)
on=m.sweep(rows, m.Mesh(collapse_contacts=True), S, chunk_size=32, progress=False)
cols=("ring_bending","beam_bending","beam_axial","ring_axial","contact","kinetic","elastic")
d=np.max(np.abs(np.stack([on[c]-off[c] for c in cols])),axis=0)
print(sorted(on.keys()))
for i in np.argsort(-d)[:8]:
    print(rows[i], f"diff {d[i]:.3f}", {c: (round(float(off[c][i]),3), round(float(on[c][i]),3)) for c in cols}, 'coll', float(on['contact_collapse'][i]) if 'contact_collapse' in on.keys() else None, off['status'][i], on['status'][i])
print('peak_ring_crush off/on for top rows')
for i in np.argsort(-d)[:10]:
    print(round(float(rows[i]['thickness_ratio']),2), rows[i]['axial_constraint'], rows[i]['mass_ratio'], float(off['peak_ring_crush'][i]), float(on['peak_ring_crush'][i]), float(off['peak_block_travel'][i]))
# final shapes of the worst row, paper model
i=int(np.argmax(d))
p=m.CollisionParams(**{k: float(v) for k,v in rows[i].items()})
for coll in (False, True):
    c=m.run(p, m.Mesh(collapse_contacts=coll), check=False)
    x=np.asarray(c.solution.final.x[0]); yG=x[-1,1]
    print(coll, c.status, 'ring y - yG max', (x[:-1,1]-yG).max(), 'min x', x[:,0].min(), 'contact_collapse', c.fractions.get('contact_collapse'))
    import msfd_jax._model.collapse as mc
