"""Slow MS-FD runs against rigid-perfectly-plastic closed forms (docs/validation_quickstatic.md).

1. The simply supported beam driven slowly at mid-span (Fig. 12b case: n_p = 40, m_p = 1,
   l_b = 3 in ring units, E/Y = 2000) against Eq. 25, with and without axial constraint.
2. Parkes' cantilever struck at the tip (mass ratios 10 and 1, W_f / L ~ 0.2), E/Y = 1e3 ... 1e6.

Prints the tables of the note and writes docs/figures/eq25_parkes.png.

    python benchmarks/validate_analytic.py [--no-figure] [--mesh-study]
"""

from __future__ import annotations

import argparse
import pathlib
import time

import jax.numpy as jnp
import numpy as np

import msfd_jax as m
from msfd_jax._analytic import beam_central_load, elastic_membrane_load, parkes_cantilever

ROOT = pathlib.Path(__file__).resolve().parents[1]

# Beam: the Fig. 12(b) case. E/Y = 2000 puts the end of the elastic range (axial yield at
# y / l_b = sqrt(2 Y / E) = 0.032) below the first compared point; 12 segments (the hinge sits at
# the centre joint, so the mesh hardly matters) and v = 0.02 keep it to ~1.3e5 steps.
BEAM_MODULUS = 2000.0
BEAM_DRIVE = 0.02
BEAM_MESH = m.Mesh(beam_contact_segments=10, beam_outer_segments=2)
BEAM_YMAX = 0.3  # y / l_b at the end of the drive
SPAN, M_P, N_P = 3.0, 1.0, 40.0
BEAM_SETTINGS = m.Settings(
    t_max=jnp.asarray(BEAM_YMAX * SPAN / BEAM_DRIVE),  # an array: one compilation for both beams
    stop_when_settled=False,
    history_points=1201,
    shape_times=(),
    max_steps=2**18,
)

# Cantilever, L/h = 10 (the elastic energy capacity M0^2 L / (6 EI) = (L/h) / (2 E/Y) is small
# against K0), W_f / L ~ 0.2. A heavy striker (mass ratio 10: 94 % of K0 at the fixed root hinge)
# and a light one (mass ratio 1: 41 % in the travelling hinge of phase I, where elasticity and
# the mesh matter most).
PARKES_CASES = ((10.0, 0.2), (1.0, 0.724))  # (G / (m L), V0 sqrt(m L / M0))
PARKES_SLENDERNESS = 10.0
PARKES_SEGMENTS = 20
PARKES_MODULI = (1.0e3, 1.0e4, 1.0e5, 1.0e6)


def parkes_settings(max_steps=2**20):
    return m.Settings(
        t_max=jnp.asarray(3.0),
        history_points=31,
        shape_times=(),
        settle_window=0.2,
        max_steps=max_steps,
    )


def run_beam(axial_constraint: float, modulus=BEAM_MODULUS, mesh=BEAM_MESH):
    """(y, whole-beam load p, whole-beam drive work) of one slow mid-span drive."""
    params = m.CollisionParams(
        thickness_ratio=1.0, span_ratio=SPAN, axial_constraint=axial_constraint,
        modulus_ratio=modulus,
    )  # fmt: skip
    scene = m.beam_midspan_load(params, mesh, drive_velocity=BEAM_DRIVE)
    sol = m.simulate(scene, BEAM_SETTINGS)
    if int(sol.result) != 1:  # runs to the time limit by design
        raise RuntimeError(m.diagnose(sol, scene))
    y = BEAM_DRIVE * np.asarray(sol.ts)
    return y, 2.0 * np.asarray(sol.history["reaction"]), 2.0 * np.asarray(sol.history["drive_work"])


def window_mean(y, values, centre, half_width=0.005 * SPAN):
    """Mean of `values` over |y - centre| <= half_width (averages out elastic vibration)."""
    w = np.abs(y - centre) <= half_width
    return float(np.mean(values[w]))


def mean_load(y, work, y1, y2):
    """Work-averaged load (W(y2) - W(y1)) / (y2 - y1), from the drive work history."""
    return float((np.interp(y2, y, work) - np.interp(y1, y, work)) / (y2 - y1))


