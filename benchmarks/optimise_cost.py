"""Cost of a design gradient relative to a forward run, its memory, and the time to tune (issue 4).

Base case (paper's mesh and settings, until settled), h_b/h_r = 2.5, smoothing s = 0.05,
w = 0.01 (the first annealing stage). Measures, after compiling:

- a forward run (the smoothed model's partition), a forward-mode gradient (jax.jvp through
  diffrax.ForwardMode, one design variable) and a reverse-mode gradient (jax.grad through
  RecursiveCheckpointAdjoint; the sweep alone, given dJ/df), median of `REPEATS`, and the
  memory XLA plans for each compiled program (`memory_analysis()`: temporaries, arguments,
  outputs);
- before/after two levers: saving no histories (``make_problem(lean=False)``, the old
  behaviour, saving 1001 history samples and the shapes, vs ``lean=True``, the default now),
  and the number of checkpoints of the reverse sweep (diffrax's default log2(max_steps) vs
  more);
- `optimise.tune` of the base case to a beam share of 0.6 K0 within 0.01 K0 (forward mode),
  its wall time (first call, which compiles the forward program, and a second call), and the
  same without the sharp-model correction.

Success rates over starts and targets: benchmarks/tuning_success.py. Writes
benchmarks/results/optimise.md.

    python benchmarks/optimise_cost.py
"""

from __future__ import annotations

import platform
import resource
import statistics
import tempfile
import time
from pathlib import Path

import jax
import jax.numpy as jnp

import msfd_jax as m
import optimise as o
from optimise._gradient import _forward, _reverse
from optimise._problem import _evaluate, arrays, objective_value_and_grad

REPEATS = 3
SMOOTH = dict(yield_smoothing=0.05, contact_smoothing=0.01)
OUT = Path(__file__).parent / "results" / "optimise.md"
MB = 1024.0**2


def _timed(fn):
    start = time.perf_counter()
    out = jax.block_until_ready(fn())
    return time.perf_counter() - start, out


def _median(fn) -> tuple[float, float]:
    first, _ = _timed(fn)
    return first, statistics.median(_timed(fn)[0] for _ in range(REPEATS))


def _memory(jitted, *args) -> str:
    """Temporaries / arguments / outputs XLA plans for the compiled program [MB]."""
    stats = jitted.lower(*args).compile().compiled.memory_analysis()
    if stats is None:
        return "n/a"
    return (
        f"{stats.temp_size_in_bytes / MB:.1f} / {stats.argument_size_in_bytes / MB:.2f} / "
        f"{stats.output_size_in_bytes / MB:.2f}"
    )


def _costs(problem, design, goal, checkpoints=(None,)):
    """Rows (name, first, median, memory) for the primal, jvp and reverse programs."""
    smoothing = arrays((SMOOTH["yield_smoothing"], SMOOTH["contact_smoothing"]))
    d = arrays(design)
    at = o.evaluate(design, problem, goal, **SMOOTH).fractions
    _, weights = objective_value_and_grad(arrays(goal), at)
    tangent = jax.tree_util.tree_map(jnp.ones_like, d)
    rows = []
    primal = _median(lambda: o.evaluate(design, problem, goal, **SMOOTH).fractions)
    rows.append(("forward run", *primal, _memory(_evaluate, d, problem, *smoothing)))
    forward = _median(lambda: o.gradient(design, problem, goal, mode="forward", **SMOOTH)[1])
    rows.append(
        ("jvp gradient (1 variable)", *forward, _memory(_forward, d, tangent, problem, *smoothing))
    )
    for n in checkpoints:
        reverse = _median(
            lambda n=n: o.gradient(
                design, problem, goal, mode="reverse", partition_at=at, checkpoints=n, **SMOOTH
            )[1]
        )
        label = "log2(max_steps)" if n is None else str(n)
        rows.append(
            (
                f"reverse gradient, {label} checkpoints (sweep, given dJ/df)",
                *reverse,
                _memory(_reverse, d, weights, problem, *smoothing, n),
            )
        )
    return rows, at


def main() -> None:
    # a fresh persistent cache: the timed first calls compile, and lowering a program again for
    # its memory analysis then reads it from the cache instead of compiling it twice
    jax.config.update("jax_compilation_cache_dir", tempfile.mkdtemp(prefix="msfd-optimise-"))
    start = time.perf_counter()
    design = o.Design(thickness_ratio=2.5)
    box = o.default_box(design)
    goal = o.objective(o.TargetShare("beam", 0.6))
    full = o.make_problem(m.CollisionParams(), m.Mesh(), m.Settings(), box, lean=False)
    lean = o.make_problem(m.CollisionParams(), m.Mesh(), m.Settings(), box)
    steps = lean.settings.max_steps
    lines = [
        "# optimise: gradient cost, memory and tuning time (base case, paper's mesh, until "
        "settled)",
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
    for name, problem, checkpoints in (
        ("before: histories saved (1001 samples + shapes), `make_problem(lean=False)`", full,
         (None,)),
        ("after: no histories saved, `make_problem()` (lean, the default)", lean,
         (None, 1024, steps)),
    ):  # fmt: skip
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
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    lines += [
        "",
        f"Peak resident memory of the whole benchmark process: {rss:.0f} MB; total "
        f"{time.perf_counter() - start:.0f} s.",
    ]
    OUT.write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
