"""The work-precision study itself: jobs per collision, rows against the references, and
its two extensions (the candidate default step on the stability catalogue, mesh refinement).
"""

from __future__ import annotations

import dataclasses
import math
import os
import statistics
import sys
import time
from collections.abc import Callable, Sequence
from typing import Any

import jax
import jax.numpy as jnp

from ..._batched.results import RESULTS
from ..._batched.simulate import Settings, critical_step, simulate
from ..._model.params import Mesh
from ..._model.scene import Scene, ring_on_beam
from .methods import lumped, max_error
from .runners import (
    CASES,
    METHODS,
    Config,
    Job,
    reference,
    rk_fixed,
    time_jobs,
    verlet_at_stop,
    verlet_fixed,
)

# ----------------------------------------------------------------------------------------------
# The study


def _progress_default(line: str) -> None:
    print(line, file=sys.stderr, flush=True)


def case_jobs(name: str, scene: Scene, config: Config, methods: Sequence[str]) -> list[Job]:
    """Every timed configuration of one collision."""
    t1, jobs = config.t_fixed, []
    fmax = config.fixed_max_steps
    if "verlet" in methods:
        for s in config.safeties:
            jobs.append(
                Job(
                    name,
                    "fixed_time",
                    "verlet",
                    "safety",
                    s,
                    verlet_fixed(scene, s, t1, max_steps=fmax),
                )
            )
            jobs.append(
                Job(name, "at_stop", "verlet", "safety", s, verlet_at_stop(scene, s, config))
            )
    if "verlet_substeps1" in methods:
        for s in config.substep1_safeties:
            jobs.append(
                Job(
                    name,
                    "fixed_time",
                    "verlet_substeps1",
                    "safety",
                    s,
                    verlet_fixed(scene, s, t1, substeps=1, max_steps=fmax * 8),
                )
            )
    if "yoshida4" in methods:
        for s in config.yoshida_safeties:
            jobs.append(
                Job(
                    name,
                    "fixed_time",
                    "yoshida4",
                    "safety",
                    s,
                    verlet_fixed(scene, s, t1, max_steps=fmax, yoshida=True),
                )
            )
    if "rk" in methods:
        for solver in config.rk_solvers:
            for tol in config.rk_tolerances:
                jobs.append(
                    Job(
                        name,
                        "fixed_time",
                        f"{solver}_perzyna",
                        "rtol",
                        tol,
                        rk_fixed(scene, solver, tol, config.rk_eta, t1, fmax),
                    )
                )
    if "perzyna_eta" in methods:
        # the regularisation's own error: tight tolerance, several relaxation times
        tight = min(config.rk_tolerances)
        for eta in config.etas:
            if eta == config.rk_eta and "rk" in methods:
                continue
            jobs.append(
                Job(
                    name,
                    "fixed_time",
                    "tsit5_perzyna_eta",
                    "eta",
                    eta,
                    rk_fixed(scene, "tsit5", tight, eta, t1, fmax),
                )
            )
    if "smoothing" in methods:
        params = CASES[name][1]
        for method, symbol, levels in (
            ("yield_smoothing", "s", config.yield_smoothings),
            ("contact_smoothing", "w", config.contact_smoothings),
        ):
            for level in levels:
                sc = ring_on_beam(params, config.mesh, **{method: level})
                fixed = verlet_fixed(sc, 0.5, t1, max_steps=fmax)
                jobs.append(Job(name, "fixed_time", method, symbol, level, fixed))
                stop = verlet_at_stop(sc, 0.5, config)
                jobs.append(Job(name, "at_stop", method, symbol, level, stop))
    return jobs