def analytic_mean_load(y1, y2, constrained: bool):
    """(1 / (y2 - y1)) int p dy of Eq. 25 (constrained) or 2 m_p / sqrt(l_b^2 - y^2)."""
    if constrained:
        s = lambda y: np.sqrt(SPAN**2 + y**2)  # noqa: E731
        work = lambda y: 2 * M_P * np.arctan(y / SPAN) + 2 * N_P * s(y)  # noqa: E731
    else:
        work = lambda y: 2 * M_P * np.arcsin(y / SPAN)  # noqa: E731
    return (work(y2) - work(y1)) / (y2 - y1)


def permanent_tip_deflection(sol, scene):
    """Tip deflection of the unloaded (plastic) shape: bars at rest length, turned by the
    accumulated plastic joint rotations. Returns (exact L sum sin(phi), small-rotation sum phi).
    """
    chain = scene.chains[0]
    phi = np.cumsum(np.asarray(sol.final.plastic_rotation[0]))[: chain.n_nodes - 1]
    lengths = np.asarray(chain.rest_length) * (1.0 + np.asarray(sol.final.plastic_strain[0]))
    return float(np.sum(lengths * np.sin(phi))), float(np.sum(lengths * phi))


def run_cantilever(mass_ratio, velocity, modulus, segments=PARKES_SEGMENTS, max_steps=2**20):
    """One MS-FD Parkes run (arrays in, so every case shares one compilation)."""
    scene = m.cantilever_tip_mass(
        mass_ratio=jnp.asarray(mass_ratio),
        velocity=jnp.asarray(velocity),
        modulus_ratio=jnp.asarray(modulus),
        slenderness=jnp.asarray(PARKES_SLENDERNESS),
        segments=segments,
    )
    sol = m.simulate(scene, parkes_settings(max_steps))
    if int(sol.result) != 0:
        raise RuntimeError(m.diagnose(sol, scene))
    exact, small = permanent_tip_deflection(sol, scene)
    return dict(
        modulus=modulus,
        segments=segments,
        tip=float(sol.final.x[0][-1, 1]),
        permanent=exact,
        permanent_small=small,
        root_fraction=_root_fraction(sol, scene),
        capacity=PARKES_SLENDERNESS / (2.0 * modulus) / float(sol.k0),
        t_end=float(sol.t_end),
        steps=int(sol.steps),
    )


def _root_fraction(sol, scene):
    """Share of the plastic bending work done at the root joint (M0 |theta_root|, m_p = 1)."""
    root = abs(float(sol.final.plastic_rotation[0][0]))
    return root / float(jnp.sum(sol.bending))


def beam_table():
    rows, curves = [], {}
    for constrained in (True, False):
        t0 = time.perf_counter()
        y, p, work = run_beam(1.0 if constrained else 0.0)
        curves[constrained] = (y, p)
        print(f"\n{'axially constrained' if constrained else 'no axial constraint'} "
              f"({time.perf_counter() - t0:.1f} s incl. compile)")  # fmt: skip
        print(" y/l_b   MS-FD p (window)  MS-FD p (inst.)   rigid-plastic p   error (window)")
        for r in (0.05, 0.1, 0.15, 0.2, 0.25, 0.3) if constrained else (0.1, 0.2, 0.3):
            yc = r * SPAN
            pw = window_mean(y, p, yc)
            pi = float(np.interp(yc, y, p))
            pa = float(beam_central_load(yc, M_P, N_P, SPAN, axial_constraint=constrained))
            rows.append((constrained, r, pw, pa))
            print(f" {r:5.3f}   {pw:12.4f}     {pi:12.4f}     {pa:12.4f}      {pw / pa - 1:+.4f}")
        print(" interval       MS-FD mean load  analytic   error    (small deflection 2 m_p/l_b)")
        for a, b in ((0.05, 0.1), (0.1, 0.2), (0.2, 0.3)):
            ml = mean_load(y, work, a * SPAN, b * SPAN)
            ma = analytic_mean_load(a * SPAN, b * SPAN, constrained)
            print(f" [{a:.2f}, {b:.2f}]   {ml:12.5f}  {ma:10.5f}  {ml / ma - 1:+.5f}   "
                  f"({2 * M_P / SPAN:.5f})")  # fmt: skip
    return curves


