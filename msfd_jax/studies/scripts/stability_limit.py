"""Observed stability limit of the Verlet step against the computed estimate dt_crit.

`critical_step` (exact structural eigenvalue + a Gershgorin bound on the contact springs)
must stay a safe estimate, and a tight one: the observed limit must lie within 10 % above it.
For each collision the step factor f = dt / dt_crit is bisected between a stable and an
unstable value over the whole run (to the settled stop, tau <= 6, the default stopping rule and
sub-steps); a run counts as unstable when the energy guard (0.05 K0) or the non-finite guard
stops it.

    python -m msfd_jax.studies.scripts.stability_limit        # ~5 min on the 2-core machine
Writes docs/results/stability_limit.md.
"""

from __future__ import annotations

import time
from pathlib import Path

import equinox as eqx
import jax

import msfd_jax as m

jax.config.update("jax_enable_x64", True)

ROOT = Path(__file__).resolve().parents[3]
T_MAX = 6.0
CASES = {
    "showcase (h_b/h_r 2.5, held, g 10, v0 0.82)": m.CollisionParams(),
    "thin free beam (h_b/h_r 0.5, free)": m.CollisionParams(
        thickness_ratio=0.5, axial_constraint=0.0
    ),
    "equal thickness (h_b/h_r 1, held)": m.CollisionParams(thickness_ratio=1.0),
    "thick beam (h_b/h_r 5, free)": m.CollisionParams(thickness_ratio=5.0, axial_constraint=0.0),
    "fast (h_b/h_r 1, v0 1.6)": m.CollisionParams(thickness_ratio=1.0, velocity=1.6),
}
COARSE = m.Mesh(6, 8, 2)  # the test mesh: the showcase on it, the last row


def stable(scene, dt_crit, factor) -> bool:
    settings = m.Settings(
        dt=float(factor * dt_crit),
        t_max=T_MAX,
        history_points=2,
        shape_times=(),
        max_steps=2**13,
    )
    sol = m.simulate(scene, settings)
    return int(sol.result) not in (m.RESULTS.non_finite, m.RESULTS.energy_balance_broken)


def limit(scene, lo=0.8, hi=1.6, iterations=8):
    dt_crit = float(m.critical_step(scene))
    if not stable(scene, dt_crit, lo):
        return dt_crit, None, lo
    while stable(scene, dt_crit, hi):
        lo, hi = hi, 2 * hi
    for _ in range(iterations):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if stable(scene, dt_crit, mid) else (lo, mid)
    return dt_crit, lo, hi


def main():
    start = time.perf_counter()
    lines = [
        "# Observed stability limit against the estimate dt_crit",
        "",
        "Produced by `python -m msfd_jax.studies.scripts.stability_limit` "
        f"({time.strftime('%Y-%m-%d %H:%M %Z')}, jax {jax.__version__}). Paper mesh 15/20+5, "
        f"whole runs (settled stop, tau <= {T_MAX}); f = dt/dt_crit bisected (8 halvings) "
        "between the largest stable and the smallest unstable factor (unstable: the energy guard "
        "0.05 K0 or the non-finite guard stops the run).",
        "",
        "| collision | dt_crit | largest stable f | smallest unstable f | structures alone "
        "| within 10 % above |",
        "|---|---|---|---|---|---|",
    ]
    cases = [(name, params, m.Mesh()) for name, params in CASES.items()]
    cases.append(("showcase, coarse test mesh 6/8+2", m.CollisionParams(), COARSE))
    for name, params, mesh in cases:
        scene = m.ring_on_beam(params, mesh)
        dt_crit, lo, hi = limit(scene)
        # the limit of the structures alone (no contact springs), as a factor of dt_crit
        bare = float(m.critical_step(eqx.tree_at(lambda s: s.contacts, scene, ()))) / dt_crit
        ok = lo is not None and lo >= 1.0 and hi <= 1.1
        lo_s = "unstable at 0.8" if lo is None else f"{lo:.4f}"
        lines.append(
            f"| {name} | {dt_crit:.4e} | {lo_s} | {hi:.4f} | {bare:.4f} | {'yes' if ok else 'no'} |"
        )
        print(lines[-1], flush=True)
    lines += ["", f"{time.perf_counter() - start:.0f} s in all.", ""]
    out = ROOT / "docs" / "results" / "stability_limit.md"
    out.write_text("\n".join(lines))
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
