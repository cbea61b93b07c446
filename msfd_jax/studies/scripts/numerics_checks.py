"""Figures quoted in docs/model.md and the issue notes that no other script prints.

- µs per step of the showcase with 1 and 8 Verlet sub-steps per diffrax step;
- the energy-error order of an elastic-only collision, smoothed and sharp contact;
- the settle-window study: dissipated fractions against the stop time for three step sizes;
- contact dissipation of the constrained h_b/h_r = 1 collision at v0 = 0.4, 0.82, 1.6;
- rounding amplification on the coarse mesh: a vmapped program against a loop of single runs,
  sharp and smoothed contact (why the batched-vs-single tests smooth it, tests/conftest.py);
- the smoothed contact's approach to the sharp law as the width falls below f_y/k;
- the coarse reproduction sweep's energy balance at safety 0.7 and 0.35
  (tests/test_reproduction.py).

    python -m msfd_jax.studies.scripts.numerics_checks     # ~5 min on the 2-core machine
Writes docs/results/numerics_checks.md.
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


def rounding_amplification(lines):
    """vmap over three thicknesses against a loop of single runs, coarse mesh: how far the
    sharp, stiff contact amplifies rounding."""
    lines += [
        "## Rounding amplification, coarse mesh: vmap against a loop of single runs",
        "",
        "Beam dissipation / K0 for h_b/h_r = 0.8, 1.7, 3.1 (constrained, g = 10, v0 = 0.82); "
        "max |vmapped - looped| over the three.",
        "",
        "| tau | sharp contact | contact smoothing 1e-3 |",
        "|---|---|---|",
    ]
    thickness = jnp.array([0.8, 1.7, 3.1])
    for t_max in (0.1, 0.2, 0.3, 0.6):
        cells = []
        for width in (0.0, 1e-3):

            def beam(h, t_max=t_max, width=width):
                scene = m.ring_on_beam(
                    m.CollisionParams(thickness_ratio=h), SMALL, contact_smoothing=width
                )
                settings = m.Settings(
                    t_max=t_max, history_points=3, shape_times=(), max_steps=2**13
                )
                sol = m.simulate(scene, settings)
                return (sol.bending[1] + sol.axial[1]) / sol.k0

            batched = jax.vmap(beam)(thickness)
            looped = jnp.stack([beam(h) for h in thickness])
            cells.append(f"{float(jnp.max(jnp.abs(batched - looped))):.1e}")
        lines.append(f"| {t_max} | {cells[0]} | {cells[1]} |")
    lines.append("")


def contact_smoothing_limit(lines):
    """Showcase, paper mesh: max change of the dissipated fractions against the sharp run."""
    keys = ("beam_bending", "beam_axial", "ring_bending", "contact")
    sharp = m.run().fractions
    lines += [
        "## Contact smoothing against the sharp law (showcase, paper mesh, default step)",
        "",
        "f_y/k of the paper section's contact pairs is 2-4e-4 R.",
        "",
        "| contact smoothing w [R] | max change of the dissipated fractions [K0] |",
        "|---|---|",
    ]
    for width in (1e-4, 1e-5, 1e-6):
        f = m.run(contact_smoothing=width).fractions
        lines.append(f"| {width:g} | {max(abs(f[k] - sharp[k]) for k in keys):.2e} |")
    lines.append("")


def coarse_reproduction_balance(lines):
    """The seven collisions of tests/test_reproduction.py: energy balance by step size."""
    thickness = [dict(thickness_ratio=h) for h in (0.5, 2.5, 4.5)]
    fast = [dict(thickness_ratio=1.0, velocity=1.6, mass_ratio=g) for g in (5.0, 20.0)]
    speeds = [dict(thickness_ratio=1.0, velocity=v) for v in (1.2, 2.0)]
    rows = thickness + fast + speeds
    lines += [
        "## Coarse-mesh reproduction sweep: energy balance by step (tests/test_reproduction.py)",
        "",
        "| safety | max abs energy balance error [K0] | statuses |",
        "|---|---|---|",
    ]
    for safety in (0.7, 0.35):
        settings = m.Settings(safety=safety, history_points=2, shape_times=())
        table = m.sweep(rows, SMALL, settings, chunk_size=len(rows), progress=False)
        error = float(np.max(np.abs(table["energy_balance_error"])))
        lines.append(f"| {safety} | {error:.1e} | {', '.join(sorted(set(table['status'])))} |")
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
    parts = (
        substeps,
        energy_order,
        settle_window,
        contact_at_unit_thickness,
        rounding_amplification,
        contact_smoothing_limit,
        coarse_reproduction_balance,
    )
    for part in parts:
        part(lines)
        print("\n".join(lines[-8:]), flush=True)
    text = "\n".join(lines)
    (ROOT / "docs" / "results" / "numerics_checks.md").write_text(text + "\n")
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
