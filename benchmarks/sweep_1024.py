"""Issue 11's goal 2: 1024 paper-mesh collisions with plain ``msfd sweep`` on this machine.

h_b/h_r 0.25-5 x 64, free/held, g = 5, 10, 20, 40, v0 = 0.6, 0.82: each configuration is run
twice as a new process (the first fills the persistent compile cache, the second is timed:
"compilation from the cache included"): plain ``msfd sweep`` (in process, one worker thread
per core by default), ``--workers 1`` (one core), and a LocalCluster of two worker processes
(``--cluster local:2``). Goal: <= 30 s wall for plain ``msfd sweep``.

    python benchmarks/sweep_1024.py            # writes benchmarks/results/sweep_1024.md
    python benchmarks/sweep_1024.py --only plain   # the goal's configuration alone
    python benchmarks/sweep_1024.py --only plain --against SRC --repeats 2
        # this tree against another (`git archive COMMIT | tar -x -C SRC`), side by side
    python benchmarks/sweep_1024.py --grid small ...   # 16 collisions instead (set-up cost)
    python benchmarks/sweep_1024.py --quick    # = --grid small --only plain, to a scratch folder

With ``--against`` each tree has its own cache; the cold processes run first (this tree, then
SRC), then the warm ones alternate, the order swapping each round, so a machine that is
slower today than yesterday shows in both columns alike.
"""

from __future__ import annotations

import argparse
import datetime
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import _bench

GRID = [
    "--thickness-ratio", "0.25:5:64", "--axial-constraint", "both",
    "--mass-ratio", "5,10,20,40", "--velocity", "0.6,0.82", "-q",
]  # fmt: skip
# `--grid small`: 16 collisions, where a new process's set-up (tracing or loading the
# queue's programs) weighs most
SMALL = ["--thickness-ratio", "0.5:4:8", "--axial-constraint", "both", "--mass-ratio", "10", "-q"]
CONFIGS = {
    "plain msfd sweep (worker threads, one per core)": [],
    "--workers 1 (one core)": ["--workers", "1"],
    "--cluster local:2": ["--cluster", "local:2"],
}
KEYS = dict(zip(("plain", "workers1", "cluster"), CONFIGS, strict=True))


def run(extra: list[str], cache: str, src: Path | None = None, grid=GRID) -> tuple[float, str]:
    cmd = [sys.executable, "-m", "msfd_jax.cli", "sweep", *grid, *extra]
    env = {**os.environ, "MSFD_CACHE_DIR": cache}
    if src is not None:  # another source tree first on the path, run from inside it
        extra_path = [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p]
        env["PYTHONPATH"] = os.pathsep.join([str(src), *extra_path])
    tick = time.perf_counter()
    out = subprocess.run(
        cmd, capture_output=True, text=True, env=env, check=False, cwd=src or tempfile.gettempdir()
    )
    wall = time.perf_counter() - tick
    last = [line for line in out.stdout.splitlines() if "collisions in" in line]
    return wall, (last[-1] if last else out.stderr[-300:])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", nargs="+", choices=list(KEYS), default=list(KEYS))
    parser.add_argument("--output", type=Path, default=None, help="default: sweep_1024.md")
    parser.add_argument("--against", type=Path, metavar="SRC", help="another source tree")
    parser.add_argument("--repeats", type=int, default=1, help="warm processes per tree")
    parser.add_argument(
        "--grid", choices=("goal2", "small"), default="goal2", help="goal 2's 1024 or 16"
    )
    _bench.add_quick(parser)
    args = parser.parse_args()
    if args.quick:
        args.grid, args.only = "small", ["plain"]
    if args.output is None:
        args.output = _bench.results_dir(args.quick) / "sweep_1024.md"
    grid = GRID if args.grid == "goal2" else SMALL
    trees = {"this tree": None}
    if args.against is not None:
        trees[f"against {args.against}"] = args.against.resolve()
    rows = []
    with tempfile.TemporaryDirectory() as cache:
        for key in args.only:
            name, extra = KEYS[key], CONFIGS[KEYS[key]]
            caches = {t: f"{cache}/{key}-{i}" for i, t in enumerate(trees)}
            cold = {t: run(extra, caches[t], src, grid)[0] for t, src in trees.items()}
            warm: dict[str, list[float]] = {t: [] for t in trees}
            summary = {}
            for r in range(args.repeats):
                for t in list(trees)[:: 1 if r % 2 == 0 else -1]:
                    wall, summary[t] = run(extra, caches[t], trees[t], grid)
                    warm[t].append(wall)
            for t in trees:
                label = name if len(trees) == 1 else f"{name}, {t}"
                times = ", ".join(f"{w:.1f}" for w in warm[t])
                rows.append((label, cold[t], times, summary[t]))
                print(f"{label}: cold {cold[t]:.1f} s, warm {times} s; {summary[t]}", flush=True)
    date = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")
    lines = [
        "# 1024 paper-mesh collisions with plain `msfd sweep` (issue 11, goal 2: <= 30 s)",
        "",
        f"`python benchmarks/sweep_1024.py {' '.join(sys.argv[1:])}` · {date} · "
        f"{os.cpu_count()} cores",
        "",
        f"Grid: `msfd sweep {' '.join(grid)}`",
        "",
        "| configuration | first process (compiles) s | next processes (cache) s | summary |",
        "|---|---:|---:|---|",
    ]
    lines += [f"| {n} | {c:.1f} | {w} | {s} |" for n, c, w, s in rows]
    args.output.write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