def parkes_table(segments=PARKES_SEGMENTS, moduli=PARKES_MODULI, max_steps=2**20):
    out = {}
    for gamma, v in PARKES_CASES:
        exact = parkes_cantilever(gamma, v)
        print(f"\nParkes: G/(mL) = {gamma:g}, v0 = {v:g}, L/h = {PARKES_SLENDERNESS:g}, "
              f"{segments} segments: W_f/L = {exact.final_tip_deflection:.5f}, root share "
              f"{exact.root_energy_fraction:.4f}")  # fmt: skip
        print(" E/Y      U_e/K0    permanent W  error   small-rot. W  error   tip y (end)  "
              "root share  steps")  # fmt: skip
        rows = []
        for beta in moduli:
            r = run_cantilever(gamma, v, beta, segments, max_steps)
            w = exact.final_tip_deflection
            rows.append((beta, r))
            print(f" {beta:7.0e}  {r['capacity']:.2e}   {r['permanent']:.5f}    "
                  f"{r['permanent'] / w - 1:+.4f}  {r['permanent_small']:.5f}    "
                  f"{r['permanent_small'] / w - 1:+.4f}  {r['tip']:.5f}      "
                  f"{r['root_fraction']:.4f}      {r['steps']}")  # fmt: skip
        out[(gamma, v)] = (exact, rows)
    return out


def figure(curves, parkes, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 4))
    yy = np.linspace(0.0, BEAM_YMAX * SPAN, 301)
    for constrained, colour in ((True, "C0"), (False, "C1")):
        y, p = curves[constrained]
        label = "axially constrained" if constrained else "no axial constraint"
        a.plot(y / SPAN, p, colour, lw=0.6, alpha=0.7, label=f"MS-FD, {label}")
        analytic = np.asarray(beam_central_load(yy, M_P, N_P, SPAN, axial_constraint=constrained))
        a.plot(yy / SPAN, analytic, "k--" if constrained else "k:", lw=1.2,
               label="Eq. 25" if constrained else r"$2m_p/\sqrt{l_b^2-y^2}$")  # fmt: skip
    kappa = 4.0 * BEAM_MODULUS * 10.0
    em = np.asarray(elastic_membrane_load(yy, M_P, kappa, SPAN))
    a.plot(yy / SPAN, em, color="0.6", lw=0.8, label="elastic axial force ($n<n_p$)")
    a.set(xlabel=r"$y_b/l_b$", ylabel="central load $p$ (whole beam)", ylim=(0, 25),
          title=rf"Fig. 12b case: $n_p=40$, $m_p=1$, $l_b=3$, $E/Y={BEAM_MODULUS:g}$")  # fmt: skip
    a.legend(fontsize=8)
    for (gamma, _), (exact, rows) in parkes.items():
        moduli = [beta for beta, _ in rows]
        err = [100 * (r["permanent"] / exact.final_tip_deflection - 1) for _, r in rows]
        b.semilogx(moduli, err, "o-", label=f"G/(mL) = {gamma:g} ($W_f/L$ = "
                   f"{exact.final_tip_deflection:.3f})")  # fmt: skip
    b.axhline(0.0, color="k", lw=0.8)
    b.set(xlabel="E/Y", ylabel="MS-FD permanent $W_f$ / Parkes $-$ 1  [%]",
          title=f"Parkes' cantilever, L/h = {PARKES_SLENDERNESS:g}, "
                f"{PARKES_SEGMENTS} segments")  # fmt: skip
    b.legend(fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=130)
    print(f"\nwrote {path}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--no-figure", action="store_true")
    parser.add_argument("--mesh-study", action="store_true", help="also 40 cantilever segments")
    args = parser.parse_args()
    curves = beam_table()
    parkes = parkes_table()
    if args.mesh_study:
        parkes_table(segments=40, moduli=(1.0e4, 1.0e5), max_steps=2**21)
        parkes_table(segments=80, moduli=(1.0e4,), max_steps=2**21)
    if not args.no_figure:
        figure(curves, parkes, ROOT / "docs" / "figures" / "eq25_parkes.png")


if __name__ == "__main__":
    main()
