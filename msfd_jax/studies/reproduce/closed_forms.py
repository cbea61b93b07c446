"""Eq. 25 (the beam's rigid-plastic membrane load) and Parkes' cantilever against MS-FD.

`reproduce_analytic` runs both (``msfd reproduce --only analytic``; the core of
``python -m msfd_jax.studies.scripts.validate_analytic``). The closed forms themselves are
`msfd_jax.studies.references.analytic`. Units as in `quasistatic`. `compute_analytic` runs
both, `draw_analytic` renders them, `table_analytic` and `judge_analytic` write the table and
the verdicts from the numbers alone; `reproduce_analytic` composes them.
"""

from __future__ import annotations

from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

import msfd_jax as m
from msfd_jax.studies.references.analytic import (
    beam_central_load,
    elastic_membrane_load,
    parkes_cantilever,
)
from msfd_jax.studies.reproduce._common import Finding, Reproduction, compose

from .quasistatic import work_mean

jax.config.update("jax_enable_x64", True)

# --------------------------------------------------------------------------------------------
# Eq. 25 and Parkes' cantilever (formerly the body of benchmarks/validate_analytic.py)

# Beam: the Fig. 12(b) case. E/Y = 2000 puts the end of the elastic range (axial yield at
# y / l_b = sqrt(2 Y / E) = 0.032) below the first compared point; 12 segments (the hinge sits at
# the centre joint, so the mesh hardly matters) and v = 0.02 keep it to ~1.3e5 steps.
BEAM_MODULUS = 2000.0
BEAM_DRIVE = 0.02
BEAM_MESH = m.Mesh(beam_contact_segments=10, beam_outer_segments=2)
EQ25_YMAX = 0.3  # y / l_b at the end of the drive
SPAN, M_P, N_P = 3.0, 1.0, 40.0
EQ25_POINTS = {True: (0.05, 0.1, 0.15, 0.2, 0.25, 0.3), False: (0.1, 0.2, 0.3)}
EQ25_INTERVALS = ((0.05, 0.1), (0.1, 0.2), (0.2, 0.3))

# Cantilever, L/h = 10 (the elastic energy capacity M0^2 L / (6 EI) = (L/h) / (2 E/Y) is small
# against K0), W_f / L ~ 0.2. A heavy striker (mass ratio 10: 94 % of K0 at the fixed root hinge)
# and a light one (mass ratio 1: 41 % in the travelling hinge of phase I, where elasticity and
# the mesh matter most).
PARKES_CASES = ((10.0, 0.2), (1.0, 0.724))  # (G / (m L), V0 sqrt(m L / M0))
PARKES_SLENDERNESS = 10.0
PARKES_SEGMENTS = 20
PARKES_MODULI = (1.0e3, 1.0e4, 1.0e5, 1.0e6)
QUICK_PARKES_MODULI = (1.0e3, 1.0e4)


def eq25_settings():
    return m.Settings(
        t_max=jnp.asarray(EQ25_YMAX * SPAN / BEAM_DRIVE),  # an array: one compilation for both
        stop_when_settled=False,
        history_points=1201,
        shape_times=(),
        max_steps=2**18,
    )


def parkes_settings(max_steps=2**20):
    return m.Settings(
        t_max=jnp.asarray(3.0),
        history_points=31,
        shape_times=(),
        settle_window=0.2,
        max_steps=max_steps,
    )


def run_eq25_beam(axial_constraint: float, modulus=BEAM_MODULUS, mesh=BEAM_MESH):
    """(y, whole-beam load p, whole-beam drive work) of one slow mid-span drive."""
    params = m.CollisionParams(
        thickness_ratio=1.0,
        span_ratio=SPAN,
        axial_constraint=axial_constraint,
        modulus_ratio=modulus,
    )
    scene = m.beam_midspan_load(params, mesh, drive_velocity=BEAM_DRIVE)
    sol = m.simulate(scene, eq25_settings())
    if int(sol.result) != 1:  # runs to the time limit by design
        raise RuntimeError(m.diagnose(sol, scene))
    y = BEAM_DRIVE * np.asarray(sol.ts)
    return y, 2.0 * np.asarray(sol.history["reaction"]), 2.0 * np.asarray(sol.history["drive_work"])


