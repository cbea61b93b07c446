"""The same code on a GPU (issue 11, goal 7): correctness against the CPU record, the cost of
a collision-step against the slot count and the contact loop, and whole sweeps' collisions/s.

With a GPU (``pip install ".[cuda]"``), in one call that keeps to `--budget-s` (a stage that
would not fit is skipped and said so; results are written after every stage):

1. **scan**: each contact loop (`--loops`: ``blocks``, a conditional per block, the CPU's
   choice; ``dense``, every pair with no conditional) at the first slot count B of
   `--slots`, then the fastest loop so far at the others:
   B collisions of the paper mesh (sweep_1024.py's grid refined to B rows: h_b/h_r
   0.25-5 x free/held x g = 5, 10, 20, 40 x v0 = 0.6, 0.82), a few segments into contact,
   then `--segments` segments of the sweep's program (64 diffrax steps x 8 Verlet substeps)
   timed one by one (median): µs per collision-step, and the compile time of the programs.
2. **check**: the showcase and the thick beam (`msfd_jax.run`) and the 64-collision sweep
   of `regression_baseline.py` on this device against the CPU's numbers of the same code
   (benchmarks/results/gpu_reference.json, written by ``--platform cpu --stages
   reference``): |fraction differences| in K0 and step counts; the showcase's warm time.
3. **sweep**: whole sweeps (`msfd_jax.sweep`, default settings but the contact loop, one
   worker) of `--sweep-n` collisions (default B and 4 B) at the best (loop, B) of the scan
   (or `--sweep-slots`):
   collisions/s and µs per collision-step without compilation, and the compile time.

Without a GPU it says so, measures nothing and writes that to the results file.
``--platform cpu`` runs the same stages on the CPU (small sizes) to check the script.

    python benchmarks/gpu_throughput.py          # writes benchmarks/results/gpu_latest.md
                                                 # (and .json; results/gpu.md summarises the
                                                 # H200's runs, which --out named apart)
    python benchmarks/gpu_throughput.py --platform cpu --slots 16 32 --sweep-n 64 \\
        --segments 2 --out /tmp/gpu.md                     # the script, on the CPU
    python benchmarks/gpu_throughput.py --platform cpu --stages reference  # the check's file
    python benchmarks/gpu_throughput.py --quick   # the scan at 16 slots, 2 segments, on the
                                                  # GPU if there is one, else the CPU
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime
import json
import subprocess
import sys
import time
import traceback
from pathlib import Path

import _bench
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"
SEGMENTS_IN = 4  # segments run before timing: every slot in contact


def grid(n: int) -> dict:
    """sweep_1024.py's grid (64 x 2 x 4 x 2 = 1024 rows) refined to n rows (n // 16 h_b/h_r)."""
    return {
        "thickness_ratio": np.linspace(0.25, 5.0, max(1, n // 16)),
        "axial_constraint": [0.0, 1.0],
        "mass_ratio": [5.0, 10.0, 20.0, 40.0],
        "velocity": [0.6, 0.82],
    }


def params_of(n: int):
    """CollisionParams with fields of shape (n,): the rows of `grid(n)`."""
    import itertools

    import jax.numpy as jnp

    from msfd_jax import CollisionParams

    g = grid(n)
    rows = np.array(list(itertools.product(*g.values())))
    base = CollisionParams().as_arrays()
    fields = {k: jnp.full(len(rows), float(v))
              for k, v in base.scalars().items()}  # fmt: skip
    for i, k in enumerate(g):
        fields[k] = jnp.asarray(rows[:, i])
    return CollisionParams(**fields)


def segment_cost(loop: str, b: int, segments: int) -> dict:
    """µs per collision-step of the sweep's segment program at B = b slots."""
    import jax
    import jax.numpy as jnp

    import msfd_jax as m

    # the sweep queue's segment program itself, on slots set up as the queue sets them
    # (settings, stability limits, start): what the scan times (no public API)
    from msfd_jax._sweeps import queue as _queue
    from msfd_jax._sweeps import sweep as _sweep
    from msfd_jax._sweeps.shard import _critical_chunk

    mesh = m.Mesh()
    settings = _sweep._sweep_settings(_bench.sweep_settings(), mesh)
    settings = dataclasses.replace(settings, max_steps=1 << 20, contact_loop=loop)
    p = params_of(b)
    tick = time.perf_counter()
    dt_crit, _, _ = jax.jit(_critical_chunk, static_argnums=(1, 2))(p, mesh, (0.0, 0.0))
    smoothing = _queue.with_flags((0.0, 0.0))
    flat, clock, y = _queue._start(
        p, dt_crit, mesh, smoothing, settings, jnp.full(b, 1e9), jnp.ones(b)
    )
    segment = _queue.DEFAULT_SEGMENT
    run = _queue._segment.lower(flat, clock, y, settings, segment).compile()
    jax.block_until_ready(y)
    compile_s = time.perf_counter() - tick
    for _ in range(SEGMENTS_IN):
        y = run(flat, clock, y, settings, segment)
    jax.block_until_ready(y)
    running = int(b - np.sum(np.asarray(y.done)))
    times = []
    for _ in range(segments):
        tick = time.perf_counter()
        y = jax.block_until_ready(run(flat, clock, y, settings, segment))
        times.append(time.perf_counter() - tick)
    steps = segment * settings.substeps
    median = float(np.median(times))
    return dict(
        loop=loop, slots=b, running=running, compile_s=compile_s, segment_s=times,
        us_per_collision_step=1e6 * median / (steps * b), us_per_step=1e6 * median / steps,
    )  # fmt: skip


REFERENCE = RESULTS / "gpu_reference.json"
CHECK_SINGLES = ("showcase", "thick")  # robust to rounding (thin_free is not: test_regression)


def computed(loop: str | None) -> dict:
    """The check's numbers on this device: the showcase and the thick beam (`msfd_jax.run`,
    first attempts) and regression_baseline.py's 64-collision sweep, with the showcase's
    warm wall time."""
    import msfd_jax as m

    # first attempts only (no balance reruns), as the regression record holds them: a
    # process-wide switch of the retry policy that no public API exposes
    from msfd_jax._collision.attempts import first_attempts
    from msfd_jax.studies.scripts import regression_baseline as rb

    out: dict = {"singles": {}}
    for name in CHECK_SINGLES:
        tick = time.perf_counter()
        out["singles"][name] = rb.single(name)
        out[f"{name}_first_s"] = time.perf_counter() - tick
    tick = time.perf_counter()
    with first_attempts():
        m.run(m.CollisionParams(), m.Mesh())
    out["showcase_warm_s"] = time.perf_counter() - tick
    settings = _sweep_settings(loop)
    tick = time.perf_counter()
    with first_attempts():
        table = m.sweep(rb.SWEEP_GRID, m.Mesh(), settings, progress=False)
    out["sweep_s"] = time.perf_counter() - tick
    out["sweep_timing"] = dict(table.timing)
    out["sweep_loop"] = settings.contact_loop or "default"
    out["sweep"] = [
        {k: float(table[k][i]) for k in rb.FRACTIONS}
        | {"steps": int(table["steps"][i]), "status": str(table["status"][i])}
        for i in range(len(table))
    ]
    return out


def _sweep_settings(loop: str | None):
    if loop is None:
        return _bench.sweep_settings()
    return dataclasses.replace(_bench.sweep_settings(), contact_loop=loop)


def write_reference() -> dict:
    """The CPU's numbers for the check (benchmarks/results/gpu_reference.json)."""
    import platform

    import jax

    ref = computed(None)
    ref.update(jax=jax.__version__, cpu=platform.processor() or platform.machine(),
               date=datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC"))  # fmt: skip
    REFERENCE.write_text(json.dumps(ref, indent=1) + "\n")
    return {"wrote": str(REFERENCE)}


def check(loop: str | None) -> dict:
    """This device's numbers against the CPU's (`write_reference`)."""
    from msfd_jax.studies.scripts import regression_baseline as rb

    ref = json.loads(REFERENCE.read_text())
    now = computed(loop)
    out = {k: v for k, v in now.items() if k not in ("singles", "sweep")}
    out["reference"] = dict(jax=ref["jax"], cpu=ref["cpu"], date=ref["date"])
    for name in CHECK_SINGLES:
        a, b = ref["singles"][name], now["singles"][name]
        out[name] = dict(
            steps=(a["steps"], b["steps"]), status=b["status"],
            max_fraction_diff=max(abs(a["fractions"][k] - b["fractions"][k]) for k in rb.FRACTIONS),
        )  # fmt: skip
    diffs = np.array([max(abs(a[k] - b[k]) for k in rb.FRACTIONS)
                      for a, b in zip(ref["sweep"], now["sweep"], strict=True)])  # fmt: skip
    out["sweep"] = dict(
        loop=now["sweep_loop"], rows=len(diffs), max_fraction_diff=float(diffs.max()),
        median_fraction_diff=float(np.median(diffs)),
        within_1e9=int(np.sum(diffs <= 1e-9)), within_1e6=int(np.sum(diffs <= 1e-6)),
        same_steps=sum(
            a["steps"] == b["steps"] for a, b in zip(ref["sweep"], now["sweep"], strict=True)
        ),
        statuses=sorted({r["status"] for r in now["sweep"]}),
        rows_over_1e6=[(i, float(d)) for i, d in enumerate(diffs) if d > 1e-6][:8],
    )  # fmt: skip
    return out


def whole_sweep(loop: str, b: int, n: int) -> dict:
    import msfd_jax as m

    settings = _sweep_settings(loop)
    tick = time.perf_counter()
    table = m.sweep(grid(n), m.Mesh(), settings, chunk_size=b, workers=1, progress=False)
    wall = time.perf_counter() - tick
    t = dict(table.timing)
    steps = int(np.sum(table["steps"]))  # Verlet steps of every collision's reported attempt
    return dict(
        loop=loop, slots=b, n=len(table), wall_s=wall, timing=t, steps=steps,
        collisions_per_s=len(table) / t["run_s"], us_per_collision_step=1e6 * t["run_s"] / steps,
        statuses={s: int(np.sum(table["status"] == s)) for s in set(map(str, table["status"]))},
    )  # fmt: skip


def device_lines() -> list[str]:
    try:
        smi = subprocess.run(
            ["nvidia-smi", "--query-gpu=name,driver_version,memory.total,clocks.max.sm",
             "--format=csv,noheader"], capture_output=True, text=True, timeout=30,
        ).stdout.strip()  # fmt: skip
    except (OSError, subprocess.SubprocessError):
        smi = ""
    return [smi] if smi else []


def report(args, head, state) -> None:
    lines = [*head]
    scan = state.get("scan", [])
    if scan:
        lines += [
            "## Segment cost against slots and contact loop (scan)",
            "",
            "One segment of the sweep's program (64 diffrax steps x 8 Verlet substeps), median "
            f"of {args.segments}, after {SEGMENTS_IN} segments into contact; compile: the "
            "critical steps, the start and the segment program.",
            "",
            "| loop | slots B | running | compile s | segment ms | µs / step (all slots) "
            "| µs / collision-step | collision-steps / s |",
            "|---|---:|---:|---:|---:|---:|---:|---:|",
        ]
        for r in scan:
            lines.append(
                f"| {r['loop']} | {r['slots']} | {r['running']} | {r['compile_s']:.1f} "
                f"| {1e3 * float(np.median(r['segment_s'])):.1f} | {r['us_per_step']:.1f} "
                f"| {r['us_per_collision_step']:.4f} | {1e6 / r['us_per_collision_step']:.3g} |"
            )
        lines.append("")
    if "check" in state:
        c = state["check"]
        w, ref = c["sweep"], c["reference"]
        lines += [
            "## The same numbers as the CPU (check)",
            "",
            f"Against benchmarks/results/gpu_reference.json (the CPU, {ref['cpu']}, jax "
            f"{ref['jax']}, {ref['date']}; first attempts).",
            "",
        ]
        for name in CHECK_SINGLES:
            s = c[name]
            lines.append(
                f"- {name} (`msfd_jax.run`): steps {s['steps'][1]} here against "
                f"{s['steps'][0]} on the CPU; largest |fraction difference| "
                f"{s['max_fraction_diff']:.2e} K0; {s['status']}; first call (compile "
                f"included) {c[name + '_first_s']:.1f} s."
            )
        lines += [
            f"- The showcase again, warm: {c['showcase_warm_s']:.2f} s.",
            f"- regression_baseline.py's 64-collision sweep (contact loop {w['loop']}): "
            f"|fraction difference| median {w['median_fraction_diff']:.1e}, largest "
            f"{w['max_fraction_diff']:.1e} K0; {w['within_1e9']} rows within 1e-9 K0, "
            f"{w['within_1e6']} within 1e-6; {w['same_steps']} of {w['rows']} with the same "
            f"steps; rows over 1e-6: {w['rows_over_1e6']}; statuses {w['statuses']}; "
            f"{c['sweep_s']:.1f} s with compilation "
            f"({c['sweep_timing'].get('compile_s', float('nan')):.1f} s of it).",
            "",
        ]
    sweeps = state.get("sweeps", [])
    if sweeps:
        lines += [
            "## Whole sweeps (collisions/s)",
            "",
            "`msfd_jax.sweep` with the default settings but the contact loop, one worker, "
            "slots refilled from the queue; run time without compilation.",
            "",
            "| loop | slots B | collisions | compile s | run s | collisions / s "
            "| µs / collision-step | statuses |",
            "|---|---:|---:|---:|---:|---:|---:|---|",
        ]
        for r in sweeps:
            t = r["timing"]
            lines.append(
                f"| {r['loop']} | {r['slots']} | {r['n']} | {t['compile_s']:.1f} "
                f"| {t['run_s']:.1f} | {r['collisions_per_s']:.1f} "
                f"| {r['us_per_collision_step']:.4f} | {r['statuses']} |"
            )
        lines.append("")
    if scan:
        best = min(scan, key=lambda r: r["us_per_collision_step"])
        lines.append(
            f"Best batch in the scan: B = {best['slots']} with the {best['loop']} loop "
            f"({best['us_per_collision_step']:.4f} µs per collision-step)."
        )
        lines.append("")
    if state.get("skipped") or state.get("errors"):
        lines += ["## Not done", ""]
        lines += [f"- skipped: {s}" for s in state.get("skipped", [])]
        lines += [f"- failed: {e}" for e in state.get("errors", [])]
        lines.append("")
    args.out.write_text("\n".join(lines))
    args.out.with_suffix(".json").write_text(json.dumps(state, indent=1, default=str) + "\n")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--platform", default="gpu", choices=["gpu", "cpu"])
    parser.add_argument("--loops", nargs="+", default=["blocks", "dense"])
    parser.add_argument(
        "--slots", nargs="+", type=int, default=[8192, 65536, 1024],
        help="slot counts in order: every loop at the first, the fastest at the others",
    )  # fmt: skip
    parser.add_argument("--segments", type=int, default=5, help="timed segments per point")
    parser.add_argument(
        "--sweep-n", nargs="*", type=int, default=None, help="collisions per whole sweep"
    )  # default: the best B and 4 B (slots refilled)
    parser.add_argument("--sweep-slots", type=int, default=None)
    parser.add_argument(
        "--stages", nargs="+", default=["scan", "check", "sweep"],
        help="scan, check, sweep; reference (on the CPU: the check's reference file)",
    )  # fmt: skip
    parser.add_argument("--budget-s", type=float, default=420.0)
    parser.add_argument("--out", type=Path, default=None, help="default: gpu_latest.md")
    _bench.add_quick(parser)
    args = parser.parse_args()
    if args.out is None:
        args.out = _bench.results_dir(args.quick) / "gpu_latest.md"
    start = time.perf_counter()
    import jax

    if args.quick:
        try:
            args.platform = "gpu" if jax.devices("gpu") else "cpu"
        except RuntimeError:
            args.platform = "cpu"
        args.slots, args.segments, args.stages, args.loops = [16], 2, ["scan"], ["blocks"]
        args.budget_s = 60.0

    jax.config.update("jax_enable_x64", True)
    date = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")
    command = f"python benchmarks/gpu_throughput.py {' '.join(sys.argv[1:])}".strip()
    head = ["# The same code on a GPU (issue 11, goal 7)", "", f"`{command}` · {date}", ""]
    try:
        devices = jax.devices(args.platform)
    except RuntimeError:
        devices = []
    if not devices:
        text = (
            f"No {args.platform.upper()} here (jax's devices: {jax.devices()}): nothing "
            'measured. Install the CUDA extra (`pip install ".[cuda]"`) on a machine with an '
            "NVIDIA GPU and rerun."
        )
        print(text)
        args.out.write_text("\n".join([*head, text, ""]))
        return
    import diffrax
    import equinox

    d = devices[0]
    head += [
        f"Device: {d.device_kind} ({d.platform}); {', '.join(device_lines())}; jax "
        f"{jax.__version__}, diffrax {diffrax.__version__}, equinox {equinox.__version__}, "
        f"Python {sys.version.split()[0]}; float64; paper mesh, sharp laws.",
        "",
    ]
    state: dict = dict(date=date, command=command, device=str(d), skipped=[], errors=[])

    def left() -> float:
        return args.budget_s - (time.perf_counter() - start)

    def attempt(name, need, f, *a):
        if left() < need:
            state["skipped"].append(f"{name} (needs ~{need:.0f} s, {left():.0f} s left)")
            print(f"skip {name}: ~{need:.0f} s needed, {left():.0f} s left", flush=True)
            return None
        tick = time.perf_counter()
        try:
            out = f(*a)
        except Exception as e:  # a stage that fails on this device is reported, not fatal
            traceback.print_exc()
            state["errors"].append(f"{name}: {type(e).__name__}: {str(e)[:300]}")
            out = None
        print(f"{name}: {time.perf_counter() - tick:.1f} s -> {out}", flush=True)
        report(args, head, state)
        return out

    with jax.default_device(d):
        if "reference" in args.stages:
            attempt("reference", 0.0, write_reference)
        state["scan"] = []
        if "scan" in args.stages:
            # every loop at the first slot count, then the fastest loop so far at the others
            costs: dict = {}
            for i, b in enumerate(args.slots):
                fastest = min(
                    costs.values(), key=lambda r: r["us_per_collision_step"], default=None
                )
                for loop in args.loops if i == 0 else [fastest["loop"]]:
                    # a guess from the last point: compile again, run as the slots grow
                    last = costs.get(loop)
                    grow = 1.0 if last is None else max(1.0, b / last["slots"])
                    rounds = SEGMENTS_IN + args.segments
                    need = 30.0
                    if last is not None:
                        need = last["compile_s"] + grow * rounds * max(last["segment_s"])
                    r = attempt(f"scan {loop} B={b}", need, segment_cost, loop, b, args.segments)
                    if r is not None:
                        costs[loop] = r
                        state["scan"].append(r)
                        report(args, head, state)
                if not costs:
                    break
        scan = state["scan"]
        best = min(scan, key=lambda r: r["us_per_collision_step"]) if scan else None
        if "check" in args.stages:
            loop = None if best is None or best["loop"] == "blocks" else best["loop"]
            out = attempt("check", 90.0, check, loop)
            if out is not None:
                state["check"] = out
                report(args, head, state)
        state["sweeps"] = []
        if "sweep" in args.stages and (best is not None or args.sweep_slots):
            b = args.sweep_slots or best["slots"]
            loop = best["loop"] if best is not None else args.loops[0]
            for n in args.sweep_n if args.sweep_n is not None else [b, 4 * b]:
                per_step = best["us_per_collision_step"] if best else 0.1
                # ~24k Verlet steps a collision (every attempt) on this grid; the tail: the
                # longest chain of attempts, ~270k steps, at >= 70 us a step on the GPU
                need = 60.0 + 1.5 * (n * 24_000 * per_step * 1e-6 + 270_000 * 70e-6)
                r = attempt(f"sweep {loop} B={b} n={n}", need, whole_sweep, loop, b, n)
                if r is not None:
                    state["sweeps"].append(r)
                    report(args, head, state)
    report(args, head, state)
    print(args.out.read_text())


if __name__ == "__main__":
    main()
