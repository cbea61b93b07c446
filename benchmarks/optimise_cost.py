"""Cost of a design gradient relative to a forward run, its memory, and the time to tune (issue 4).

Base case (paper's mesh and settings, until settled), h_b/h_r = 2.5, smoothing s = 0.05,
w = 0.01 (the first annealing stage). Measures, after compiling:

- a forward run (the smoothed model's partition), a forward-mode gradient (jax.jvp through
  diffrax.ForwardMode, one design variable) and a reverse-mode gradient (jax.grad through
  RecursiveCheckpointAdjoint; the sweep alone, given dJ/df), the median of `REPEATS` rounds
  in which every program is timed in turn (interleaved, so the ratios are side by side), and the
  memory XLA plans for each compiled program (`memory_analysis()`: temporaries, arguments,
  outputs);
- before/after two levers: saving no histories (``make_problem(lean=False)``, the old
  behaviour, saving 1001 history samples and the shapes, vs ``lean=True``, the default now),
  and the number of checkpoints of the reverse sweep (diffrax's default log2(max_steps) vs
  more);
- `optimise.tune` of the base case to a beam share of 0.6 K0 within 0.01 K0 (forward mode),
  its wall time (first call, which compiles the forward program, and a second call), and the
  same without the sharp-model correction.

Success rates over starts and targets: benchmarks/tuning_success.py. Every form writes
benchmarks/results/optimise.md (`--quick`: a scratch folder).

    python benchmarks/optimise_cost.py [--batch 8]   # everything (~7 min)
    python benchmarks/optimise_cost.py --lean        # goal 5's table (~3 min; the current result)
    python benchmarks/optimise_cost.py --jvp-only    # the forward run and its jvp only
    python benchmarks/optimise_cost.py --quick       # --jvp-only on a coarse mesh, 2 rounds

`--lean` was called `--quick` until the benchmarks were cut (issue 29).
"""

from __future__ import annotations

import argparse
import dataclasses
import platform
import resource
import statistics
import tempfile
import time
from pathlib import Path

import _bench
import diffrax
import jax
import jax.numpy as jnp
import numpy as np

import msfd_jax as m
import optimise as o

# the batched, differentiable solve of many designs (goal 5's batched jvp) and the sweep's
# step bound for it: the public `sweep` is neither batched under jit nor differentiable
from msfd_jax._sweeps.queue import solve_batch
from msfd_jax._sweeps.sweep import sweep_step_bound

# the compiled programs behind `o.evaluate` and `o.gradient` (forward run, jvp, reverse) and
# their arguments, lowered for the memory XLA plans for each (no public API)
from optimise._gradient import _forward, _reverse
from optimise._problem import _evaluate, arrays, objective_value_and_grad

REPEATS = 5  # interleaved rounds (`_medians`)
SMOOTH = dict(yield_smoothing=0.05, contact_smoothing=0.01)
QUICK_MESH = m.Mesh(ring_segments=8, beam_contact_segments=10, beam_outer_segments=3)
MB = 1024.0**2
APOSTROPHE = "'"


def _medians(programs: dict) -> dict[str, tuple[float, float]]:
    """(first call, median) of each zero-argument program, timed in turn for `REPEATS`
    rounds (`_bench.interleaved_times`), so the ratios compare like with like."""
    first, times = _bench.interleaved_times({k: (f,) for k, f in programs.items()}, REPEATS)
    return {k: (first[k], statistics.median(times[k])) for k in programs}


def _memory(jitted, *args) -> str:
    """Temporaries / arguments / outputs XLA plans for the compiled program [MB]."""
    compiled = jitted.lower(*args).compile()
    stats = getattr(compiled, "compiled", compiled).memory_analysis()  # eqx or jax jit
    if stats is None:
        return "n/a"
    return (
        f"{stats.temp_size_in_bytes / MB:.1f} / {stats.argument_size_in_bytes / MB:.2f} / "
        f"{stats.output_size_in_bytes / MB:.2f}"
    )


def _costs(problem, design, goal, checkpoints=(None,)):
    """Rows (name, first, median, memory) for the primal, jvp and reverse programs (no
    reverse rows for `checkpoints` empty)."""
    smoothing = arrays((SMOOTH["yield_smoothing"], SMOOTH["contact_smoothing"]))
    d = arrays(design)
    at = o.evaluate(design, problem, goal, **SMOOTH).fractions
    _, weights = objective_value_and_grad(arrays(goal), at)
    tangent = jax.tree_util.tree_map(jnp.ones_like, d)
    programs = {
        "forward run": lambda: o.evaluate(design, problem, goal, **SMOOTH).fractions,
        "jvp gradient (1 variable)": lambda: o.gradient(
            design, problem, goal, mode="forward", **SMOOTH
        )[1],
    }
    memory = {
        "forward run": lambda: _memory(_evaluate, d, problem, *smoothing),
        "jvp gradient (1 variable)": lambda: _memory(_forward, d, tangent, problem, *smoothing),
    }
    for n in checkpoints:
        label = f"reverse gradient, {'log2(max_steps)' if n is None else n} checkpoints"
        label += " (sweep, given dJ/df)"
        programs[label] = lambda n=n: o.gradient(
            design, problem, goal, mode="reverse", partition_at=at, checkpoints=n, **SMOOTH
        )[1]
        memory[label] = lambda n=n: _memory(_reverse, d, weights, problem, *smoothing, n)
    timings = _medians(programs)
    rows = [(k, *timings[k], memory[k]()) for k in programs]
    return rows, at


