"""Mesh refinement: which outputs of the MS-FD model are converged, which are mesh-dependent.

Three collisions (g = 10, v0 = 0.82): the showcase (h_b/h_r = 2.5, constrained), a thin free
beam (0.5, free) and a thick constrained beam (4.0), each on the paper's mesh refined x1, x2,
x4 (every segment count multiplied; the step follows the computed stability limit).
Writes docs/results/convergence.md.

    python -m msfd_jax.studies.scripts.convergence            # x1, x2, x4 (several minutes)
    python -m msfd_jax.studies.scripts.convergence --factors 1 2
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

import msfd_jax as m

ROOT = Path(__file__).resolve().parents[3]
CASES = {
    "showcase (2.5, constrained)": m.CollisionParams(),
    "thin free beam (0.5, free)": m.CollisionParams(thickness_ratio=0.5, axial_constraint=0.0),
    "thick beam (4.0, constrained)": m.CollisionParams(thickness_ratio=4.0),
}
KEYS = ("beam_bending", "beam_axial", "ring_bending", "ring_axial", "contact")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--factors", type=int, nargs="+", default=[1, 2, 4])
    args = parser.parse_args(argv)
    settings = m.Settings(history_points=11, shape_times=())
    lines = [
        "# Mesh convergence of the energy partition",
        "",
        "Produced by `python -m msfd_jax.studies.scripts.convergence` "
        f"({time.strftime('%Y-%m-%d')}, 2-core "
        "CPU). Dissipated fractions of K0 and their change from the finest mesh; the "
        "kinetic/elastic split at the stop is a vibration phase and is not compared.",
        "",
    ]
    for name, params in CASES.items():
        rows = []
        for factor in args.factors:
            mesh = m.Mesh().refined(factor)
            start = time.perf_counter()
            c = m.run(params, mesh, settings)
            wall = time.perf_counter() - start
            f = c.fractions
            rows.append((factor, [f[k] for k in KEYS], c, wall))
            print(name, factor, [round(f[k], 4) for k in KEYS], flush=True)
        finest = np.array(rows[-1][1])
        lines += [
            f"## {name}",
            "",
            "| mesh | " + " | ".join(KEYS) + " | max change vs finest | tau end | steps | wall s |",
            "|---|" + "---|" * (len(KEYS) + 4),
        ]
        for factor, values, c, wall in rows:
            change = np.max(np.abs(np.array(values) - finest))
            lines.append(
                f"| x{factor} | "
                + " | ".join(f"{v:.4f}" for v in values)
                + f" | {change:.2e} | {float(c.solution.t_end):.2f} | {int(c.solution.steps)}"
                f" | {wall:.1f} |"
            )
        lines.append("")
    text = "\n".join(lines)
    (ROOT / "docs" / "results" / "convergence.md").write_text(text + "\n")
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
