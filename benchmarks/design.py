"""Graded-beam design by gradients (issue 30 item 4): cost, correctness, against a
derivative-free search and the best uniform beam, on a finer mesh, a Pareto front, cold start.

The paper's SI case (`msfd_jax.PAPER_SI`: v = 30 m/s, block 67 kg, axially held beam, uniform
h_b/h_r = 2.5), one process, side by side:

1. the reverse-mode gradient of one surrogate quantity (the smoothed peak deflection) with
   respect to every segment's thickness (K = segments): its cost against a warm forward run
   (sharp, and smoothed: the map it differentiates), compile times and resident memory, and
   its agreement with central differences and forward mode (`jax.jvp`) at a fixed `Settings.dt`
   (the gradient holds the step fixed, optimise/_gradient.py);
2. the designer's problem (`optimise.design`): minimise the 10 ms deceleration, deflection
   <= 0.16 m, beam mass <= 0.9 of the uniform beam, K = 6, against the best uniform beam meeting
   the same limits (a vmapped batch of uniform beams); goal >= 15 % lower deceleration;
3. the same problem at K >= 10 by COBYLA (scipy, constraints native) from the same start, on
   the same sharp model: forward-run equivalents and wall time to reach the gradient design's
   objective; goal: gradients >= 5x fewer;
4. the design of 2. rechecked on a 2x finer mesh and at half the step (safety 0.35);
5. a Pareto front, deflection limit against the lowest deceleration, uniform and graded: the
   graded one by `optimise.design_front` (one batched run, the figure
   `docs/figures/design_pareto.png`) and by a loop of `optimise.design`, side by side;
6. the cold start of 2. (imports, compiles, design loop, checks); goal <= 3 min.

    python benchmarks/design.py --pareto 0.14 0.16 0.20 --pareto-steps 15   # the result (~15 min)
    python benchmarks/design.py --quick    # Mesh(6, 8, 2), 10 steps (~9 min: mostly compiles)

Writes benchmarks/results/design.md and docs/figures/design_pareto.png (`--quick`: both to the
scratch folder of `_bench.results_dir`).
"""

from __future__ import annotations

import time

T_START = time.perf_counter()  # before the imports: the cold start counts them

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import datetime  # noqa: E402
import os  # noqa: E402
import platform  # noqa: E402
import resource  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
from pathlib import Path  # noqa: E402

import _bench  # noqa: E402
import diffrax  # noqa: E402
import equinox as eqx  # noqa: E402
import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402
import scipy  # noqa: E402
from scipy.optimize import minimize  # noqa: E402

import msfd_jax as m  # noqa: E402
import optimise as o  # noqa: E402
from optimise._front import _sharp_lanes, _surrogate_grad_lanes  # noqa: E402

# the design module's compiled programs (no public API): the sharp quantities of a design and
# the surrogate's reverse-mode gradient, timed and checked here one by one
from optimise._graded import _sharp, _surrogate_grad, quantities, stored_checkpoints  # noqa: E402
from optimise._search import _surrogate_jacobian  # noqa: E402

T_IMPORTS = time.perf_counter() - T_START
LIMIT = 0.16  # deflection limit [m]
BUDGET = 0.9  # beam mass, fraction of the uniform h_b/h_r = 2.5 beam
BOUNDS = (1.0, 5.0)
G = 9.81
APOSTROPHE_MESH = "the paper's mesh"
FIGURE = Path(__file__).resolve().parent.parent / "docs" / "figures" / "design_pareto.png"


def rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def timed(f, *args):
    tick = time.perf_counter()
    out = jax.block_until_ready(f(*args))
    return out, time.perf_counter() - tick


@eqx.filter_jit
def _smoothed(controls, problem):
    """The surrogate's values (smoothed model, smooth peaks): what the gradient differentiates."""
    return quantities(controls, problem, sharp=False)[0]


@eqx.filter_jit
def _jvp_deflection(controls, tangent, problem):
    """Forward mode (diffrax.ForwardMode) of the surrogate deflection along `tangent`."""

    def f(c):
        return quantities(c, problem, sharp=False, adjoint=diffrax.ForwardMode())[0]["deflection"]

    return jax.jvp(f, (controls,), (tangent,))[1]


def floats(values: dict) -> dict:
    return {k: float(v) for k, v in values.items()}