def window_mean(y, values, centre, half_width=0.005 * SPAN):
    """Mean of `values` over |y - centre| <= half_width (averages out elastic vibration)."""
    w = np.abs(y - centre) <= half_width
    return float(np.mean(values[w]))


def analytic_mean_load(y1, y2, constrained: bool):
    """(1 / (y2 - y1)) int p dy of Eq. 25 (constrained) or 2 m_p / sqrt(l_b^2 - y^2)."""
    if constrained:
        work = lambda y: 2 * M_P * np.arctan(y / SPAN) + 2 * N_P * np.sqrt(SPAN**2 + y**2)  # noqa: E731
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
    root = abs(float(sol.final.plastic_rotation[0][0]))  # m_p = 1 at the root joint
    return dict(
        modulus=modulus,
        segments=segments,
        tip=float(sol.final.x[0][-1, 1]),
        permanent=exact,
        permanent_small=small,
        root_fraction=root / float(jnp.sum(sol.bending)),
        capacity=PARKES_SLENDERNESS / (2.0 * modulus) / float(sol.k0),
        t_end=float(sol.t_end),
        steps=int(sol.steps),
    )


def eq25_study():
    """Both slow beams: curves, point table rows and work-averaged interval rows."""
    curves, points, intervals = {}, [], []
    for constrained in (True, False):
        y, p, work = run_eq25_beam(1.0 if constrained else 0.0)
        curves[constrained] = (y, p)
        for r in EQ25_POINTS[constrained]:
            yc = r * SPAN
            pa = float(beam_central_load(yc, M_P, N_P, SPAN, axial_constraint=constrained))
            pw, pi = window_mean(y, p, yc), float(np.interp(yc, y, p))
            points.append(
                dict(
                    constrained=constrained,
                    y_over_lb=r,
                    window=pw,
                    instant=pi,
                    analytic=pa,
                    error=pw / pa - 1,
                )
            )
        for a, b in EQ25_INTERVALS:
            ml = work_mean(y, work, a * SPAN, b * SPAN)
            ma = analytic_mean_load(a * SPAN, b * SPAN, constrained)
            intervals.append(
                dict(
                    constrained=constrained,
                    interval=(a, b),
                    msfd=ml,
                    analytic=ma,
                    error=ml / ma - 1,
                )
            )
    return curves, points, intervals


def parkes_study(segments=PARKES_SEGMENTS, moduli=PARKES_MODULI, max_steps=2**20):
    """Parkes' cases against MS-FD cantilevers: {(gamma, v): (ParkesSolution, [rows])}."""
    out = {}
    for gamma, v in PARKES_CASES:
        exact = parkes_cantilever(gamma, v)
        rows = [run_cantilever(gamma, v, beta, segments, max_steps) for beta in moduli]
        for r in rows:
            r["error"] = r["permanent"] / exact.final_tip_deflection - 1
        out[(gamma, v)] = (exact, rows)
    return out


