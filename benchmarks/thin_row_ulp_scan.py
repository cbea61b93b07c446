"""How far rounding moves the thinnest free beam of the regression sweep (h_b/h_r 0.25,
free, g = 5): the impact velocity moved 1 to 8 ulps up and down, first attempts, on the CPU.
Prints each run's steps and beam bending fraction (the unmoved velocity first).

Why: `regression_baseline --check` judged this row's step change (6464 steps from the old
core's record) against its one-ulp spread (24 and 96 steps) and failed it; eight ulps either
way spread its steps over 29 192 - 58 200, so two samples had underestimated the spread.

    python benchmarks/thin_row_ulp_scan.py    # ~1.5 min
"""

from __future__ import annotations

import numpy as np


def main() -> None:
    import jax

    jax.config.update("jax_enable_x64", True)
    import msfd_jax as m
    from msfd_jax._attempts import first_attempts

    v = float(m.CollisionParams().velocity)
    vels = [v]
    for toward in (2.0, 0.0):
        u = v
        for _ in range(8):
            u = float(np.nextafter(u, toward))
            vels.append(u)
    row = dict(thickness_ratio=0.25, axial_constraint=0.0, mass_ratio=5.0)
    with first_attempts():
        t = m.sweep([row | {"velocity": u} for u in vels], m.Mesh(), progress=False)
    print("steps:", [int(s) for s in t["steps"]])
    print("beam_bending:", [round(float(b), 5) for b in t["beam_bending"]])


if __name__ == "__main__":
    main()
