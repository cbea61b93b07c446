import json, sys, time
SAF=[float(x) for x in sys.argv[3:]]
import msfd_jax as m
d=json.load(open('benchmarks/results/reliability.json'))
rows=[r for r in d['rows'] if r['status'] in ('settled','time limit') and abs(r['energy_balance_error'])>1e-4]
keys=('thickness_ratio','mass_ratio','velocity','modulus_ratio','slenderness','axial_constraint')
for r in rows[int(sys.argv[1]):int(sys.argv[2])]:
    p=m.CollisionParams(**{k:r[k] for k in keys})
    print({k:round(r[k],4) for k in keys}, 'bench', r['energy_balance_error'], r['retries'], flush=True)
    for mesh in (m.Mesh(),):
        for s in SAF:
            t=time.time()
            try:
                c=m.run(p, mesh, m.Settings(safety=s), check=False)
                sol=c.solution
                print(f'  safety {s}: {c.status} err {c.energy_balance_error:+.3e} tau {float(sol.t_end):.3f} steps {int(sol.steps)} retries {c.retries} frac {c.fractions["contact"]:.3f} coll "{c.collapse_note[:60]}" {time.time()-t:.1f}s', flush=True)
            except Exception as e:
                print('  safety',s,'EXC',str(e)[:300], flush=True)
