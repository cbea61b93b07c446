"""The dense contact loop on the CPU against the CPU's record of the blocks (issue 11 goal 7):
does the loop itself move the regression sweep, or only the GPU's rounding?

Runs gpu_throughput.py's check numbers (`computed`) with ``contact_loop="dense"`` on this
CPU and compares the 64-collision sweep with benchmarks/results/gpu_reference.json (blocks,
same code). Prints the largest and median |fraction difference| (K0), the rows within 1e-9
and 1e-6 K0 and the rows with the same steps.

    python benchmarks/dense_loop_cpu.py       # ~2 min
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))


def main() -> None:
    import jax

    jax.config.update("jax_enable_x64", True)
    import gpu_throughput as g

    from msfd_jax.studies.scripts import regression_baseline as rb

    ref = json.loads(g.REFERENCE.read_text())["sweep"]
    now = g.computed("dense")["sweep"]
    diffs = np.array([max(abs(a[k] - b[k]) for k in rb.FRACTIONS)
                      for a, b in zip(ref, now, strict=True)])  # fmt: skip
    same = sum(a["steps"] == b["steps"] for a, b in zip(ref, now, strict=True))
    print(json.dumps(dict(
        max=float(diffs.max()), median=float(np.median(diffs)),
        within_1e9=int((diffs <= 1e-9).sum()), within_1e6=int((diffs <= 1e-6).sum()),
        same_steps=same, rows=len(diffs),
    )))  # fmt: skip


if __name__ == "__main__":
    main()