def section_gradient(p, scales, mesh, rounds: int) -> tuple[list[str], dict]:
    """Item 1: cost, memory and correctness of the all-segment reverse gradient."""
    dt = float(m.critical_step(m.ring_on_beam(p, mesh))) * m.Settings().safety
    problem = o.graded_problem(
        p, scales, mesh, profile_points=None, settings=m.Settings(dt=dt), bounds=BOUNDS
    )
    n = problem.points
    stored = stored_checkpoints(problem)  # optimise.design's default
    c = jnp.asarray(np.full(n, float(p.thickness_ratio)))
    weights = {"deflection": jnp.asarray(1.0, jnp.float64)}
    e0 = jnp.zeros(n).at[0].set(1.0)
    programs = {
        "sharp forward run (`_sharp`)": (_sharp, c, problem),
        "smoothed forward run (the surrogate's values)": (_smoothed, c, problem),
        # as `optimise.design` calls it: every step's state stored (checkpoints = max_steps),
        # so the backward sweep recomputes no part of the forward run
        f"reverse gradient, all {n} segments (`_surrogate_grad`, every step stored)": (
            _surrogate_grad,
            c,
            weights,
            problem,
            "deceleration_10ms",
            stored,
        ),
        # SLSQP's (`optimise.design`'s default method): the objective's and one limit's rows
        f"reverse Jacobian, 2 rows x {n} segments (`_surrogate_jacobian`, SLSQP's)": (
            _surrogate_jacobian,
            c,
            problem,
            ("deceleration_10ms", "deflection"),
            stored,
        ),
        # diffrax's default (checkpoints=None): binomial checkpoints, steps recomputed
        f"reverse gradient, all {n} segments, diffrax's default checkpoints (recomputing)": (
            _surrogate_grad,
            c,
            weights,
            problem,
            "deceleration_10ms",
            None,
        ),
        "forward mode, one direction (`jax.jvp`, ForwardMode)": (_jvp_deflection, c, e0, problem),
    }
    first, memory = {}, {}
    for name, (f, *args) in programs.items():
        before = rss_mb()
        _, first[name] = timed(f, *args)
        memory[name] = rss_mb() - before
    _, times = _bench.interleaved_times(programs, rounds)
    med = {k: statistics.median(v) for k, v in times.items()}
    names = list(programs)
    sharp, smooth, rev, jac, recomputing, jvp = (med[k] for k in names)
    # correctness: five components against central differences and forward mode
    values, grad = _surrogate_grad(c, weights, problem, "deceleration_10ms", stored)
    grad = np.asarray(grad)
    idx = sorted({int(i) for i in np.linspace(0, n - 1, 5).round()})
    check = []
    for i in idx:
        e = jnp.zeros(n).at[i].set(1.0)
        fd = {}
        for h in (1e-3, 1e-4):
            up = float(_smoothed(c + h * e, problem)["deflection"])
            down = float(_smoothed(c - h * e, problem)["deflection"])
            fd[h] = (up - down) / (2 * h)
        fwd = float(_jvp_deflection(c, e, problem))
        check.append((i, grad[i], fd[1e-3], fd[1e-4], fwd))

    def rel(a, b):
        return abs(a - b) / max(abs(b), 1e-300)

    worst_fd = max(min(rel(g, a), rel(g, b)) for _, g, a, b, _ in check)
    worst_fwd = max(rel(g, f) for _, g, _, _, f in check)
    scale = max(abs(g) for _, g, _, _, _ in check)
    lines = [
        "## 1. Gradient cost and correctness (all segments, K = segments)",
        "",
        f"The uniform beam h_b/h_r = {float(p.thickness_ratio):g}, {n} segment thicknesses; "
        f"the surrogate quantity: the smoothed peak deflection (yield 0.05, contact 0.01, "
        f"smooth maximum). Fixed step dt = {dt:.4g} (the uniform beam's derived step, "
        "`Settings(dt=...)`): the gradient holds the step fixed, so central differences agree "
        f"with it only at a fixed dt. max_steps {problem.settings.max_steps}. Times: median "
        f"of {rounds} interleaved warm rounds (`_bench.interleaved_times`); compile = first call "
        "- median. Memory: growth of the process's peak resident set (`ru_maxrss`) over the "
        "first call of each program, in this order (compile and run; a program that fits in "
        "the peak already reached shows 0).",
        "",
        "| program | first call [s] | compile [s] | warm median [s] | x sharp forward "
        "| x smoothed forward | peak RSS growth [MB] |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    for k in names:
        lines.append(
            f"| {k} | {first[k]:.1f} | {first[k] - med[k]:.1f} | {med[k]:.3f} | "
            f"{med[k] / sharp:.1f} | {med[k] / smooth:.2f} | {memory[k]:.0f} |"
        )
    lines += [
        "",
        f"Goal (reverse gradient of all {n} thicknesses <= 8x a forward run), the gradient as "
        "`optimise.design` computes it (every step stored): "
        f"**{'met' if rev <= 8 * smooth else 'missed'}** against the smoothed forward run it "
        f"differentiates, the same map ({rev / smooth:.1f}x); "
        f"{'met' if rev <= 8 * sharp else 'missed'} against the sharp forward run "
        f"({rev / sharp:.1f}x). The smoothed model runs longer than the sharp one (its "
        "collision settles later, so fewer steps are cut by the settling rule), which is the "
        "gap between the two ratios. diffrax's default checkpoints (binomial, recomputing "
        f"steps in the backward sweep) cost {recomputing / smooth:.1f}x. Forward mode costs "
        f"{jvp / smooth:.1f}x a smoothed run per direction: {n} directions "
        f"{n * jvp / rev:.0f}x the reverse gradient. SLSQP (`optimise.design`'s default "
        "method) needs the objective's and each limit's gradient: their Jacobian, one forward "
        f"run and the backward sweeps vmapped over the rows, costs {jac / sharp:.1f} sharp runs "
        f"for two rows ({jac / rev:.2f}x the one-row gradient; `optimise._search.JACOBIAN_COST` "
        f"= {o._search.JACOBIAN_COST:g} is what `GradedDesign.evaluations` counts).",
        "",
        "| segment | reverse [m] | central diff. h = 1e-3 | central diff. h = 1e-4 | "
        "forward mode | rel. err. vs CD (best h) | rel. err. vs forward |",
        "|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for i, g, a, b, f in check:
        lines.append(
            f"| {i} | {g:.6e} | {a:.6e} | {b:.6e} | {f:.6e} | {min(rel(g, a), rel(g, b)):.1e} "
            f"| {rel(g, f):.1e} |"
        )
    lines += [
        "",
        f"Largest relative error: {worst_fd:.1e} against central differences, {worst_fwd:.1e} "
        f"against forward mode (largest component {scale:.3e} m per unit h/h_r). The smooth "
        "maximum's width (`PEAK_WIDTH` x the peak) is held by `stop_gradient`, so the reverse "
        "gradient omits the width's own change; central differences include it (a relative "
        "effect of order PEAK_WIDTH x log(samples near the top)).",
        "",
    ]
    info = {"sharp": sharp, "smooth": smooth, "reverse": rev, "jacobian": jac, "jvp": jvp, "n": n}
    return lines, info


def best_uniform(values: dict, thickness: np.ndarray, limit: float):
    """(index of the lowest deceleration among the uniform beams with deflection <= limit, or
    the one closest to the limit when none meets it; met)."""
    d = np.asarray(values["deflection"])
    a = np.asarray(values["deceleration_10ms"])
    ok = np.flatnonzero(d <= limit)
    if len(ok):
        return int(ok[np.argmin(a[ok])]), True
    return int(np.argmin(d)), False


def recheck(p, scales, mesh, designs: dict) -> tuple[dict, dict]:
    """Item 4: each design's per-segment profile on a 2x finer mesh (each value repeated
    twice: the refined mesh splits every segment in two, contact segments then outer ones, O
    to E) and at half the step; sharp values. Returns (values per check and design, each
    check's problem)."""
    fine = mesh.refined(2)
    out, problems = {}, {}
    # one compiled program per mesh: the half step's bound on the steps, the default safety
    # given as an array (a new safety compiles no new program)
    for label, on in (("design mesh", mesh), ("2x finer mesh", fine)):
        half = o.graded_problem(
            p, scales, on, profile_points=None, settings=m.Settings(safety=0.35), bounds=BOUNDS
        )
        default = dataclasses.replace(
            half, settings=dataclasses.replace(half.settings, safety=jnp.asarray(0.7, jnp.float64))
        )
        factor = m.beam_segments(on) // m.beam_segments(mesh)
        for step, problem in (("step x 1", default), ("step x 1/2", half)):
            if label == "design mesh" and step == "step x 1":
                continue  # the design's own values
            row = {}
            for name, profile in designs.items():
                controls = jnp.asarray(np.repeat(np.asarray(profile), factor))
                values, (code, error) = _sharp(controls, problem)
                row[name] = floats(values) | {"status": m.RESULTS(int(code)).status}
            out[f"{label}, {step}"] = row
            problems[f"{label}, {step}"] = problem
    return out, problems


def lanes(problem, rows) -> tuple[dict, list[str]]:
    """Sharp values of `rows` (control values, one row per collision) in one vmapped batch,
    and each row's status."""
    values, (codes, _) = _sharp_lanes(jnp.asarray(np.asarray(rows, float)), problem)
    statuses = [m.RESULTS(int(k)).status for k in np.asarray(codes)]
    return {k: np.asarray(v) for k, v in values.items()}, statuses


def best_record(values: dict, grid: np.ndarray, statuses: list[str]) -> dict:
    """The best uniform beam of a batch of the thicknesses `grid` (`best_uniform`): its
    values, thickness, whether it meets the limit and its status."""
    j, met = best_uniform(values, grid, LIMIT)
    return {k: float(v[j]) for k, v in values.items()} | {
        "thickness": float(grid[j]),
        "met": met,
        "status": statuses[j],
    }


def uniform_rechecks(problems: dict, grid: np.ndarray) -> dict:
    """The best uniform beam meeting the limits on each check's own mesh and step (section
    2's comparison made again there): the uniform thicknesses `grid` in one vmapped batch per
    check. Outside the cold start's clock (the example needs no such batch)."""
    out = {}
    for check, problem in problems.items():
        values, statuses = lanes(problem, np.repeat(grid[:, None], problem.points, 1))
        out[check] = best_record(values, grid, statuses)
    return out


def cores_used() -> tuple[str, str]:
    """(the `taskset` prefix of the command when this process is pinned, else "", and the
    cores it ran on, in words)."""
    allowed = sorted(os.sched_getaffinity(0))
    if len(allowed) < (os.cpu_count() or 1):  # pinned: say so, with the command that did it
        pinned = f"taskset -c {','.join(map(str, allowed))} "
        return pinned, f"{len(allowed)} of {os.cpu_count()} cores (taskset)"
    return "", f"{os.cpu_count()} cores"


def cold_design(p, scales, mesh, kw: dict):
    """Issue 30's example problem in this (cold) process: the problem at K = 6 on `mesh`, its
    two programs compiled (timed apart: each called once more warm) and `optimise.design`.
    Returns (problem, result, the stages' seconds from `T_START`'s imports on, the warm calls'
    seconds not counted)."""
    cold = {"imports (jax, msfd_jax, optimise, scipy)": T_IMPORTS}
    tick = time.perf_counter()
    problem = o.graded_problem(p, scales, mesh, bounds=BOUNDS)  # K = 6
    cold["problem set-up (cap, step bound)"] = time.perf_counter() - tick
    c0 = jnp.asarray(np.full(problem.points, float(p.thickness_ratio)))
    _, first = timed(_sharp, c0, problem)
    _, warm = timed(_sharp, c0, problem)
    cold["compile: sharp forward"] = first - warm
    # the program `design` runs (its default method, SLSQP: the Jacobian of the objective and
    # the limit, every step stored): another checkpoints value would compile a second program
    # inside the loop (this section did so until 2026-12-07)
    args_grad = (c0, problem, ("deceleration_10ms", "deflection"), stored_checkpoints(problem))
    _, first_g = timed(_surrogate_jacobian, *args_grad)
    _, warm_g = timed(_surrogate_jacobian, *args_grad)
    cold["compile: surrogate Jacobian (SLSQP's)"] = first_g - warm_g
    result = o.design(problem, limits={"deflection": LIMIT}, **kw)
    cold[f"design loop ({result.iterations} iterations: sharp runs and gradients)"] = (
        result.wall_time_s
    )
    return problem, result, cold, warm + warm_g


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=30, help="design iterations (quick: 10)")
    parser.add_argument(
        "--pareto", type=float, nargs="+", default=None, help="deflection limits [m]"
    )
    parser.add_argument("--pareto-steps", type=int, default=None, help="default: --steps")
    parser.add_argument("--dfo-evals", type=int, default=400, help="COBYLA's evaluation cap")
    parser.add_argument("--rounds", type=int, default=3, help="interleaved timing rounds")
    _bench.add_quick(parser)
    args = parser.parse_args()
    if args.quick:
        mesh, args.steps, args.rounds = m.Mesh(6, 8, 2), min(args.steps, 10), 2
        args.dfo_evals = min(args.dfo_evals, 200)
    else:
        mesh = m.Mesh()
    limits = args.pareto or ([0.16, 0.20] if args.quick else [0.14, 0.16, 0.18, 0.20])
    pareto_steps = args.pareto_steps or args.steps
    figure = _bench.results_dir(True) / "design_pareto.png" if args.quick else FIGURE
    p, scales = m.from_si(**dict(m.PAPER_SI, block_mass=67.0))
    h0 = float(p.thickness_ratio)
    kw = dict(
        minimise="deceleration_10ms",
        max_beam_mass_ratio=BUDGET,
        thickness_bounds=BOUNDS,
        steps=args.steps,
    )

    # --- 6 and 2: the example problem from a cold process -------------------------------
    problem, result, cold, warm_runs = cold_design(p, scales, mesh, kw)
    c0 = jnp.asarray(np.full(problem.points, h0))
    f64 = jnp.float64  # as `design` gives them (a weakly typed scalar would compile anew)
    w0 = {"deceleration_10ms": jnp.asarray(1e-3, f64), "deflection": jnp.asarray(0.0, f64)}
    names = ("deceleration_10ms", "deflection")
    print("design:", result.status, result.values, flush=True)

    # uniform beams under the same budget, one vmapped batch
    grid = np.linspace(BOUNDS[0], BUDGET * h0, 20)
    tick = time.perf_counter()
    batch, ok = lanes(problem, np.repeat(grid[:, None], problem.points, 1))
    uniform_s = time.perf_counter() - tick
    reference = floats(_sharp(c0, problem)[0])  # the uniform h_b/h_r = 2.5 beam (mass 1)
    iu, uniform_met = best_uniform(batch, grid, LIMIT)
    u_best = {k: float(v[iu]) for k, v in batch.items()}

    # --- 4: the found design and the best uniform beam on a finer mesh, half the step ------
    tick = time.perf_counter()
    designs = {
        "graded (found)": result.thickness_profile,
        f"uniform h/h_r = {grid[iu]:.3f}": np.full(len(result.thickness_profile), grid[iu]),
    }
    checks, check_problems = recheck(p, scales, mesh, designs)
    cold["checks (2x finer mesh, half step: compiles and runs)"] = time.perf_counter() - tick
    cold_total = sum(cold.values())
    print("checks:", checks, flush=True)
    own_uniform = uniform_rechecks(check_problems, grid)
    print("best uniform per check:", own_uniform, flush=True)

    # --- 1: gradient cost and correctness -------------------------------------------------
    grad_lines, cost = section_gradient(p, scales, mesh, args.rounds)

    # --- 3: gradients against COBYLA at K >= 10 --------------------------------------------
    k10 = min(10, m.beam_segments(mesh))
    problem10 = o.graded_problem(p, scales, mesh, profile_points=k10, bounds=BOUNDS)
    stored10 = stored_checkpoints(problem10)  # the programs `design` runs
    c10 = jnp.asarray(np.full(k10, h0))
    grad10 = {}
    for method in o._graded.METHODS:  # slsqp (the default), adam
        tick10 = time.perf_counter()
        _sharp(c10, problem10)  # compile the method's programs before its clock starts
        if method == "slsqp":
            jax.block_until_ready(_surrogate_jacobian(c10, problem10, names, stored10))
            per, counted = cost["jacobian"] / cost["sharp"], o._search.JACOBIAN_COST
        else:
            jax.block_until_ready(
                _surrogate_grad(c10, w0, problem10, "deceleration_10ms", stored10)
            )
            per, counted = cost["reverse"] / cost["sharp"], o._graded.GRADIENT_COST
        compile10 = time.perf_counter() - tick10
        stamps = []
        t_begin = time.perf_counter()
        found = o.design(
            problem10,
            limits={"deflection": LIMIT},
            method=method,
            progress=lambda it, rec, stamps=stamps: stamps.append(time.perf_counter()),
            **kw,
        )
        target = found.values["deceleration_10ms"]
        # feasible: the first point as good as the best; infeasible: as good as the closest
        v_target = max(0.0, found.values["deflection"] / LIMIT - 1.0)
        hit = next(
            i
            for i, r in enumerate(found.history)
            if r["violation"] <= v_target * (1 + 1e-9) and r["objective"] <= target * (1 + 1e-12)
        )
        grad10[method] = {
            "result": found,
            "target": target,
            "v_target": v_target,
            "hit": hit,
            "per": per,
            "counted": counted,
            "compile": compile10,
            "reach": {
                "counted": (hit + 1) + counted * hit,
                "measured": (hit + 1) + per * hit,
                "wall": stamps[hit] - t_begin,
            },
        }
        print(f"K = {k10}, {method}:", found.status, target, hit, flush=True)
    row = problem10.mass_row()
    start = o._graded.project_budget(np.full(k10, h0), *BOUNDS, row, BUDGET)
    scale = result.start["deceleration_10ms"]
    cache: dict = {}
    log: list = []
    t_dfo = time.perf_counter()

    def sharp_at(x):
        key = tuple(np.round(np.asarray(x, float), 15))
        if key not in cache:
            c = np.clip(np.asarray(x, float), *BOUNDS)
            values, (code, _) = _sharp(jnp.asarray(c), problem10)
            v = floats(values)
            failed = m.RESULTS(int(code)).failed
            x = np.asarray(x, float)
            in_box = (
                row @ x <= BUDGET * (1 + 1e-9)
                and np.all(x >= BOUNDS[0] - 1e-9)
                and np.all(x <= BOUNDS[1] + 1e-9)
            )
            violation = max(0.0, v["deflection"] / LIMIT - 1.0)
            cache[key] = (v, failed)
            log.append(
                (
                    time.perf_counter() - t_dfo,
                    v["deceleration_10ms"],
                    in_box and not failed and violation == 0.0,
                    violation if in_box and not failed else np.inf,
                )
            )
        return cache[key]

    def objective(x):
        v, failed = sharp_at(x)
        return 1e3 if failed else v["deceleration_10ms"] / scale

    cons = [
        {"type": "ineq", "fun": lambda x: 1.0 - sharp_at(x)[0]["deflection"] / LIMIT},
        {"type": "ineq", "fun": lambda x: BUDGET - row @ x},
        {"type": "ineq", "fun": lambda x: x - BOUNDS[0]},
        {"type": "ineq", "fun": lambda x: BOUNDS[1] - x},
    ]
    dfo = minimize(
        objective,
        start,
        method="COBYLA",
        constraints=cons,
        options={"maxiter": args.dfo_evals, "rhobeg": 0.25, "tol": 1e-4},
    )
    dfo_wall = time.perf_counter() - t_dfo
    reach_dfo = {
        method: next(
            (
                (i + 1, t)
                for i, (t, a, _, viol) in enumerate(log)
                if viol <= g["v_target"] * (1 + 1e-9) and a <= g["target"] * (1 + 1e-12)
            ),
            None,
        )
        for method, g in grad10.items()
    }
    best_dfo = min((a for _, a, ok_, _ in log if ok_), default=float("nan"))

    # --- 5: Pareto front -------------------------------------------------------------------
    # a loop of `design` (one limit after another, the single programs compiled above) and
    # one `design_front` (every limit in lockstep, its two batched programs compiled first)
    front_kw = {**kw, "steps": pareto_steps}
    graded_front = {LIMIT: result}
    tick = time.perf_counter()
    for lim in limits:
        if lim in graded_front:
            continue
        graded_front[lim] = o.design(problem, limits={"deflection": lim}, **front_kw)
        print("pareto", lim, graded_front[lim].values, flush=True)
    loop_s = time.perf_counter() - tick
    tick = time.perf_counter()
    starts = jnp.asarray(np.full((len(limits), problem.points), h0))
    jax.block_until_ready(_sharp_lanes(starts, problem))
    w_lanes = {k: jnp.full(len(limits), float(v)) for k, v in w0.items()}
    stored_p = stored_checkpoints(problem)
    jax.block_until_ready(
        _surrogate_grad_lanes(starts, w_lanes, problem, "deceleration_10ms", stored_p)
    )
    front_compile_s = time.perf_counter() - tick
    batched = o.design_front(problem, "deflection", limits, **front_kw)
    batched_front = dict(zip(limits, batched, strict=True))
    front_s = batched[0].wall_time_s
    print("front", {k: v.values for k, v in batched_front.items()}, flush=True)
    write_figure(figure, grid, batch, batched_front, limits)

    # --- the report -----------------------------------------------------------------------
    date = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")
    flag = "".join(f" {a}" for a in sys.argv[1:])
    pinned, where = cores_used()
    lines = [
        "# Graded-beam design: gradient cost, against uniform beams and a derivative-free "
        f"search ({'a coarse mesh' if args.quick else APOSTROPHE_MESH})",
        "",
        f"`{pinned}python benchmarks/design.py{flag}` · {date} · jax {jax.__version__}, "
        f"scipy {scipy.__version__}, {platform.machine()}, {jax.devices()[0].platform}, "
        f"{where} of a machine shared with other users (load average at the end "
        f"{os.getloadavg()[0]:.1f}: compare ratios within one table) · {mesh}, "
        f"{m.beam_segments(mesh)} beam segments.",
        "",
        "The case: `msfd_jax.PAPER_SI` (aluminium ring R = 0.5 m on a 3 m beam, v = 30 m/s, "
        f"block 67 kg, axially held), uniform h_b/h_r = {h0:g}. The design problem: minimise "
        f"the 10 ms block deceleration subject to peak deflection <= {LIMIT} m, beam mass <= "
        f"{BUDGET} x the uniform beam's, {BOUNDS[0]:g} <= h/h_r <= {BOUNDS[1]:g}; every value "
        "is the sharp model's.",
        "",
        *grad_lines,
    ]
    lines += report_design(
        result, batch, grid, iu, uniform_met, u_best, uniform_s, ok, h0, kw, reference
    )
    checks_lines = report_checks(checks, result, u_best, designs, own_uniform)
    lines += report_dfo(grad10, k10, dfo, log, reach_dfo, best_dfo, dfo_wall)
    lines += checks_lines
    rel_fig = os.path.relpath(figure, _bench.results_dir(args.quick))
    lines += [
        "## 5. Pareto front: deflection limit against the lowest deceleration",
        "",
        f"![Pareto front]({rel_fig})",
        "",
        f"Uniform: the {len(grid)} uniform beams above (mass <= {BUDGET}); the lowest "
        "deceleration among those within each limit. Graded, one batched run (the figure): "
        f"`optimise.design_front(problem, 'deflection', {list(limits)})`, every limit's design "
        "in lockstep, each iteration one vmapped sharp run and one vmapped gradient for all "
        f"{len(limits)}, at most {pareto_steps} steps: {front_s:.0f} s, its two programs "
        f"compiled before in {front_compile_s:.0f} s. Graded, a loop: `optimise.design` once "
        f"per limit with the single programs compiled above, {pareto_steps} steps at most "
        f"({loop_s:.0f} s; the {LIMIT} m design is that of section 2, {kw['steps']} steps at "
        "most). Both on this one core, side by side.",
        "",
        "| deflection limit [m] | best uniform [g] (h/h_r) | graded, batched [g] | deflection "
        "[m] | status | iterations | gain | graded, loop [g] | status |",
        "|---:|---:|---:|---:|---|---:|---:|---:|---|",
    ]
    for lim in sorted(batched_front):
        r, q = batched_front[lim], graded_front[lim]
        j, met = best_uniform(batch, grid, lim)
        ua = batch["deceleration_10ms"][j]
        ga = r.values["deceleration_10ms"]
        uniform = f"{ua / G:.1f} ({grid[j]:.3f})" if met else f"none (closest {grid[j]:.3f})"
        lines.append(
            f"| {lim:.3f} | {uniform} | {ga / G:.1f} | {r.values['deflection']:.4f} | "
            f"{r.status} | {r.iterations} | {100 * (1 - ga / ua):.1f} % | "
            f"{q.values['deceleration_10ms'] / G:.1f} | {q.status} |"
        )
    lines += [
        "",
        "## 6. Cold start of the example problem (section 2's design, compile included)",
        "",
        "| stage | s |",
        "|---|---:|",
        *[f"| {k} | {v:.1f} |" for k, v in cold.items()],
        f"| **total** | **{cold_total:.1f}** |",
        "",
        f"Goal (<= 3 min on this 2-core machine): **{'met' if cold_total <= 180 else 'missed'}** "
        f"({cold_total / 60:.1f} min). Not counted: one warm sharp run and one warm gradient "
        f"({warm_runs:.1f} s) timed to split compile from run.",
        "",
        f"Peak resident memory of the whole benchmark process: {rss_mb():.0f} MB; total "
        f"{time.perf_counter() - T_START:.0f} s.",
    ]
    _bench.write_result("design.md", lines, args.quick)


def loop_costs(result) -> list[str]:
    """What a gradient cost along the design (`history`'s times), against section 1's one
    point: the collisions settle earlier or later as the profile changes."""
    sharp = np.array([r["sharp_s"] for r in result.history])
    grads = np.array([r["gradient_s"] for r in result.history[:-1]])
    return [
        f"Along the design (programs compiled before the loop): {len(sharp)} sharp runs, "
        f"median {np.median(sharp):.3f} s (sum {sharp.sum():.1f} s); {len(grads)} gradients, "
        f"median {np.median(grads):.2f} s (from {grads.min():.2f} to {grads.max():.2f} s; sum "
        f"{grads.sum():.1f} s): a gradient costs {np.median(grads) / np.median(sharp):.1f} "
        f"sharp runs at the medians, {grads.sum() / sharp.sum() * len(sharp) / len(grads):.1f} "
        "on average; the rest of the loop (Python, projection, optax) "
        f"{result.wall_time_s - sharp.sum() - grads.sum():.1f} s.",
        "",
    ]


def profile_text(result) -> str:
    """A found design's profile (per segment) and its control values, one line."""
    return (
        "Profile h/h_r per segment, O (mid-span) to E (support): "
        + ", ".join(f"{x:.3f}" for x in result.thickness_profile)
        + "; control values: "
        + ", ".join(f"{x:.3f}" for x in result.controls)
        + "."
    )


def report_design(result, batch, grid, iu, met, u_best, uniform_s, ok, h0, kw, ref) -> list[str]:
    v = result.values
    gain = 1 - v["deceleration_10ms"] / u_best["deceleration_10ms"]
    lines = [
        "## 2. The designer's problem (K = 6) against the best uniform beam",
        "",
        f"`optimise.design(problem, limits={{'deflection': {LIMIT}}}, max_beam_mass_ratio="
        f"{BUDGET}, steps={kw['steps']})` from the uniform beam projected onto the budget (the "
        f"start row below): status **{result.status}**, {result.iterations} "
        f"iterations, {result.evaluations:g} forward-run equivalents (as `GradedDesign` "
        f"counts them), {result.wall_time_s:.0f} s.",
        "",
        *loop_costs(result),
        profile_text(result),
        "",
        f"Uniform beams: {len(grid)} thicknesses h/h_r = {grid[0]:g} ... {grid[-1]:g} (mass "
        f"<= {BUDGET}), one vmapped batch of the sharp model ({uniform_s:.1f} s, compile "
        f"included; statuses {sorted(set(ok))}).",
        "",
        "| beam | h/h_r | deflection [m] | 10 ms deceleration [m/s^2] | [g] | beam mass |",
        "|---|---|---:|---:|---:|---:|",
        f"| uniform, the reference (mass 1) | {h0:g} | {ref['deflection']:.4f} "
        f"| {ref['deceleration_10ms']:.0f} | {ref['deceleration_10ms'] / G:.1f} "
        f"| {ref['beam_mass']:.3f} |",
        "| the start: the reference projected onto the budget (Euclidean, in the control "
        "values: not uniform, the end control points weigh half) | "
        + ", ".join(f"{x:.3f}" for x in result.history[0]["controls"])
        + f" | {result.start['deflection']:.4f} | {result.start['deceleration_10ms']:.0f} | "
        f"{result.start['deceleration_10ms'] / G:.1f} | {result.start['beam_mass']:.3f} |",
    ]
    for h, d, a, bm in zip(
        grid, batch["deflection"], batch["deceleration_10ms"], batch["beam_mass"], strict=True
    ):
        lines.append(f"| uniform | {h:.3f} | {d:.4f} | {a:.0f} | {a / G:.1f} | {bm:.3f} |")
    lines += [
        f"| **graded (found)** | profile above | {v['deflection']:.4f} | "
        f"{v['deceleration_10ms']:.0f} | {v['deceleration_10ms'] / G:.1f} | "
        f"{v['beam_mass']:.3f} |",
        "",
    ]
    which = (
        "the best uniform beam meeting the limits"
        if met
        else (
            "no uniform beam within the budget meets the deflection limit; compared with the "
            "closest (the smallest deflection)"
        )
    )
    lines += [
        f"Against {which} (h/h_r = {grid[iu]:.3f}: deflection {u_best['deflection']:.4f} m, "
        f"{u_best['deceleration_10ms']:.0f} m/s^2): the graded beam's deceleration is "
        f"{100 * gain:.1f} % lower. Goal (>= 15 % lower at the same limits): "
        f"**{'met' if met and gain >= 0.15 and result.status != 'infeasible' else 'missed'}**"
        + ("" if result.status != "infeasible" else " (the design itself misses the limit)")
        + ".",
        "",
    ]
    return lines


def report_checks(checks, result, u_best, designs, own_uniform) -> list[str]:
    names = list(designs)
    base_gain = 1 - result.values["deceleration_10ms"] / u_best["deceleration_10ms"]
    lines = [
        "## 4. The design rechecked: 2x finer mesh, half the step",
        "",
        "The found per-segment profile with each value repeated twice on `mesh.refined(2)` "
        "(every segment split in two: contact segments, then outer ones, O to E), and on the "
        "design mesh at `Settings(safety=0.35)` (half the default 0.7); the design mesh's best "
        "uniform beam alike, and the best uniform beam meeting the limit on the check's own "
        "mesh and step (section 2's comparison made again there: the same 20 thicknesses in one "
        "vmapped batch). Two gains: against the same uniform thickness, and against that "
        "check's own best uniform beam. Sharp model.",
        "",
        "| check | beam | deflection [m] | limit met (2 % margin) | deceleration [m/s^2] "
        "| gain over the same uniform | kept | gain over this check's best uniform | kept "
        "| status |",
        "|---|---|---:|---|---:|---:|---:|---:|---:|---|",
        f"| design mesh, step x 1 | {names[0]} | {result.values['deflection']:.4f} | "
        f"{'yes' if result.values['deflection'] <= LIMIT else 'no'} | "
        f"{result.values['deceleration_10ms']:.0f} | {100 * base_gain:.1f} % | 100 % | "
        f"{100 * base_gain:.1f} % | 100 % | |",
    ]
    verdicts = []
    for check, row in checks.items():
        g, u, own = row[names[0]], row[names[1]], own_uniform[check]
        gain = 1 - g["deceleration_10ms"] / u["deceleration_10ms"]
        gain_own = 1 - g["deceleration_10ms"] / own["deceleration_10ms"]
        kept = gain / base_gain if base_gain > 0 else float("nan")
        kept_own = gain_own / base_gain if base_gain > 0 else float("nan")
        within = g["deflection"] <= LIMIT * 1.02
        verdicts.append((check, within, kept, kept_own, u, own))
        lines.append(
            f"| {check} | {names[0]} | {g['deflection']:.4f} | "
            f"{'yes' if within else 'no'} | {g['deceleration_10ms']:.0f} | {100 * gain:.1f} % "
            f"| {100 * kept:.0f} % | {100 * gain_own:.1f} % | {100 * kept_own:.0f} % "
            f"| {g['status']} |"
        )
        lines.append(
            f"| {check} | {names[1]} | {u['deflection']:.4f} | "
            f"{'yes' if u['deflection'] <= LIMIT else 'no'} | {u['deceleration_10ms']:.0f} "
            f"| | | | | {u['status']} |"
        )
        lines.append(
            f"| {check} | best uniform here: h/h_r = {own['thickness']:.3f}"
            f"{'' if own['met'] else ' (none meets the limit: the closest)'} | "
            f"{own['deflection']:.4f} | {'yes' if own['met'] else 'no'} | "
            f"{own['deceleration_10ms']:.0f} | | | | | {own['status']} |"
        )
    lines += [""]
    for check, within, kept, kept_own, u, own in verdicts:
        lines.append(
            f"- {check}: deflection limit {'holds' if within else 'does not hold'} within 2 %; "
            f"against this check's best uniform beam "
            f"{'meeting the limit' if own['met'] else '(none meets the limit: the closest)'} "
            f"(h/h_r = {own['thickness']:.3f}) the gain keeps {100 * kept_own:.0f} % of itself "
            f"(goal >= 80 %: **{'met' if kept_own >= 0.8 else 'missed'}**); against the design "
            f"mesh's uniform thickness, which here deflects {u['deflection']:.4f} m "
            f"({'within' if u['deflection'] <= LIMIT else 'past'} the limit), {100 * kept:.0f} %."
        )
    lines.append("")
    return lines


def verdict(reach, ratio: float) -> str:
    """The goal's verdict: met, missed, or undecided when COBYLA stopped before reaching the
    target (the ratio is then a lower bound)."""
    if ratio >= 5:
        return "met"
    return "missed" if reach else "undecided (COBYLA stopped first: a lower bound)"


def report_dfo(grad10, k, dfo, log, reach_dfo, best_dfo, dfo_wall) -> list[str]:
    label = {"slsqp": "SLSQP (the default)", "adam": "Adam, augmented Lagrangian"}
    lines = [
        f"## 3. Gradients against a derivative-free search (K = {k} control points)",
        "",
        "All from the same start (the uniform beam projected into the budget), on the same "
        f"sharp objective and limits. Gradient: `optimise.design` with K = {k}, by each of its "
        "methods. Derivative-free: `scipy.optimize.minimize(method='COBYLA')` (constraints "
        f"native: deflection <= {LIMIT} m, mass budget and bounds as inequalities; rhobeg "
        f"0.25, {len(log)} evaluations made), each distinct point one sharp run. A gradient "
        "point's cost in forward runs: one sharp run and the surrogate's gradient (Adam: one "
        "row) or Jacobian (SLSQP: the objective's and the limit's rows), counted in "
        "`GradedDesign.evaluations` by the constants `GRADIENT_COST` and `JACOBIAN_COST`, and "
        "measured in section 1 (both given). Wall times exclude compiling (each method's "
        "programs compiled before its clock; COBYLA reuses the sharp program).",
        "",
        "| method | status, points | best feasible [m/s^2] (g) | deflection [m] | reached at "
        "point | forward-run equivalents to reach it (counted, measured) | wall to reach it "
        "[s] | total wall [s] (compile before) |",
        "|---|---|---:|---:|---:|---:|---:|---:|",
    ]
    for method, g in grad10.items():
        r, reach = g["result"], g["reach"]
        lines.append(
            f"| {label[method]} | {r.status}, {r.iterations} | {g['target']:.0f} "
            f"({g['target'] / G:.1f}) | {r.values['deflection']:.4f} | {g['hit']} | "
            f"{reach['counted']:.0f}, {reach['measured']:.0f} | {reach['wall']:.0f} | "
            f"{r.wall_time_s:.0f} ({g['compile']:.0f}) |"
        )
    lines.append(
        f"| COBYLA | {dfo.message.split('because ')[-1].rstrip('.')} | {best_dfo:.0f} "
        f"({best_dfo / G:.1f}) | | | | | {dfo_wall:.0f} |"
    )
    lines += [
        "",
        "COBYLA to reach each gradient design's objective (the same limit excess or less):",
        "",
        "| target | COBYLA evaluations (= forward runs) | COBYLA wall [s] | COBYLA / gradient, "
        "forward-run equivalents (measured cost) | goal (>= 5) |",
        "|---|---:|---:|---:|---|",
    ]
    for method, g in grad10.items():
        reach = reach_dfo[method]
        need = reach[0] if reach else len(log)
        ratio = need / g["reach"]["measured"]
        at = (
            f"{reach[0]} | {reach[1]:.0f}"
            if reach
            else f"not reached (> {len(log)}) | > {dfo_wall:.0f}"
        )
        lines.append(
            f"| {label[method]}: {g['target']:.0f} m/s^2 | {at} | "
            f"{'' if reach else '> '}{ratio:.2g}x | **{verdict(reach, ratio)}** |"
        )
    lines.append("")
    return lines


def write_figure(path: Path, grid, batch, front: dict, limits) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    d = np.asarray(batch["deflection"])
    a = np.asarray(batch["deceleration_10ms"]) / G
    ax.plot(d, a, "o", color="tab:gray", ms=4, label="uniform beams (mass <= 0.9)")
    xs = np.linspace(min(d.min(), min(front)) * 0.98, max(d.max(), max(front)) * 1.02, 200)
    best = [a[d <= x].min() if np.any(d <= x) else np.nan for x in xs]
    ax.step(xs, best, where="post", color="tab:gray", label="best uniform within the limit")
    lims = sorted(front)
    ax.plot(
        lims,
        [front[x].values["deceleration_10ms"] / G for x in lims],
        "s-",
        color="tab:red",
        label="graded (optimise.design, K = 6)",
    )
    ax.set_xlabel("deflection limit (uniform: deflection) [m]")
    ax.set_ylabel("lowest 10 ms block deceleration [g]")
    ax.set_title("Guardrail design: deflection limit against deceleration")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    main()
