import time, msfd_jax as m
P=dict(thickness_ratio=3.9391236194848664, mass_ratio=71.70547312737035, velocity=2.3025388806737657, modulus_ratio=176.80284929790662, slenderness=10.42857922841385, axial_constraint=0.0)
for n in (25, 30):
    t=time.time()
    c=m.run(m.CollisionParams(**P), m.Mesh(n,20,5,collapse_contacts=True), m.Settings(history_points=2, shape_times=()), check=False)
    print(n, c.status, c.energy_balance_error, c.retries, f"{time.time()-t:.0f}s", c.message[:300], flush=True)