def _row(job: Job, references: dict) -> dict[str, Any]:
    out = job.out or {}
    ref = references[(job.case, job.metric)]["fractions"]
    row = dict(
        case=job.case,
        metric=job.metric,
        method=job.method,
        parameter=job.parameter,
        value=job.value,
        result=out.get("result", "not run"),
        ok=out.get("ok", False),
        steps=out.get("steps", 0),
        rejected=out.get("rejected", 0),
        force_evaluations=out.get("force_evaluations", 0),
        t_end=out.get("t_end"),
        fractions=out.get("fractions", {}),
        compile_and_first_run_s=job.compile_s,
        wall_s=list(job.times),
        wall_median_s=statistics.median(job.times) if job.times else math.nan,
        wall_min_s=min(job.times) if job.times else math.nan,
        loadavg_1min=list(job.loads),
    )
    f = row["fractions"]
    if f and row["ok"]:
        if job.metric == "fixed_time":
            row["error"] = max_error(f, ref)
            row["error_lumped"] = max_error(lumped(f), lumped(ref))
        else:
            row["error"] = max_error(lumped(f), lumped(ref))
            row["error_lumped"] = row["error"]
        row["error_all_fractions"] = max_error(f, ref)
        row["error_components"] = {k: f[k] - ref[k] for k in ref}
    else:
        row["error"] = row["error_lumped"] = row["error_all_fractions"] = math.nan
    return row


def study(
    config: Config = Config(),
    cases: Sequence[str] | None = None,
    methods: Sequence[str] | None = None,
    metrics: Sequence[str] = ("fixed_time", "at_stop"),
    progress: Callable[[str], None] | None = None,
) -> dict[str, Any]:
    """Run the work-precision study; returns references and one row per configuration.

    **Arguments:**
    - `config`: what to run (`Config()` full, `QUICK` coarse and short).
    - `cases`: names in `CASES` (default all). `methods`: names in `METHODS` (default all).
    - `metrics`: "fixed_time" and/or "at_stop".
    - `progress`: called with a line per stage (default: stderr).
    """
    progress = progress or _progress_default
    cases = list(cases or CASES)
    methods = list(methods or METHODS)
    unknown = [c for c in cases if c not in CASES] + [m for m in methods if m not in METHODS]
    if unknown:
        raise ValueError(
            f"unknown case(s)/method(s) {unknown}; cases: {', '.join(CASES)}; "
            f"methods: {', '.join(METHODS)}"
        )
    references, rows, meta = {}, [], {}
    for name in cases:
        scene = ring_on_beam(CASES[name][1], config.mesh)
        meta[name] = dict(
            description=CASES[name][0],
            dt_critical=float(critical_step(scene)),
            k0=float(scene.initial_kinetic_energy),
        )
        progress(f"{name}: {CASES[name][0]}, dt_crit = {meta[name]['dt_critical']:.3e}")
        for metric in metrics:
            references[(name, metric)] = reference(scene, config, metric, progress)
        jobs = [j for j in case_jobs(name, scene, config, methods) if j.metric in metrics]
        time_jobs(jobs, config.repeats, progress)
        rows += [_row(j, references) for j in jobs]
    if "kvaerno5" in methods and "fixed_time" in metrics:
        try:
            rows += kvaerno_comparison(config, cases, progress)
        except Exception as error:  # noqa: BLE001 - report, keep the rest of the study
            progress(f"kvaerno5 comparison failed: {error!r}")
    return dict(
        config=_config_dict(config),
        cases=meta,
        references=[dict(case=c, **r) for (c, _), r in references.items()],
        rows=rows,
        affinity=sorted(os.sched_getaffinity(0)),
        cpu_count=os.cpu_count(),
    )


