"""Compile time of the solver's programs with XLA:CPU's fusion emitters on (XLA's default) and
off (``XLA_FLAGS=--xla_cpu_use_fusion_emitters=false``, what the test suite runs with,
tests/conftest.py), side by side: the first call (compile and run) and a warm call of each
workload in a new process with no compile cache, alternating the two settings, and the
largest difference between their results. ``--suite`` also times two test files under each
setting (tests/conftest.py's ``MSFD_TEST_FUSION_EMITTERS=1`` keeps XLA's default).

Workloads (each its own program): the paper's showcase (`msfd_jax.run`, the paper's mesh); a
sweep of 8 collisions on Mesh(8, 10, 3) (`msfd_jax.sweep`, contact smoothed); the README's
reverse-mode design gradient (`optimise.gradient`, Mesh(8, 10, 3)). The first call of a new
process is what a user waits for; compile ~ first - warm where the warm call repeats the
first's work (a sweep's first call also overlaps compiling with running, so it is not split).

    python benchmarks/compile_time.py --repeats 2 --suite   # benchmarks/results/compile_time.md
    python benchmarks/compile_time.py --quick               # the showcase once, scratch folder

Pinned to one core (`_bench.pin`).
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import _bench

ROOT = Path(__file__).resolve().parent.parent
FLAG = "--xla_cpu_use_fusion_emitters=false"
CONFIGS = {"fusion emitters on (XLA's default)": "", "fusion emitters off": FLAG}
SUITE_FILES = ["tests/test_engine.py", "tests/test_regression.py"]

CHILD = r"""
import json, sys, time
import numpy as np
import msfd_jax as m

def timed(f):
    t = time.perf_counter(); out = f(); return out, time.perf_counter() - t

out = {}
def showcase():
    return np.asarray([m.run(m.CollisionParams()).fractions[k] for k in m.FRACTION_KEYS])

def sweep():
    mesh = m.Mesh(8, 10, 3)
    grid = {"thickness_ratio": [1.0, 2.0, 3.0, 4.0], "mass_ratio": [5.0, 10.0]}
    # contact smoothed (w = 1e-3 R, as tests/conftest.py's comparisons): the sharp contact of
    # a vmapped sweep amplifies one-ulp differences (1.8e-6 K0 here), hiding what is compared
    return np.asarray(m.sweep(grid, mesh, contact_smoothing=1e-3)["beam_bending"])

def gradient():
    import optimise as o
    mesh = m.Mesh(8, 10, 3)
    design = o.Design(thickness_ratio=2.5)
    box = o.default_box(design)
    problem = o.make_problem(m.CollisionParams(), mesh, m.Settings(t_max=4.0), box)
    goal = o.objective(o.TargetShare("beam", 0.45), o.ShareAtMost("ring", 0.55))
    return np.asarray([float(o.gradient(design, problem, goal, mode="reverse")[1].thickness_ratio)])

for name in sys.argv[1:]:
    f = {"showcase": showcase, "sweep": sweep, "gradient": gradient}[name]
    first, t_first = timed(f)
    warm, t_warm = timed(f)
    out[name] = {"first": t_first, "warm": t_warm, "values": warm.tolist()}
