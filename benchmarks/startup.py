"""Issue 11's goal 4: a new ``msfd run --json`` process with a warm compile cache (<= 2 s).

Runs the showcase once in a new process to fill a fresh cache (compiled programs and the
serialized programs of `msfd_jax._runtime.export`), then `--repeats` more times, and prints each
process's wall time, its CPU time (user + system: what the wall time is on an idle core, and
what stays comparable when other work shares the core), and the JSON's own split: the run
(`wall_time_s`) and the compilation or cache load (`compile_time_s`); the rest is Python
start-up, imports and the scene's set-up. It also times the floor: new processes that only
``import jax`` (and run one op), and that ``import msfd_jax``.

Child processes run without ``PYTHONDONTWRITEBYTECODE`` (as an installed package, whose
byte code pip writes): otherwise every process recompiles the package's sources.

    python benchmarks/startup.py [--repeats 3] [--against SRC]   # benchmarks/results/startup.md
    python benchmarks/startup.py --quick      # one warm process, to a scratch folder
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import _bench

FLOOR = {
    "python -c pass": "pass",
    "import jax; one op": "import jax; jax.numpy.zeros(1).block_until_ready()",
    "import msfd_jax": "import msfd_jax",
}


def timed(cmd: list[str], env: dict[str, str]) -> tuple[float, float, str]:
    """(wall s, CPU s of the child: user + system, stdout) of one new process.

    The child runs in its cache directory: ``python -m``/``-c`` put the working directory
    first on sys.path, and in the repository that would import this tree whatever
    PYTHONPATH says.
    """
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    tick = time.perf_counter()
    cwd = env["MSFD_CACHE_DIR"]
    os.makedirs(cwd, exist_ok=True)
    out = subprocess.run(cmd, capture_output=True, text=True, env=env, check=True, cwd=cwd)
    wall = time.perf_counter() - tick
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime
    return wall, cpu, out.stdout


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--output", type=Path, default=None, help="default: startup.md")
    parser.add_argument(
        "--against",
        type=Path,
        metavar="SRC",
        help="another source tree (e.g. `git archive COMMIT | tar -x -C SRC`): its warm "
        "runs alternate with this tree's, each with its own cache (a fair before/after)",
    )
    _bench.add_quick(parser)
    args = parser.parse_args()
    if args.quick:
        args.repeats = 1
    if args.output is None:
        args.output = _bench.results_dir(args.quick) / "startup.md"
    base = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    trees = {"this tree": Path(__file__).resolve().parent.parent}
    if args.against is not None:
        trees[f"against {args.against}"] = args.against.resolve()
    # the environment's PYTHONPATH comes after the tree's (e.g. other package versions)
    extra = [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p]
    rows, floor = [], []
    cmd = [sys.executable, "-m", "msfd_jax.cli", "run", "--json"]
    with tempfile.TemporaryDirectory() as cache:
        envs = {
            name: {
                **base,
                "PYTHONPATH": os.pathsep.join([str(src), *extra]),
                "MSFD_CACHE_DIR": f"{cache}/{i}",
            }  # fmt: skip
            for i, (name, src) in enumerate(trees.items())
        }
        for i in range(args.repeats + 1):  # the first is cold: it fills the cache
            for name, env in envs.items():
                wall, cpu, stdout = timed(cmd, env)
                record = json.loads(stdout)
                run_s, load_s = record["wall_time_s"], record["compile_time_s"]
                kind = "cold" if i == 0 else "warm"
                rows.append((name, kind, wall, cpu, run_s, load_s, record["steps"]))
                print(
                    f"{name}, {kind}: process {wall:.2f} s (CPU {cpu:.2f} s), run {run_s:.3f} s,"
                    f" compile/load {load_s:.2f} s, steps {record['steps']}"
                )
    env = envs["this tree"]
    for name, code in FLOOR.items():
        times = [timed([sys.executable, "-c", code], env)[:2] for _ in range(args.repeats)]
        wall, cpu = min(t[0] for t in times), min(t[1] for t in times)
        floor.append((name, wall, cpu))
        print(f"floor, {name}: process {wall:.2f} s (CPU {cpu:.2f} s), best of {args.repeats}")
    write(args, rows, floor)


def write(args: argparse.Namespace, rows: list, floor: list) -> None:
    date = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")
    load = os.getloadavg()[0]
    against = "" if args.against is None else f" --against {args.against}"
    against += " --quick" if args.quick else ""
    lines = [
        "# New-process `msfd run --json` (issue 11, goal 4: <= 2 s with a warm cache)",
        "",
        f"`python benchmarks/startup.py --repeats {args.repeats}{against}` · {date} · load "
        f"average at the end {load:.1f} on {os.cpu_count()} cores (CPU s = wall s on an "
        "idle core)",
        "",
        "| source | cache | process wall s | process CPU s | run s | compile or load s | steps |",
        "|---|---|---:|---:|---:|---:|---:|",
    ]
    lines += [
        f"| {n} | {k} | {w:.2f} | {u:.2f} | {r:.3f} | {c:.2f} | {s} |"
        for n, k, w, u, r, c, s in rows
    ]
    lines += [
        "",
        "| source | warm processes | median wall s | median CPU s |",
        "|---|---:|---:|---:|",
    ]
    for name in dict.fromkeys(r[0] for r in rows):
        warm = [r for r in rows if r[0] == name and r[1] == "warm"]
        wall = statistics.median(r[2] for r in warm)
        cpu = statistics.median(r[3] for r in warm)
        lines.append(f"| {name} | {len(warm)} | {wall:.2f} | {cpu:.2f} |")
    lines += ["", "| floor (new process, best of the repeats) | wall s | CPU s |"]
    lines += ["|---|---:|---:|"]
    lines += [f"| {name} | {w:.2f} | {u:.2f} |" for name, w, u in floor]
    args.output.write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