def kvaerno_comparison(
    config: Config, cases: Sequence[str], progress: Callable[[str], None]
) -> list[dict[str, Any]]:
    """The implicit solver on a tiny case (coarse mesh, short run) against Verlet and Tsit5.

    Rows use metric "fixed_time_tiny" with their own Verlet reference.
    """
    name = cases[0]
    scene = ring_on_beam(CASES[name][1], config.kvaerno_mesh)
    tiny = dataclasses.replace(config, t_fixed=config.kvaerno_t)
    ref = reference(scene, tiny, "fixed_time", progress)
    refs = {(name, "fixed_time_tiny"): ref}
    t1 = config.kvaerno_t
    jobs = [
        Job(
            name,
            "fixed_time_tiny",
            "kvaerno5_perzyna",
            "rtol",
            tol,
            rk_fixed(scene, "kvaerno5", tol, config.rk_eta, t1, 2**11),
        )
        for tol in config.kvaerno
    ]
    jobs += [
        Job(
            name,
            "fixed_time_tiny",
            "tsit5_perzyna",
            "rtol",
            tol,
            rk_fixed(scene, "tsit5", tol, config.rk_eta, t1, config.fixed_max_steps),
        )
        for tol in config.kvaerno
    ]
    jobs += [
        Job(
            name,
            "fixed_time_tiny",
            "verlet",
            "safety",
            s,
            verlet_fixed(scene, s, t1, max_steps=config.fixed_max_steps),
        )
        for s in (1.0, 0.5, 0.25)
    ]
    time_jobs(jobs, max(1, config.repeats // 2), progress)
    rows = [_row(j, refs) for j in jobs]
    for r in rows:
        r["mesh"] = _mesh_name(config.kvaerno_mesh)
        r["t_fixed"] = t1
        r["reference"] = dict(
            successive_differences=ref["successive_differences"],
            observed_order=ref["observed_order"],
        )
    return rows


def _mesh_name(mesh: Mesh) -> str:
    return f"{mesh.ring_segments}/{mesh.beam_contact_segments}+{mesh.beam_outer_segments}"


def _config_dict(config: Config) -> dict[str, Any]:
    out = dataclasses.asdict(config)
    out["mesh"] = _mesh_name(config.mesh)
    out["kvaerno_mesh"] = _mesh_name(config.kvaerno_mesh)
    return out


# ----------------------------------------------------------------------------------------------
# Stability of a candidate default step on the stability catalogue


def candidate_stability(
    safety: float, quick: bool = False, progress: Callable[[str], None] | None = None
) -> list[dict[str, Any]]:
    """Every catalogue scene run at the default step (no `step_factor`) with `safety` instead."""
    from .. import stability as st

    rows = []
    for entry in st.CATALOGUE:
        if entry.step_factor is not None or entry.float32 or entry.expect != st.FINISHES:
            continue
        e = dataclasses.replace(entry, step_factor=safety)
        row = st.run_scene(e, quick)
        (progress or _progress_default)(
            f"  stability {entry.name} at safety {safety}: {row['result']}, "
            f"error {row['energy_balance_error']:+.2e}; {row['verdict']}"
        )
        rows.append(row)
    return rows


# ----------------------------------------------------------------------------------------------
# Mesh refinement (extends msfd_jax/studies/scripts/convergence.py)


def mesh_refinement(
    factors: Sequence[int] = (4, 8),
    cases: Sequence[str] | None = None,
    progress: Callable[[str], None] | None = None,
) -> list[dict[str, Any]]:
    """Dissipated fractions at the settled stop (default settings) on refined paper meshes."""
    progress = progress or _progress_default
    rows = []
    for name in cases or CASES:
        for factor in factors:
            mesh = Mesh().refined(factor)
            scene = ring_on_beam(CASES[name][1], mesh)
            settings = Settings(history_points=11, shape_times=())
            start = time.perf_counter()
            sol = jax.block_until_ready(simulate(scene, settings))
            wall = time.perf_counter() - start
            k0 = float(sol.k0)
            f = {
                "beam_bending": float(sol.bending[scene.chain_index("beam")]) / k0,
                "beam_axial": float(sol.axial[scene.chain_index("beam")]) / k0,
                "ring_bending": float(sol.bending[scene.chain_index("ring")]) / k0,
                "ring_axial": float(sol.axial[scene.chain_index("ring")]) / k0,
                "contact": float(jnp.sum(sol.contact)) / k0,
            }
            row = dict(
                case=name,
                factor=factor,
                fractions=f,
                t_end=float(sol.t_end),
                steps=int(sol.steps),
                result=RESULTS(int(sol.result)).status,
                wall_s_with_compile=wall,
            )
            progress(f"  mesh x{factor} {name}: {row}")
            rows.append(row)
    return rows
