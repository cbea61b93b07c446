"""Probe (one question, then removed from the tree): does a rerun at a halved step reuse the
first attempt's compiled program, and what does diffrax's larger loop bound cost a forward run?

    python benchmarks/retry_program.py

1. A small-mesh collision run three times (safety 0.7, 0.35, 0.175, as `run`'s two balance
   reruns), each attempt compiled as before (its own step bound = its own program) and as now
   (the first attempt's loop bound x `retry_headroom()`, reused), each way in a fresh process.
2. The paper's showcase run with loop bounds 1x and 4x its step bound: run times side by side.
"""

import subprocess
import sys
import time

import msfd_jax as m
from msfd_jax._collision import run as R
from msfd_jax._collision.attempts import retry_headroom, smaller_step
from msfd_jax._model.scene import ring_on_beam


def attempts(reuse: bool) -> None:
    mesh = m.Mesh(ring_segments=6, beam_contact_segments=8, beam_outer_segments=2)
    scene = ring_on_beam(m.CollisionParams(), mesh)
    settings = m.Settings(t_max=1.5, history_points=31, shape_times=(0.5,))
    start, loop, rows = time.perf_counter(), 0, []
    for attempt in range(3):
        headroom = retry_headroom() if reuse and attempt == 0 else 1
        sol, run_s, compile_s, bound = R._solve_timed(
            scene, settings, loop_steps=loop if reuse else 0, headroom=headroom
        )
        loop = bound if attempt == 0 else loop
        rows.append((round(compile_s, 2), int(sol.steps), float(sol.energy_balance_error)))
        settings = smaller_step(settings)
    print(f"{'reused' if reuse else 'own programs'}: {time.perf_counter() - start:.1f} s;", rows)


def loop_bound_cost() -> None:
    scene = ring_on_beam(m.CollisionParams(), m.Mesh())
    best = {}
    for headroom in (1, 4, 1, 4):
        for _ in range(4):
            sol, run_s, _, loop = R._solve_timed(scene, m.Settings(), headroom=headroom)
            best[headroom] = min(best.get(headroom, 1e9), run_s)
    print(
        f"showcase ({int(sol.steps)} steps): best run {best[1]:.4f} s at 1x, "
        f"{best[4]:.4f} s at 4x the step bound: ratio {best[4] / best[1]:.3f}"
    )


if __name__ == "__main__":
    if sys.argv[1:] == ["old"]:
        attempts(False)
    elif sys.argv[1:] == ["new"]:
        attempts(True)
    else:
        for mode in ("old", "new"):
            subprocess.run([sys.executable, __file__, mode], check=True)
        loop_bound_cost()
