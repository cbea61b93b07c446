"""Rerun the benchmarks and write docs/performance.md from their result files.

    python benchmarks/run_all.py                 # every benchmark in full (hours), then the page
    python benchmarks/run_all.py --quick         # every benchmark's --quick (~15 min)
    python benchmarks/run_all.py --only memory_maps startup --quick
    python benchmarks/run_all.py --page-only     # the page alone, from benchmarks/results/

A full run writes each benchmark's result file in benchmarks/results/ (the command that made
the committed one, `BENCHMARKS`) and then docs/performance.md. ``--quick`` runs each script's
``--quick`` form with ``MSFD_BENCH_RESULTS`` pointed at a scratch folder (`--results`), and
writes the page there too: quick figures never replace the committed ones. The GPU benchmark
runs only where JAX sees a GPU. The page states the date and machine of its writing; every
figure on it keeps the date and machine its result file records.
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime
import json
import os
import platform
import re
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
RESULTS = HERE / "results"
PAGE = ROOT / "docs" / "performance.md"


@dataclasses.dataclass(frozen=True)
class Bench:
    name: str  # the script, benchmarks/NAME.py
    measures: str
    result: str  # the result file in benchmarks/results/
    full: tuple[tuple[str, ...], ...] = ((),)  # the arguments of each full invocation
    gpu: bool = False  # runs only where JAX sees a GPU


BENCHMARKS = (
    Bench(
        "core_throughput",
        "cost per collision-step of a sweep (64 collisions) and one showcase run, against "
        "the numba reference of the same model, side by side on one core",
        "core.md",
        (("--slots", "16", "32", "--repeats", "2"),),
    ),
    Bench(
        "sweep_1024",
        "issue 11 goal 2: 1024 paper-mesh collisions with plain `msfd sweep` in a new "
        "process (compile cache warm), goal 30 s",
        "sweep_1024.md",
        (("--only", "plain", "--repeats", "2"),),
    ),
    Bench(
        "startup",
        "issue 11 goal 4: a new `msfd run --json` process with a warm cache, goal 2 s",
        "startup.md",
        (("--repeats", "3"),),
    ),
    Bench(
        "optimise_cost",
        "a design gradient's cost against a forward run (forward and reverse mode, batched)",
        "optimise.md",
        (("--lean",),),
    ),
    Bench(
        "cost_growth",
        "how a collision's cost grows with the mesh (x1, x2, x4), both contact loops",
        "cost_growth.md",
    ),
    Bench(
        "sweep_loops",
        "a whole sweep with each contact loop (blocks, listed) at the mesh x1, x2, x4",
        "sweep_loops.md",
        (
            ("--count", "192", "--factor", "1"),
            ("--count", "64", "--factor", "2"),
            ("--count", "64", "--factor", "4"),
        ),
    ),
    Bench(
        "sweep_throughput",
        "collisions/s of `sweep` by slot count and mesh (`--shard`: over two host devices, "
        "run apart with XLA_FLAGS, benchmarks/README.md); `--collapse`: the same sweep with "
        "the collapse contacts off, automatic (the default) and always on, side by side",
        "sweep.md",
        ((), ("--collapse",)),
    ),
    Bench(
        "cluster_throughput",
        "the same sweep in process and on Dask LocalClusters of 1 and 2 workers",
        "cluster.md",
    ),
    Bench(
        "reliability",
        "status counts and energy balance errors over 300 random designs",
        "reliability.md",
        (("--seeds", "3", "4", "5", "--n", "100"),),
    ),
    Bench(
        "memory_maps",
        "memory mappings XLA:CPU keeps per compiled program, against vm.max_map_count",
        "memory_maps.md",
    ),
    Bench(
        "smoothing_bias",
        "the bias of yield and contact smoothing on the energy partition",
        "smoothing_bias.md",
    ),
    Bench(
        "tuning_success",
        "success of `optimise.tune` from 4 starts to 5 targets, free and held beam",
        "tuning_success.md",
    ),
    Bench(
        "design",
        "graded-beam design (issue 30): the all-segment reverse gradient's cost and checks, "
        "against the best uniform beam and COBYLA, a finer-mesh recheck, a Pareto front, the "
        "cold start",
        "design.md",
        (("--pareto", "0.14", "0.16", "0.20", "--pareto-steps", "15"),),
    ),
    Bench(
        "design_mesh",
        "graded-beam design (issue 30) on the 2x mesh, rechecked on the 4x mesh; the mesh "
        "study of the design quantities; the cold start there",
        "design_mesh.md",
    ),
    Bench(
        "compile_time",
        "compile time of the solver's programs with XLA:CPU's fusion emitters on (default) "
        "and off (the test suite's setting), side by side, and two test files under each",
        "compile_time.md",
        (("--repeats", "2", "--suite"),),
    ),
    Bench(
        "gpu_throughput",
        "the same code on a GPU: agreement with the CPU, cost per collision-step against "
        "the slots, whole sweeps",
        "gpu.md",
        gpu=True,
    ),
)


def _has_gpu() -> bool:
    code = "import jax, sys; sys.exit(0 if jax.devices('gpu') else 1)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, check=False)
    return out.returncode == 0


def run(benches, quick: bool, results: Path) -> list[str]:
    """Run each benchmark (full or ``--quick``); returns a line per run for the log."""
    env = dict(os.environ, MSFD_BENCH_RESULTS=str(results))
    gpu = _has_gpu() if any(b.gpu for b in benches) else False
    log = []
    for b in benches:
        if b.gpu and not gpu and not quick:
            log.append(f"{b.name}: skipped (no GPU here)")
            print(log[-1], flush=True)
            continue
        for args in (("--quick",),) if quick else b.full:
            cmd = [sys.executable, str(HERE / f"{b.name}.py"), *args]
            print("$", " ".join(["python", f"benchmarks/{b.name}.py", *args]), flush=True)
            tick = time.perf_counter()
            code = subprocess.call(cmd, env=env, cwd=ROOT)
            wall = time.perf_counter() - tick
            log.append(f"{b.name} {' '.join(args)}: exit {code}, {wall:.0f} s")
            print(log[-1], flush=True)
    return log


# --- the page ---------------------------------------------------------------------------


def _first(pattern: str, text: str, default: str = "?") -> str:
    found = re.search(pattern, text, re.M)
    return found.group(1) if found else default


def _date(text: str, path: Path) -> str:
    """The date the result file records, else the date of its last commit (said so)."""
    found = _first(r"(20\d\d-\d\d-\d\d)", text, "")
    if found:
        return found
    out = subprocess.run(
        ["git", "log", "-1", "--format=%ad", "--date=short", "--", str(path)],
        capture_output=True, text=True, cwd=ROOT, check=False,
    )  # fmt: skip
    return f"{out.stdout.strip()} (commit)" if out.stdout.strip() else "not recorded"


def _command(text: str, bench: Bench) -> str:
    """The commands the result file records (each section's), else the full run's."""
    found = re.findall(r"`((?:python |taskset )[^`]*benchmarks/[^`]*\.py[^`]*)`", text)
    found = list(dict.fromkeys(c for c in found if f"benchmarks/{bench.name}.py" in c))
    if not found:
        found = [" ".join(["python", f"benchmarks/{bench.name}.py", *a]) for a in bench.full]
    return "; ".join(f"`{c.strip()}`" for c in found)


def _rows(text: str, first_cell: str) -> list[list[str]]:
    """The cells of every table row whose first cell starts with `first_cell`."""
    rows = []
    for line in text.splitlines():
        if line.startswith("|") and line.strip("| ").startswith(first_cell):
            rows.append([c.strip() for c in line.strip().strip("|").split("|")])
    return rows


def _core(text: str, results: Path) -> list[tuple[str, str, str]]:
    record = json.loads((results / "core.json").read_text())
    numba = record["numba_sweep"]["us_per_step"]
    sweep = ", ".join(
        f"{r['us_per_collision_step']:.2f} µs ({r['slots']} slots)" for r in record["jax_sweep"]
    )
    ratio = ", ".join(f"{r['numba_over_jax']:.2f}" for r in record["jax_sweep"])
    show = record["showcase"]
    jax_ms = show["jax"]["default settings"]["seconds"] * 1e3
    return [
        (
            "sweep of 64 paper-mesh collisions, per collision-step (every attempt's steps)",
            sweep,
            f"numba {numba:.2f} µs/step; numba / jax {ratio}",
        ),
        (
            f"one showcase collision ({show['steps']} steps), in process",
            f"{jax_ms:.1f} ms",
            f"numba {show['numba_s'] * 1e3:.1f} ms; numba / jax "
            f"{show['jax']['default settings']['numba_over_jax']:.2f}",
        ),
    ]


def _sweep_1024(text: str, results: Path) -> list[tuple[str, str, str]]:
    rows = _rows(text, "plain msfd sweep")
    if not rows:
        return []
    this, *other = rows
    peer = "goal 30 s"
    if other:
        tree = _first(r'"(/\S+)" = `git archive (\w+)`', text)
        commit = _first(r"`git archive (\w+)`", text)
        peer = f"the tree of {commit} ({tree}) side by side: {other[0][2]} s; goal 30 s"
    return [
        (
            "1024 paper-mesh collisions, new `msfd sweep` process, warm cache",
            f"{this[2]} s (first process, compiling: {this[1]} s)",
            peer,
        )
    ]


def _startup(text: str, results: Path) -> list[tuple[str, str, str]]:
    warm = [r for r in _rows(text, "this tree") if r[1] == "warm"]
    median = _rows(text, "this tree")
    floor = _rows(text, "import jax")
    if not warm:
        return []
    walls = [float(r[2]) for r in warm]
    med = [r for r in median if len(r) == 4]
    return [
        (
            "new `msfd run --json` process (showcase), warm cache",
            f"{min(walls):.2f}-{max(walls):.2f} s wall"
            + (f" (median CPU {med[0][3]} s)" if med else ""),
            (f"floor `import jax; one op` {floor[0][1]} s; " if floor else "") + "goal 2 s",
        )
    ]


def _optimise(text: str, results: Path) -> list[tuple[str, str, str]]:
    out = []
    forward = _rows(text, "forward run")
    jvp = _rows(text, "jvp gradient")
    reverse = _rows(text, "reverse gradient")
    batched = _first(r"Batched jvp / batched forward: ([\d.]+x)", text, "")
    if forward and jvp:
        out.append(
            (
                "forward-mode gradient, one design variable (h_b/h_r = 2.5, s = 0.05, w = 0.01)",
                f"{jvp[0][2]} s, {jvp[0][3]}x the forward run",
                f"forward run {forward[0][2]} s; issue 11 goal 5 asks 2x",
            )
        )
    if reverse:
        best = min(reverse, key=lambda r: float(r[3]))
        out.append(
            (
                "reverse-mode gradient (best checkpoint count)",
                f"{best[2]} s, {best[3]}x the forward run, {best[4].split('/')[0].strip()} MB",
                "forward run as above; goal 4x",
            )
        )
    if batched:
        out.append(("batched jvp, 8 designs in one pass", f"{batched} its batched forward", "-"))
    return out


def _cost_growth(text: str, results: Path) -> list[tuple[str, str, str]]:
    rows = {(r[0], r[4]): r for r in _rows(text, "x")}
    out = []
    for loop in ("listed", "blocks"):
        grown = [rows[k] for k in sorted(rows) if k[1] == loop]
        if grown:
            out.append(
                (
                    f"cost / (nodes x steps) over the mesh, contact loop {loop}",
                    " / ".join(f"{r[-1]} ({r[0]})" for r in grown),
                    "nodes x steps (1.00 = proportional)",
                )
            )
    return out


def _sweep_loops(text: str, results: Path) -> list[tuple[str, str, str]]:
    ratios = re.findall(
        r"^## Paper mesh (x\d+).*?blocks / listed: \*\*([\d.]+)\*\*", text, re.M | re.S
    )
    if not ratios:
        return []
    return [
        (
            "whole sweep, time with a conditional per block over the listed loop",
            ", ".join(f"{r} ({m})" for m, r in ratios),
            "the listed loop, same collisions, one core",
        )
    ]


def _sweep(text: str, results: Path) -> list[tuple[str, str, str]]:
    one = [r for r in _rows(text, "paper") if r[2] == "1"]
    two = [r for r in _rows(text, "paper") if r[2].startswith("2")]
    if not one:
        return []
    lines = [
        (
            "paper-mesh sweep of 64, collisions/s by chunk (compilation excluded)",
            ", ".join(f"{r[3]} (chunk {r[1]})" for r in one),
            "two host devices: " + ", ".join(f"{r[3]} (chunk {r[1]})" for r in two),
        )
    ]
    cost = json.loads((results / "sweep.json").read_text()).get("collapse_cost", [])
    paper = {r["collapse"]: r for r in cost if r["mesh"] == "paper"}
    if "off (paper's model)" in paper and "default (automatic)" in paper:
        auto, off = paper["default (automatic)"], paper["off (paper's model)"]
        on = paper.get("always on")
        lines.append(
            (
                "the same 64 (paper mesh), wall time with the collapse contacts automatic"
                " (the default) over off",
                f"{auto['ratio_to_off']:.3f} ({auto['wall_s']:.3g} s against {off['wall_s']:.3g}"
                f" s; {auto['solved_after_a_failure']} rows solved again)",
                "always on: "
                + (f"{on['ratio_to_off']:.3f}" if on else "-")
                + "; issue 31 asks <= 1.10",
            )
        )
    return lines


def _cluster(text: str, results: Path) -> list[tuple[str, str, str]]:
    rows = {r[0]: r for r in _rows(text, "") if len(r) == 8 and r[0] != "configuration"}
    two = rows.get("LocalCluster, 2 workers, 1 thread each")
    base = rows.get("in process")
    if not (two and base):
        return []
    return [
        (
            "sweep of 64 on a LocalCluster of 2 single-threaded workers, collisions/s",
            f"{two[4]} ({two[5]})",
            f"in process {base[4]}",
        )
    ]


def _reliability(text: str, results: Path) -> list[tuple[str, str, str]]:
    record = json.loads((results / "reliability.json").read_text())
    total = record["total"]
    status = ", ".join(f"{v} {k}" for k, v in total["status"].items())
    q = total["balance_quantiles"]
    return [
        (
            f"{total['rows']} random designs through `sweep` ({record['mesh']})",
            f"{status}; balance error of successes: median {q['0.5']:.1e}, max {q['1.0']:.1e} K0",
            f"{total['above_1e-4']} successes above 1e-4 K0, "
            f"{total['success_above_1e-4_unflagged']} of them without `balance_warning`",
        )
    ]


def _memory_maps(text: str, results: Path) -> list[tuple[str, str, str]]:
    run_maps = _first(r"\| \+ one `run` \(its programs compiled\) \| (\d+) \|", text)
    fit = _first(r"fit under the limit: about (\d+)", text)
    limit = _first(r"vm.max_map_count (\d+)", text)
    return [
        (
            "memory mappings per compiled collision program (XLA:CPU)",
            f"{run_maps} (about {fit} programs fit)",
            f"vm.max_map_count {limit}",
        )
    ]


def _smoothing(text: str, results: Path) -> list[tuple[str, str, str]]:
    levels = re.findall(r"^- s = ([\d.]+), w = ([\d.]+): ([\d.]+) K0", text, re.M)
    if not levels:
        return []
    return [
        (
            "largest absolute bias of a smoothed share (h_b/h_r 1, 2.5, 4)",
            "; ".join(f"{b} K0 at s = {s}, w = {w}" for s, w, b in levels[:3]),
            "the sharp model at the same design",
        )
    ]


def _tuning(text: str, results: Path) -> list[tuple[str, str, str]]:
    lines = re.findall(r"^- (.*?): (\d+/\d+) converged, (\d+/\d+) by", text, re.M)
    if not lines:
        return []
    return [
        (
            "`optimise.tune` to targets across the achievable range (coarse mesh)",
            "; ".join(
                f"{label} {c} converged ({g} by gradient steps alone)" for label, c, g in lines
            ),
            "-",
        )
    ]


def _design(text: str, results: Path) -> list[tuple[str, str, str]]:
    stored = _rows(text, "reverse gradient, all 25 segments (`_surrogate_grad`, every step")
    recomputing = _rows(text, "reverse gradient, all 25 segments, diffrax's default")
    gain = _first(r"the graded beam's deceleration is ([\d.]+) % lower", text)
    cold = _first(r"\| \*\*total\*\* \| \*\*([\d.]+)\*\* \|", text)
    out = []
    if stored:
        out.append(
            (
                "reverse gradient of 25 segment thicknesses (paper SI case, every step stored)",
                f"{stored[0][3]} s, {stored[0][5]}x the smoothed forward run it differentiates, "
                f"{stored[0][4]}x a sharp run",
                (f"recomputing checkpoints {recomputing[0][5]}x; " if recomputing else "")
                + "goal 8x",
            )
        )
    out.append(
        (
            "graded beam against the best uniform beam (10 ms deceleration, same limits)",
            f"{gain} % lower",
            "goal 15 %",
        )
    )
    sqp = _rows(text, "SLSQP (the default) |")
    dfo = _rows(text, "SLSQP (the default):")
    if sqp and dfo:
        out.append(
            (
                "the designer's problem at K = 10 by SLSQP, against COBYLA (forward-run "
                "equivalents to reach SLSQP's design)",
                f"{sqp[0][2].split()[0]} m/s^2 after {sqp[0][5].split(',')[-1].strip()} "
                f"forward-run equivalents (measured cost); COBYLA reaches it in {dfo[0][1]} runs",
                "goal: gradients 5x fewer",
            )
        )
    out.append(("the design example from a cold start", f"{cold} s", "goal 180 s"))
    return out


def _design_mesh(text: str, results: Path) -> list[tuple[str, str, str]]:
    gain = _first(r"The graded beam's deceleration is ([\d.]+) % below", text)
    kept = _first(r"2x finer mesh, step x 1: .*? the gain keeps (\d+) % of itself", text)
    coarse, fine = _rows(text, "x1 |"), _rows(text, "x4 |")
    cold = _first(r"\| \*\*total\*\* \| \*\*([\d.]+)\*\* \|", text)
    out = [
        (
            "graded beam designed on the 2x mesh against the best uniform beam there (10 ms "
            "deceleration, same limits)",
            f"{gain} % lower; rechecked on the 4x mesh, the gain keeps {kept} % of itself",
            "goals 15 % and 80 %",
        )
    ]
    if coarse and fine:
        best = [row[3].split(", ") for row in (coarse[0], fine[0])]
        out.append(
            (
                "the best uniform beam's 10 ms deceleration, the paper's mesh (x1) against x4",
                f"{best[0][2]} m/s^2 (h/h_r {best[0][0]}) against {best[1][2]} (h/h_r "
                f"{best[1][0]}); the paper-mesh design's gain on x4: {fine[0][4].split(', ')[-1]}",
                "the x4 mesh, same table",
            )
        )
    out.append(("the design on the 2x mesh from a cold start", f"{cold} s", "goal 180 s"))
    return out


def _compile_time(text: str, results: Path) -> list[tuple[str, str, str]]:
    out = []
    for row in _rows(text, "showcase") + _rows(text, "sweep") + _rows(text, "gradient"):
        if len(row) == 7 and row[4]:
            compiled = f"; compile {row[5]} s, {row[6]}x" if row[6] else ""
            out.append(
                (
                    f"new process's first call, {row[0]}, fusion emitters off",
                    f"{row[2]} s, {row[4]}x XLA's default{compiled}",
                    "the default in the same run",
                )
            )
    suite = {r[0]: r[1] for r in _rows(text, "fusion emitters") if len(r) == 3}
    if len(suite) == 2:
        on, off = suite.values()
        out.append(("two test files (one core), fusion emitters off", f"{off} s", f"on: {on} s"))
    return out


def _gpu(text: str, results: Path) -> list[tuple[str, str, str]]:
    best = _first(r"\| dense \| 65536 \| [\d.]+ \| \*\*([\d.]+)\*\*", text)
    sweep = _first(r"\*\*8192 collisions on 8192 slots: ([\d.]+) collisions/s\*\*", text)
    cpu = _first(r"One CPU core ran ([\d.]+) µs per collision-step", text)
    return [
        (
            "cost per collision-step on one H200, 65536 slots, dense contact loop",
            f"{best} µs",
            f"one CPU core {cpu} µs in a sweep's segment (another day and machine: not side "
            "by side)",
        ),
        ("a whole sweep of 8192 collisions on 8192 slots (H200)", f"{sweep} collisions/s", "-"),
    ]


HEADLINES: dict[str, Callable[[str, Path], list[tuple[str, str, str]]]] = {
    "core_throughput": _core,
    "sweep_1024": _sweep_1024,
    "startup": _startup,
    "optimise_cost": _optimise,
    "cost_growth": _cost_growth,
    "sweep_loops": _sweep_loops,
    "sweep_throughput": _sweep,
    "cluster_throughput": _cluster,
    "reliability": _reliability,
    "memory_maps": _memory_maps,
    "smoothing_bias": _smoothing,
    "tuning_success": _tuning,
    "design": _design,
    "design_mesh": _design_mesh,
    "compile_time": _compile_time,
    "gpu_throughput": _gpu,
}

MACHINE = (  # what a result file says of its machine
    r"(One NVIDIA \w+)",
    r"· (x86_64, pinned to core\(s\) \[[\d, ]+\])",
    r"on (Linux-\S+), (\d+ CPUs)",
    r"(vm \(x86_64, cpu\))",
    r"(x86_64, cpu, 2 cores shared with other users)",
    r"(x86_64, cpu, 1 of 2 cores \(taskset\))",
    r"(jax [\d.]+, one core \(`taskset`\))",
    r"· (core\(s\) \[[\d, ]+\])",
    r"on (\d+ cores)",
    r"· (\d+ cores)",
    r"jax [\d.]+, (x86_64)",
)


def _machine(text: str) -> str:
    for pattern in MACHINE:
        found = re.search(pattern, text)
        if found:
            return ", ".join(found.groups())
    return "not recorded in the file"


def this_machine() -> str:
    model = "unknown CPU"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return f"{platform.platform()}, {os.cpu_count()} CPUs ({model})"


def page(results: Path, quick: bool = False) -> str:
    """docs/performance.md from the result files in `results`."""
    now = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")
    head = [
        "# Performance",
        "",
        "<!-- Written by `python benchmarks/run_all.py`; edit the script, not this page. -->",
        "",
        "The current figures of the durable benchmarks ([benchmarks/README.md]"
        "(../benchmarks/README.md)), each read from its result file in `benchmarks/results/`"
        " with the command, date and machine that file records. This shared machine's speed "
        "has varied by up to 2x between days, so compare figures measured side by side (the "
        "peer column) rather than across dates. History: [CHANGELOG.md](../CHANGELOG.md).",
        "",
        f"Page written {now} on {this_machine()}"
        + (" from `--quick` results (not the committed ones)." if quick else "."),
        "",
        "| what | figure | peer, side by side | command | date | machine | result |",
        "|---|---|---|---|---|---|---|",
    ]
    sections = []
    for b in BENCHMARKS:
        path = results / b.result
        if not path.exists():
            sections.append(f"- `{b.name}`: no result file in {results}.")
            continue
        text = path.read_text()
        try:
            figures = HEADLINES[b.name](text, results)
        except (OSError, KeyError, ValueError, IndexError, json.JSONDecodeError) as exc:
            figures, note = [], f"figures not read ({type(exc).__name__}: {exc})"
            sections.append(f"- `{b.name}`: {note}; see `{b.result}`.")
        command = _command(text, b) if not b.gpu else f"the commands in `{b.result}`"
        link = f"[{b.result}](../benchmarks/results/{b.result})"
        for what, figure, peer in figures:
            head.append(
                f"| {what} | {figure} | {peer} | {command} | {_date(text, path)} | "
                f"{_machine(text)} | {link} |"
            )
    lines = head + [""]
    lines += [
        "## What each benchmark measures",
        "",
        "| script | measures | result |",
        "|---|---|---|",
    ]
    lines += [f"| `benchmarks/{b.name}.py` | {b.measures} | `{b.result}` |" for b in BENCHMARKS]
    if sections:
        lines += ["", "## Missing or unread", "", *sections]
    lines += ["", NOTES.strip(), ""]
    return "\n".join(lines)


NOTES = """
## Notes

- The sweep and cluster throughput figures (`sweep.md`, `cluster.md`) are of 2026-12-01,
  before the batched core of issue 11 (then a chunk of 1 or 8 collisions was its own
  program; the batched core rounds a chunk up to a power of two from 16). They are the last
  full runs of those benchmarks; `core.md` and `sweep_1024.md` measure the current core.
- Issue 11's targets (a third of numba's time per collision-step, 1024 collisions in 30 s,
  a jvp at 2x and a reverse gradient at 4x a forward run) are not met. Why a third of numba
  is out of reach for a pure-JAX core on XLA:CPU, and the other one-question probes behind
  the design, are in [CHANGELOG.md](../CHANGELOG.md) with the commit each probe last lived in.
- The GPU figures come from one H200 lent for 15 minutes (`gpu.md` summarises the raw results
  of that session, which git keeps at commit c8d5d64); `python benchmarks/gpu_throughput.py`
  on a GPU writes `gpu_latest.md`.
"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="each script's --quick form")
    parser.add_argument("--only", nargs="+", choices=[b.name for b in BENCHMARKS])
    parser.add_argument("--page-only", action="store_true", help="write the page, run nothing")
    parser.add_argument(
        "--results",
        type=Path,
        default=None,
        help="where results go (default: benchmarks/results/, --quick: a scratch folder)",
    )
    args = parser.parse_args()
    results = args.results or (
        Path(tempfile.gettempdir()) / "msfd-bench-quick" if args.quick else RESULTS
    )
    results.mkdir(parents=True, exist_ok=True)
    benches = [b for b in BENCHMARKS if not args.only or b.name in args.only]
    if not args.page_only:
        log = run(benches, args.quick, results)
        print("summary:", "; ".join(log))
    out = results / "performance.md" if args.quick or results != RESULTS else PAGE
    out.write_text(page(results, quick=args.quick))
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