def _batched(problem, first_forward: float, size: int) -> list[str]:
    """Issue 11 goal 5: every design's derivative of a batch in one batched forward-mode pass.

    `size` designs (h_b/h_r from 1 to 4, the base case otherwise, smoothed as above) through
    `solve_batch`: the batched forward run and one `jax.jvp` with ``diffrax.ForwardMode()``
    and a tangent of ones (each design's derivative along its own thickness), per design
    against the single forward run of the table above.
    """
    h = jnp.linspace(1.0, 4.0, size)
    base = m.CollisionParams()
    params = m.CollisionParams(
        **{f: jnp.full(size, float(getattr(base, f))) for f in base.__dataclass_fields__}
    )
    params = dataclasses.replace(params, thickness_ratio=h)
    mesh, settings = problem.mesh, problem.settings
    one = jax.vmap(lambda p: m.critical_step(m.ring_on_beam(p, mesh)))
    dt_crit = jax.jit(one)(params)
    bound = max(sweep_step_bound(np.asarray(dt_crit), settings), settings.max_steps)

    def beam_share(thickness, adjoint=None):
        p = dataclasses.replace(params, thickness_ratio=thickness)
        out = solve_batch(p, mesh, settings, dt_crit, max_steps=bound, adjoint=adjoint, **SMOOTH)
        return out["beam_bending"] + out["beam_axial"]

    forward = jax.jit(beam_share)
    tangents = jax.jit(
        lambda t: jax.jvp(lambda x: beam_share(x, diffrax.ForwardMode()), (h,), (t,))
    )
    ones = jnp.ones(size)
    names = ("batched forward run", "batched jvp (each design along its own h_b/h_r)")
    timings = _medians(dict(zip(names, (lambda: forward(h), lambda: tangents(ones)), strict=True)))
    rows = [
        (names[0], *timings[names[0]], _memory(forward, h)),
        (names[1], *timings[names[1]], _memory(tangents, ones)),
    ]
    lines = [
        f"## Batched forward mode: {size} designs in one pass (`solve_batch`, issue 11 goal 5)",
        "",
        f"h_b/h_r = 1 ... 4 ({size} designs), the base case otherwise, s = 0.05, w = 0.01; "
        f"max_steps {bound}. Per design = median / {size}; x single forward = per design / "
        "the lean single forward run's median above.",
        "",
        "| what | first call [s] (compiles) | median [s] | per design [s] | x single forward "
        "| memory [MB] |",
        "|---|---|---|---|---|---|",
    ]
    for what, first, med, memory in rows:
        per = med / size
        lines.append(
            f"| {what} | {first:.2f} | {med:.3f} | {per:.4f} | {per / first_forward:.2f} "
            f"| {memory} |"
        )
    jvp_over_forward = rows[1][2] / rows[0][2]
    lines += ["", f"Batched jvp / batched forward: {jvp_over_forward:.2f}x.", ""]
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--lean",
        action="store_true",
        help="the lean problem only (no `lean=False` rows), checkpoints log2(max_steps) and "
        "max_steps, no tuning runs",
    )
    parser.add_argument("--batch", type=int, default=8, help="designs in the batched pass")
    parser.add_argument(
        "--jvp-only",
        action="store_true",
        help="the lean problem's forward run and jvp gradient only (issue 11 goal 5)",
    )
    _bench.add_quick(parser)
    args = parser.parse_args()
    global REPEATS
    mesh = m.Mesh()
    if args.quick:
        args.jvp_only, mesh, REPEATS = True, QUICK_MESH, 2
    out = _bench.results_dir(args.quick) / "optimise.md"
    # a fresh persistent cache: the timed first calls compile, and lowering a program again for
    # its memory analysis then reads it from the cache instead of compiling it twice
    jax.config.update("jax_compilation_cache_dir", tempfile.mkdtemp(prefix="msfd-optimise-"))
    start = time.perf_counter()
    design = o.Design(thickness_ratio=2.5)
    box = o.default_box(design)
    goal = o.objective(o.TargetShare("beam", 0.6))
    full = o.make_problem(m.CollisionParams(), mesh, m.Settings(), box, lean=False)
    lean = o.make_problem(m.CollisionParams(), mesh, m.Settings(), box)
    steps = lean.settings.max_steps
    lines = [
        "# optimise: gradient cost, memory and tuning time (base case, "
        f"{'a coarse' if args.quick else 'the paper' + APOSTROPHE + 's'} mesh, until settled)",
        "",
        f"Produced by `python benchmarks/optimise_cost.py`; jax {jax.__version__}, "
        f"{platform.machine()}, {jax.devices()[0].platform}, 2 cores shared with other users "
        "(their load changes during a run: compare ratios within one table); max_steps "
        f"{steps} diffrax steps of "
        f"{lean.settings.substeps} Verlet steps.",
        "",
        "## Cost and memory of a gradient (h_b/h_r = 2.5, s = 0.05, w = 0.01)",
        "",
        "Memory: what XLA plans for the compiled program, temporaries / arguments / outputs "
        "[MB] (`Compiled.memory_analysis()`).",
        "",
    ]
    results = {}
    cases = (
        ("before: histories saved (1001 samples + shapes), `make_problem(lean=False)`", full,
         (None,)),
        ("after: no histories saved, `make_problem()` (lean, the default)", lean,
         (None, 1024, steps)),
    )  # fmt: skip
    if args.jvp_only:
        flag = "--quick" if args.quick else "--jvp-only"
        lines[2] = lines[2].replace("optimise_cost.py`", f"optimise_cost.py {flag}`")
        rows, _ = _costs(lean, design, goal, ())
        lines += [
            "| what | first call [s] (compiles) | median [s] | x forward run | memory [MB] |",
            "|---|---|---|---|---|",
        ]
        for what, first, med, memory in rows:
            ratio = med / rows[0][2]
            lines.append(f"| {what} | {first:.2f} | {med:.3f} | {ratio:.2f} | {memory} |")
        lines += ["", f"Issue 11 goal 5: jvp <= 2x ({rows[1][2] / rows[0][2]:.2f}x measured)."]
        _finish(lines, start, out)
        return
    if args.lean:
        lines[2] = lines[2].replace("optimise_cost.py`", "optimise_cost.py --lean`")
        cases = (("no histories saved, `make_problem()` (lean, the default)", lean, (None, steps)),)
    for name, problem, checkpoints in cases:
        rows, at = _costs(problem, design, goal, checkpoints)
        results[name] = (rows, at)
        base = rows[0][2]
        lines += [
            f"### {name}",
            "",
            "| what | first call [s] (compiles) | median [s] | x forward run | memory [MB] |",
            "|---|---|---|---|---|",
        ]
        for what, first, med, memory in rows:
            lines.append(f"| {what} | {first:.2f} | {med:.3f} | {med / base:.2f} | {memory} |")
        lines.append("")
    if args.lean:
        ((rows_lean, _),) = results.values()
        jvp = rows_lean[1][2] / rows_lean[0][2]
        rev = min(r[2] for r in rows_lean[2:]) / rows_lean[0][2]
        lines += [
            f"Issue 11 goal 5: jvp <= 2x ({jvp:.2f}x measured), reverse <= 4x ({rev:.2f}x "
            "measured, best checkpoint count; its memory in the table).",
            "",
        ]
        lines += _batched(lean, rows_lean[0][2], args.batch)
        _finish(lines, start, out)
        return
    (rows_full, at_full), (rows_lean, at_lean) = results.values()
    diff = max(abs(float(at_full[k]) - float(at_lean[k])) for k in at_full)
    jvp, rev = rows_lean[1][2] / rows_lean[0][2], min(r[2] for r in rows_lean[2:]) / rows_lean[0][2]
    lines += [
        f"The partition is the same either way (largest difference {diff:.1e} K0).",
        "",
        f"Targets of issue 4: jvp <= 2x ({jvp:.2f}x measured, lean), reverse <= 6x "
        f"({rev:.2f}x measured, lean, best checkpoint count). Absolute: forward run "
        f"{rows_full[0][2]:.3f} s -> {rows_lean[0][2]:.3f} s, jvp {rows_full[1][2]:.3f} s -> "
        f"{rows_lean[1][2]:.3f} s, reverse {rows_full[2][2]:.3f} s -> "
        f"{min(r[2] for r in rows_lean[2:]):.3f} s.",
        "",
        *_batched(lean, rows_lean[0][2], args.batch),
        "## Tuning the base case to a beam share of 0.6 K0 within 0.01 K0 (lean problem)",
        "",
        "| run | status | iterations | h_b/h_r | sharp beam share | wall [s] |",
        "|---|---|---|---|---|---|",
    ]
    for name, kwargs in (
        ("forward mode, first call", {}),
        ("forward mode, again (compiled)", {}),
        ("reverse mode", {"mode": "reverse"}),
        ("no sharp correction (tunes the smoothed model)", {"sharp_correction": False}),
    ):
        r = o.tune(design, lean, goal, box=box, progress=None, **kwargs)
        beam = r.fractions["beam_bending"] + r.fractions["beam_axial"]
        h = r.design.as_floats()["thickness_ratio"]
        lines.append(
            f"| {name} | {r.status} | {r.iterations} | {h:.4f} | {beam:.4f} | {r.wall_time_s:.1f} |"
        )
    _finish(lines, start, out)


def _finish(lines: list[str], start: float, out: Path) -> None:
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    lines += [
        "",
        f"Peak resident memory of the whole benchmark process: {rss:.0f} MB; total "
        f"{time.perf_counter() - start:.0f} s.",
    ]
    out.write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
