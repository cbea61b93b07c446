"""Issue 12 item 2: the stability catalogue's fast_impact (v0 = 5, g = 10, paper mesh) with
and without `Mesh.collapse_contacts`, default settings (safety 0.7). Writes
benchmarks/results/collapse.md. Run: python benchmarks/collapse_fast_impact.py
"""

import time
from pathlib import Path

import numpy as np

import msfd_jax as m

ROWS = []
for on in (False, True):
    start = time.perf_counter()
    c = m.run(m.CollisionParams(velocity=5.0, mass_ratio=10.0), m.Mesh(collapse_contacts=on),
              check=False)  # fmt: skip
    x = np.asarray(c.solution.final.x[0])
    behind = int(np.sum(x[:-1, 1] < x[-1, 1]))
    f = c.fractions
    ROWS.append(
        f"| {on} | {c.status} | {float(c.solution.t_end):.4g} | {c.energy_balance_error:+.2e} | "
        f"{c.safety:.2f} | {float(c.solution.dt):.3g} | {f['contact_collapse']:.3f} | "
        f"{behind} | {time.perf_counter() - start:.1f} |"
    )
    print(ROWS[-1], c.message, sep="\n")
text = (
    "# fast_impact with and without collapse contacts (issue 12)\n\n"
    "`python benchmarks/collapse_fast_impact.py`: v0 = 5, g = 10, paper mesh, safety 0.7.\n\n"
    "| collapse_contacts | status | tau end | energy error / K0 | dt/dt_crit | dt | "
    "contact_collapse / K0 | ring nodes behind the block face | wall s (incl. compile) |\n"
    "|---|---|---|---|---|---|---|---|---|\n" + "\n".join(ROWS) + "\n"
)
Path(__file__).with_name("results").joinpath("collapse.md").write_text(text)