def _analytic_figure(curves, parkes, path):
    from matplotlib.figure import Figure

    fig = Figure(figsize=(10, 4))
    a, b = fig.add_subplot(1, 2, 1), fig.add_subplot(1, 2, 2)
    yy = np.linspace(0.0, EQ25_YMAX * SPAN, 301)
    for constrained, colour in ((True, "C0"), (False, "C1")):
        y, p = curves[constrained]
        label = "axially constrained" if constrained else "no axial constraint"
        a.plot(y / SPAN, p, colour, lw=0.6, alpha=0.7, label=f"MS-FD, {label}")
        analytic = np.asarray(beam_central_load(yy, M_P, N_P, SPAN, axial_constraint=constrained))
        a.plot(
            yy / SPAN,
            analytic,
            "k--" if constrained else "k:",
            lw=1.2,
            label="Eq. 25" if constrained else r"$2m_p/\sqrt{l_b^2-y^2}$",
        )
    em = np.asarray(elastic_membrane_load(yy, M_P, 4.0 * BEAM_MODULUS * 10.0, SPAN))
    a.plot(yy / SPAN, em, color="0.6", lw=0.8, label="elastic axial force ($n<n_p$)")
    a.set(
        xlabel=r"$y_b/l_b$",
        ylabel="central load $p$ (whole beam)",
        ylim=(0, 25),
        title=rf"Fig. 12b case: $n_p=40$, $m_p=1$, $l_b=3$, $E/Y={BEAM_MODULUS:g}$",
    )
    a.legend(fontsize=8)
    for (gamma, _), (exact, rows) in parkes.items():
        b.semilogx(
            [r["modulus"] for r in rows],
            [100 * r["error"] for r in rows],
            "o-",
            label=f"G/(mL) = {gamma:g} ($W_f/L$ = {exact.final_tip_deflection:.3f})",
        )
    b.axhline(0.0, color="k", lw=0.8)
    b.set(
        xlabel="E/Y",
        ylabel="MS-FD permanent $W_f$ / Parkes $-$ 1  [%]",
        title=f"Parkes' cantilever, L/h = {PARKES_SLENDERNESS:g}, {PARKES_SEGMENTS} segments",
    )
    b.legend(fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=130)


def parkes_table(parkes) -> list[str]:
    lines = []
    for (gamma, v), (exact, rows) in parkes.items():
        lines += [
            f"Parkes, G/(mL) = {gamma:g}, v0 = {v:g}, L/h = {PARKES_SLENDERNESS:g}, "
            f"{rows[0]['segments']} segments: W_f/L = {exact.final_tip_deflection:.5f}, root "
            f"share {exact.root_energy_fraction:.4f}",
            "",
            "| E/Y | U_e/K0 | permanent W | error | small-rot. W | tip y (end) | root share | "
            "steps |",
            "|---:|---:|---:|---:|---:|---:|---:|---:|",
        ]
        for r in rows:
            lines.append(
                f"| {r['modulus']:.0e} | {r['capacity']:.2e} | {r['permanent']:.5f} | "
                f"{100 * r['error']:+.2f} % | {r['permanent_small']:.5f} | {r['tip']:.5f} | "
                f"{r['root_fraction']:.4f} | {r['steps']} |"
            )
        lines.append("")
    return lines


def compute_analytic(quick: bool) -> dict:
    """Eq. 25's slow beams (``curves``, ``points``, ``intervals``, `eq25_study`) and Parkes'
    cases (``parkes``, `parkes_study`; low E/Y only when `quick`), and ``quick``."""
    curves, points, intervals = eq25_study()
    parkes = parkes_study(moduli=QUICK_PARKES_MODULI if quick else PARKES_MODULI)
    return dict(quick=quick, curves=curves, points=points, intervals=intervals, parkes=parkes)


def published_analytic(numbers: dict) -> dict:
    """The numbers of ``reproduce.json``."""
    points, intervals, parkes = numbers["points"], numbers["intervals"], numbers["parkes"]
    return dict(
        eq25_points=points,
        eq25_intervals=[dict(r, interval=list(r["interval"])) for r in intervals],
        parkes={
            f"{g:g}": dict(exact=exact.final_tip_deflection, rows=rows)
            for (g, _), (exact, rows) in parkes.items()
        },
    )


def draw_analytic(numbers: dict, figures_dir: Path) -> list[str]:
    """``eq25_parkes.png``: Eq. 25's beams and Parkes' errors against E/Y."""
    _analytic_figure(numbers["curves"], numbers["parkes"], figures_dir / "eq25_parkes.png")
    return ["eq25_parkes.png"]


