"""Issue 11's goal 4: a new ``msfd run --json`` process with a warm compile cache (<= 2 s).

Runs the showcase once in a new process to fill a fresh cache, then `--repeats` more times,
and prints the whole process's wall time with the JSON's own split: the run (`wall_time_s`)
and the compilation or cache load (`compile_time_s`); the rest is Python start-up, imports,
tracing outside the compiled program and the scene's set-up.

    python benchmarks/startup.py [--repeats 3]      # writes benchmarks/results/startup.md
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

RESULTS = Path(__file__).resolve().parent / "results"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as cache:
        env = {**os.environ, "MSFD_CACHE_DIR": cache}
        cmd = [sys.executable, "-m", "msfd_jax.cli", "run", "--json"]
        for i in range(args.repeats + 1):
            tick = time.perf_counter()
            out = subprocess.run(cmd, capture_output=True, text=True, env=env, check=True)
            wall = time.perf_counter() - tick
            record = json.loads(out.stdout)
            rows.append((i == 0, wall, record["wall_time_s"], record["compile_time_s"]))
            kind = "cold" if i == 0 else "warm"
            run_s, load_s = record["wall_time_s"], record["compile_time_s"]
            print(f"{kind}: process {wall:.2f} s, run {run_s:.3f} s, compile/load {load_s:.2f} s")
    date = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")
    lines = [
        "# New-process `msfd run --json` (issue 11, goal 4: <= 2 s with a warm cache)",
        "",
        f"`python benchmarks/startup.py --repeats {args.repeats}` · {date}",
        "",
        "| cache | process s | run s | compile or cache load s |",
        "|---|---:|---:|---:|",
    ]
    lines += [f"| {'cold' if c else 'warm'} | {w:.2f} | {r:.3f} | {k:.2f} |" for c, w, r, k in rows]
    (RESULTS / "startup.md").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
