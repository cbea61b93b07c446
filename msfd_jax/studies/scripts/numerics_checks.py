"""Figures quoted in docs/model.md and the issue notes that no other script prints.

- µs per step of the showcase with 1 and 8 Verlet sub-steps per diffrax step;
- the energy-error order of an elastic-only collision, smoothed and sharp contact;
- the settle-window study: dissipated fractions against the stop time for three step sizes;
- contact dissipation of the constrained h_b/h_r = 1 collision at v0 = 0.4, 0.82, 1.6.

    python -m msfd_jax.studies.scripts.numerics_checks     # ~3 min on the 2-core machine
Writes benchmarks/results/numerics_checks.md.
"""

from __future__ import annotations

import time
from pathlib import Path

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

import msfd_jax as m

ROOT = Path(__file__).resolve().parents[3]
SMALL = m.Mesh(6, 8, 2)


def substeps(lines):
    scene = m.ring_on_beam()
    lines += [
        "## Sub-steps (showcase, paper mesh)",
        "",
        "| substeps | steps | us/step |",
        "|---|---|---|",
    ]
    for k in (1, 8):
        settings = m.Settings(substeps=k)
        sol = jax.block_until_ready(m.simulate(scene, settings))
        best = min(
            _timed(lambda s=settings: jax.block_until_ready(m.simulate(scene, s))) for _ in range(5)
        )
        lines.append(f"| {k} | {int(sol.steps)} | {best * 1e6 / int(sol.steps):.2f} |")
    lines.append("")


def _timed(fn):
    start = time.perf_counter()
    fn()
    return time.perf_counter() - start


def _elastic(scene):
    big = 1e12
    return eqx.tree_at(
        lambda s: (
            [c.section.plastic_moment for c in s.chains]
            + [c.section.plastic_axial for c in s.chains]
            + [k.yield_force for k in s.contacts]
        ),
        scene,
        [jnp.asarray(big)] * 4 + [jnp.full_like(k.yield_force, big) for k in scene.contacts],
    )


def energy_order(lines):
    lines += [
        "## Energy-error order, elastic-only collision (v0 = 0.05, coarse mesh, tau <= 0.4)",
        "",
        "| contact smoothing | errors at safety 0.4, 0.2, 0.1 [K0] | order |",
        "|---|---|---|",
    ]
    for width in (1e-4, 0.0):
        scene = _elastic(
            m.ring_on_beam(m.CollisionParams(velocity=0.05), SMALL, contact_smoothing=width)
        )
        dt_crit = float(m.critical_step(scene))
        errors = []
        for safety in (0.4, 0.2, 0.1):
            settings = m.Settings(
                dt=safety * dt_crit,
                t_max=0.4,
                stop_when_settled=False,
                history_points=401,
                shape_times=(),
                max_steps=2**14,
                substeps=1,
            )
            sol = m.simulate(scene, settings)
            total = jnp.sum(sol.history["kinetic"], -1) + sol.history["elastic"]
            errors.append(float(jnp.max(jnp.abs(total - sol.k0)) / sol.k0))
        order = np.polyfit(np.log([0.4, 0.2, 0.1]), np.log(errors), 1)[0]
        lines.append(f"| {width:g} | {', '.join(f'{e:.2e}' for e in errors)} | {order:.2f} |")
    lines.append("")


def settle_window(lines):
    scene = m.ring_on_beam()
    dt_crit = float(m.critical_step(scene))
    keys = m.FRACTION_KEYS
    lines += [
        "## Stop time and accuracy (showcase): dt/8 reference against safety 0.5 and 0.8",
        "",
        "| settle window | run | tau end | max diff, 7 fractions [K0] "
        "| max diff, dissipated + (K+U) [K0] |",
        "|---|---|---|---|---|",
    ]
    for window in (0.5, 1.5):
        runs = {}
        for label, dt in (
            ("dt/8", 0.5 * dt_crit / 8),
            ("0.5", 0.5 * dt_crit),
            ("0.8", 0.8 * dt_crit),
        ):
            settings = m.Settings(dt=dt, settle_window=window, history_points=11, shape_times=())
            sol = m.simulate(scene, settings)
            f = m.fractions(sol, scene)
            seven = np.array([float(f[k]) for k in keys])
            lumped = np.concatenate([seven[:5], [seven[5] + seven[6]]])
            runs[label] = (seven, lumped, float(sol.t_end))
        for label, (seven, lumped, t_end) in runs.items():
            d7 = np.max(np.abs(seven - runs["dt/8"][0]))
            dl = np.max(np.abs(lumped - runs["dt/8"][1]))
            lines.append(f"| {window} | {label} | {t_end:.3f} | {d7:.2e} | {dl:.2e} |")
    lines.append("")


def contact_at_unit_thickness(lines):
    lines += [
        "## Contact dissipation, h_b/h_r = 1, constrained, g = 10 (paper mesh)",
        "",
        "| v0 | contact [M_pr] | contact / K0 | peak total contact force |",
        "|---|---|---|---|",
    ]
    for v0 in (0.4, 0.82, 1.6):
        c = m.run(m.CollisionParams(thickness_ratio=1.0, velocity=v0))
        s = c.solution
        force = s.history["contact_force"]
        peak = float(jnp.max(jnp.where(jnp.isfinite(force), force, 0.0)))
        lines.append(
            f"| {v0} | {float(jnp.sum(s.contact)):.4f} | {c.fractions['contact']:.4f} "
            f"| {peak:.2f} |"
        )
    lines.append("")


def main() -> int:
    lines = [
        "# Numerics checks quoted in docs/model.md and the issue notes",
        "",
        "Produced by `python -m msfd_jax.studies.scripts.numerics_checks` "
        f"({time.strftime('%Y-%m-%d')}, "
        "2-core CPU, not pinned).",
        "",
    ]
    for part in (substeps, energy_order, settle_window, contact_at_unit_thickness):
        part(lines)
        print("\n".join(lines[-8:]), flush=True)
    text = "\n".join(lines)
    (ROOT / "benchmarks" / "results" / "numerics_checks.md").write_text(text + "\n")
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