def table_analytic(numbers: dict) -> str:
    """The markdown tables: Eq. 25 by point and by interval, then Parkes'."""
    points, intervals, parkes = numbers["points"], numbers["intervals"], numbers["parkes"]
    table = [
        f"Slow mid-span drive (v = {BEAM_DRIVE:g}) of the Fig. 12b beam (m_p = 1, n_p = 40, "
        f"l_b = 3, E/Y = {BEAM_MODULUS:g}, 12 segments); p = 2 x reaction; window = mean over "
        "|y - y_c| <= 0.005 l_b.",
        "",
        "| beam | y/l_b | MS-FD p (window) | MS-FD p (instant) | rigid-plastic p | error |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for r in points:
        table.append(
            f"| {'constrained' if r['constrained'] else 'free'} | {r['y_over_lb']:.2f} | "
            f"{r['window']:.4f} | {r['instant']:.4f} | {r['analytic']:.4f} | "
            f"{100 * r['error']:+.2f} % |"
        )
    table += [
        "",
        "| beam | interval y/l_b | MS-FD work-averaged p | analytic | error |",
        "|---|---|---:|---:|---:|",
    ]
    for r in intervals:
        a, b = r["interval"]
        table.append(
            f"| {'constrained' if r['constrained'] else 'free'} | [{a:.2f}, {b:.2f}] | "
            f"{r['msfd']:.5f} | {r['analytic']:.5f} | {r['error']:+.1e} |"
        )
    table += [""] + parkes_table(parkes)
    return "\n".join(table)


def judge_analytic(numbers: dict) -> list[Finding]:
    """The verdicts on Eq. 25 and on Parkes' cantilever (n/a when quick)."""
    quick, intervals, parkes = numbers["quick"], numbers["intervals"], numbers["parkes"]
    worst_interval = max(abs(r["error"]) for r in intervals)
    stiffest = {g: rows[-1] for (g, _), (_, rows) in parkes.items()}  # highest E/Y run
    return [
        Finding(
            "Eq. 25 / Fig. 12b",
            "A rigid-perfectly-plastic axially constrained beam under a central load follows "
            "Eq. 25 (p ~ 16 at y_b/l_b = 0.2 for n_p = 40, m_p = 1, l_b = 3).",
            f"Slow MS-FD beam, work-averaged load over y/l_b in 0.05-0.3: worst error "
            f"{100 * worst_interval:.3f} % (constrained and free).",
            bool(worst_interval < 0.01),
            "Once both springs yield, the MS-FD forces are exactly m_p and n_p; only elastic "
            "bending and ringing remain.",
        ),
        Finding(
            "Hou et al. / Parkes",
            "MS-FD reproduces Parkes' rigid-plastic cantilever struck at the tip.",
            "Permanent tip deflection error at the highest E/Y run: "
            + ", ".join(
                f"G/(mL) = {g:g}: {100 * r['error']:+.2f} % (E/Y = {r['modulus']:.0e})"
                for g, r in stiffest.items()
            ),
            None if quick else bool(max(abs(r["error"]) for r in stiffest.values()) < 0.05),
            "Rigid-plastic only as E/Y grows (elastic capacity against K0); the light "
            "striker's travelling hinge carries the larger error (quick: low E/Y only, n/a).",
        ),
    ]


def reproduce_analytic(quick: bool, figures_dir: Path) -> Reproduction:
    """Eq. 25 against the slowly driven MS-FD beam; Parkes' cantilever against MS-FD."""
    return compose(
        "analytic",
        "Eq. 25 and Parkes' cantilever: slow and struck MS-FD runs against closed forms",
        quick,
        figures_dir,
        compute=compute_analytic,
        draw=draw_analytic,
        table=table_analytic,
        judge=judge_analytic,
        publish=published_analytic,
    )