print(json.dumps(out))
"""


def child_env(flags: str, cache: str) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith("JAX_COMPILATION_CACHE")}
    env["XLA_FLAGS"] = f"{env.get('XLA_FLAGS', '')} {flags}".strip()
    env["MSFD_CACHE_DIR"] = cache  # a new, empty one per process: nothing is loaded
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")]).strip(os.pathsep)
    return env


def main() -> None:
    _bench.pin()
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=2, help="new processes per setting")
    parser.add_argument("--suite", action="store_true", help=f"also time {SUITE_FILES}")
    _bench.add_quick(parser)
    args = parser.parse_args()
    workloads = ["showcase"] if args.quick else ["showcase", "sweep", "gradient"]
    repeats = 1 if args.quick else args.repeats
    times = {c: {w: {"first": [], "warm": []} for w in workloads} for c in CONFIGS}
    values = {}
    for r in range(repeats):
        for config, flags in CONFIGS.items():
            with tempfile.TemporaryDirectory() as cache:
                proc = subprocess.run(
                    [sys.executable, "-c", CHILD, *workloads],
                    env=child_env(flags, cache),
                    cwd=cache,
                    capture_output=True,
                    text=True,
                    check=True,
                )
            record = json.loads(proc.stdout.strip().splitlines()[-1])
            for w in workloads:
                for k in ("first", "warm"):
                    times[config][w][k].append(record[w][k])
                values.setdefault(w, {})[config] = record[w]["values"]
            print(
                f"round {r + 1}, {config}: {json.dumps({w: record[w]['first'] for w in workloads})}"
            )
    suite = {}
    if args.suite and not args.quick:
        for config, keep in (
            ("fusion emitters on (XLA's default)", "1"),
            ("fusion emitters off", "0"),
        ):
            env = {**os.environ, "MSFD_TEST_FUSION_EMITTERS": keep, "CI": "true"}
            env.pop("MSFD_TEST_XLA_FLAGS_CHECKED", None)
            tick = time.perf_counter()
            cmd = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-n", "0"]
            done = subprocess.run([*cmd, *SUITE_FILES], cwd=ROOT, env=env, capture_output=True)
            suite[config] = (time.perf_counter() - tick, done.returncode)
            print(f"suite, {config}: {suite[config][0]:.0f} s, exit {done.returncode}")
    write(args, workloads, times, values, suite)


def _med(times, config, workload, key) -> float:
    return statistics.median(times[config][workload][key])


def write(args, workloads, times, values, suite) -> None:
    path = _bench.results_dir(args.quick) / "compile_time.md"
    date = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")
    import jax

    command = "python benchmarks/compile_time.py" + (
        " --quick" if args.quick else f" --repeats {args.repeats}" + (" --suite" if suite else "")
    )
    lines = [
        "# Compile time: XLA:CPU's fusion emitters on and off",
        "",
        f"`{command}` · {date} · jax {jax.__version__}, one core (`taskset`), load average "
        f"at the end {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores · each process new, "
        "no compile cache; medians over the processes; compile ~ first call - warm call.",
        "",
        "| workload | setting | first call [s] | warm call [s] | first call, off / on | "
        "compile [s] | compile, off / on |",
        "|---|---|---:|---:|---:|---:|---:|",
    ]
    on, off = CONFIGS
    for w in workloads:
        med = {
            c: {k: statistics.median(times[c][w][k]) for k in ("first", "warm")} for c in CONFIGS
        }
        compile_s = {c: med[c]["first"] - med[c]["warm"] for c in CONFIGS}
        split = all(v > 0 for v in compile_s.values()) and w != "sweep"
        for c in CONFIGS:
            first = f"{med[off]['first'] / med[on]['first']:.2f}" if c == off else ""
            ratio = f"{compile_s[off] / compile_s[on]:.2f}" if c == off and split else ""
            lines.append(
                f"| {w} | {c} | {med[c]['first']:.2f} | {med[c]['warm']:.3f} | {first} | "
                f"{f'{compile_s[c]:.2f}' if split else '-'} | {ratio} |"
            )
    slow = [
        c
        for c in CONFIGS
        if "sweep" in workloads
        and _med(times, c, "sweep", "warm") > _med(times, c, "sweep", "first")
    ]
    if slow:
        lines += [
            "",
            "The sweep's second call in the same process was slower than its first "
            f"({', '.join(slow)}): not explained here (the sweep's queue overlaps compiling "
            "with running on the first call); its row compares first calls only.",
        ]
    lines += ["", "| workload | largest difference of the results, off against on |", "|---|---:|"]
    for w in workloads:
        a, b = values[w][on], values[w][off]
        diff = max(abs(x - y) for x, y in zip(a, b, strict=True))
        scale = max(abs(x) for x in a)
        lines.append(f"| {w} | {diff:.1e} (values up to {scale:.3g}) |")
    if suite:
        lines += [
            "",
            f"Test files {', '.join(SUITE_FILES)} (`CI=true pytest -n 0`, one core):",
            "",
            "| setting | wall [s] | exit |",
            "|---|---:|---:|",
        ]
        lines += [f"| {c} | {w:.0f} | {rc} |" for c, (w, rc) in suite.items()]
    path.write_text("\n".join(lines) + "\n")
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
