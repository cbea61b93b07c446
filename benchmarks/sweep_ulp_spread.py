"""How far one ulp moves the first rows of regression_baseline.py's 64-collision sweep on the
CPU, beside what the GPU moved them (issue 11, goal 7): is the GPU's difference rounding?

The rows of thin beams (h_b/h_r 0.25-1.5) with sharp contact are sensitive: the impact
velocity nudged by one ulp either way (``np.nextafter``) on the CPU, first attempts, against
the CPU's record of the same code (gpu_reference.json). The GPU's column is the check of
gpu_throughput.py on an H200 (gpu_scan_check.json; dense contact loop).

    python benchmarks/sweep_ulp_spread.py          # ~1 min; writes results/sweep_ulp_spread.md
"""

from __future__ import annotations

import ast
import itertools
import json
from pathlib import Path

import numpy as np

RESULTS = Path(__file__).resolve().parent / "results"
ROWS = 16


def main() -> None:
    import jax

    jax.config.update("jax_enable_x64", True)
    import msfd_jax as m
    from msfd_jax import _sweep
    from msfd_jax._attempts import first_attempts
    from msfd_jax.studies.scripts import regression_baseline as rb

    ref = json.loads((RESULTS / "gpu_reference.json").read_text())["sweep"]
    gpu = json.loads((RESULTS / "gpu_scan_check.json").read_text())["check"]["sweep"]
    gpu_rows = dict(ast.literal_eval(str(gpu["rows_over_1e6"]))) if gpu else {}
    rows = list(itertools.product(*rb.SWEEP_GRID.values()))[:ROWS]
    v = float(m.CollisionParams().velocity)
    moved = {}
    for name, vel in (("+1 ulp", np.nextafter(v, 2.0)), ("-1 ulp", np.nextafter(v, 0.0))):
        grid = [dict(thickness_ratio=t, axial_constraint=a, mass_ratio=g, velocity=float(vel))
                for t, a, g in rows]  # fmt: skip
        with first_attempts():
            table = m.sweep(grid, m.Mesh(), _sweep.SWEEP_SETTINGS, progress=False)
        moved[name] = [
            (max(abs(float(table[k][i]) - ref[i][k]) for k in rb.FRACTIONS),
             int(table["steps"][i]) - ref[i]["steps"])
            for i in range(ROWS)
        ]  # fmt: skip
    lines = [
        "# One ulp of velocity against the GPU's difference (regression sweep, first rows)",
        "",
        "`python benchmarks/sweep_ulp_spread.py` · largest |fraction difference| in K0 from "
        "the CPU's own record (gpu_reference.json), and the change of steps; GPU: the H200 "
        "check (gpu_scan_check.md lists its first 8 rows over 1e-6 K0; '-' where not listed).",
        "",
        "| row | h_b/h_r | axial | g | +1 ulp (CPU) | steps | -1 ulp (CPU) | steps | GPU |",
        "|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for i, (t, a, g) in enumerate(rows):
        up, down = moved["+1 ulp"][i], moved["-1 ulp"][i]
        on_gpu = f"{gpu_rows[i]:.1e}" if i in gpu_rows else "-"
        lines.append(
            f"| {i} | {t:.3f} | {a:g} | {g:g} | {up[0]:.1e} | {up[1]:+d} | {down[0]:.1e} "
            f"| {down[1]:+d} | {on_gpu} |"
        )
    lines.append("")
    (RESULTS / "sweep_ulp_spread.md").write_text("\n".join(lines))
    print("\n".join(lines))


if __name__ == "__main__":
    main()
