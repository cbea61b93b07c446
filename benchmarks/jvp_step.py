"""Forward-mode cost of the Verlet step, against the step itself (issue 11, goal 5).

Goal 5 asks a forward-mode derivative for one design variable at no more than twice a forward
run. A whole run's jvp compiles for minutes (benchmarks/optimise_cost.py); this times its
core, side by side on one core: `--steps` substeps of the showcase collision (one collision,
h_b/h_r = 2.5, the smoothing `optimise` starts from: yield 0.05, contact 0.01) from half-way
through it, as a function of h_b/h_r (the scene is rebuilt from it, so the tangent enters
every stiffness, mass and yield value), and the `jax.jvp` of that function along h_b/h_r.
Both are timed with the joint angle's derivative as `_safe.atan2` defines it (the exact
derivative, a custom jvp) and as autodiff of its rational approximation (the former way),
so the table shows what the custom derivative saves.

    python benchmarks/jvp_step.py        # writes benchmarks/results/jvp_step.md

Re-executes itself under ``taskset -c 0`` when available (MSFD_BENCH_CORE picks the core).
"""

from __future__ import annotations

import argparse
import datetime
import os

import _bench


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=2000)
    parser.add_argument("--rounds", type=int, default=7)
    args = parser.parse_args()
    _bench.pin()
    import dataclasses

    import jax

    jax.config.update("jax_enable_x64", True)
    import jax.numpy as jnp
    import numpy as np

    import msfd_jax as m
    from msfd_jax import _engine, _queue, _safe, _sweep

    settings = dataclasses.replace(_sweep.SWEEP_SETTINGS, t_max=10.0)
    mesh = m.Mesh()
    dt, steps = _bench.showcase_steps(mesh)
    smoothing = _queue.with_flags((0.01, 0.05))
    base = m.CollisionParams().as_arrays()

    def start(thickness):
        fields = {f.name: jnp.atleast_1d(getattr(base, f.name)) for f in dataclasses.fields(base)}
        p = m.CollisionParams(**(fields | {"thickness_ratio": jnp.atleast_1d(thickness)}))
        return _queue._start(p, jnp.full(1, dt / 0.7), mesh, smoothing, settings, 1e7)

    h = jnp.full(1, dt)
    flat, clock, y = start(2.5)
    half = _bench.substep_loop(steps // 2, h, clock.tolerance)(flat, y)

    def run(thickness):
        flat, clock, _ = start(thickness)

        def body(i, s):
            return _engine.verlet_substep(flat, s, i * h, h, clock.tolerance)

        out = jax.lax.fori_loop(0, args.steps, body, half)
        return jnp.concatenate([out.bending[:, 0], out.axial[:, 0], out.contact[:, 0]])

    exact = _safe.atan2

    def approximation(y, x):  # the rational approximation, differentiated by autodiff
        return exact.fun(y, x)

    def with_atan2(fn, atan2):
        def f(*a):
            saved = _engine.atan2
            _engine.atan2 = atan2
            try:
                return fn(*a)
            finally:
                _engine.atan2 = saved

        return f

    t0 = jnp.asarray(2.5)
    programs = {}
    for name, atan2 in (
        ("exact derivative", exact),
        ("autodiff of the approximation", approximation),
    ):
        primal = jax.jit(with_atan2(run, atan2))
        tangent = jax.jit(with_atan2(lambda t: jax.jvp(run, (t,), (jnp.ones_like(t),)), atan2))
        programs[name, "run"] = (primal, t0)
        programs[name, "jvp"] = (tangent, t0)
    values = {k: f(*a) for k, (f, *a) in programs.items()}
    d_exact = values["exact derivative", "jvp"][1]
    d_auto = values["autodiff of the approximation", "jvp"][1]
    scale = float(jnp.max(jnp.abs(d_auto)))
    diff = float(jnp.max(jnp.abs(d_exact - d_auto))) / scale
    best = _bench.interleaved_best(programs, args.rounds)
    date = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")
    lines = [
        "# Forward mode through the Verlet step (issue 11, goal 5)",
        "",
        f"`python benchmarks/jvp_step.py` · {date} · core(s) {sorted(os.sched_getaffinity(0))} "
        f"· jax {jax.__version__} · the showcase collision (h_b/h_r = 2.5, yield smoothing "
        f"0.05, contact 0.01), {args.steps} substeps from half-way, as a function of h_b/h_r "
        f"(scene rebuilt from it); best of {args.rounds} interleaved rounds",
        "",
        "| joint angle's derivative | run [ms] | jvp [ms] | jvp / run | fusions in the loop "
        "body: run, jvp |",
        "|---|---:|---:|---:|---|",
    ]
    for name in ("exact derivative", "autodiff of the approximation"):
        run_s, jvp_s = best[name, "run"], best[name, "jvp"]
        counts = [_bench.loop_body_fusions(*programs[name, k]) for k in ("run", "jvp")]
        kernels = ", ".join(map(str, counts))
        lines.append(
            f"| {name} | {1e3 * run_s:.1f} | {1e3 * jvp_s:.1f} | {jvp_s / run_s:.2f} | {kernels} |"
        )
    lines += [
        "",
        f"The two derivatives of the dissipation per spring after {args.steps} substeps differ "
        f"by {diff:.1e} of their largest ({np.float64(scale):.3g} M_pr per unit h_b/h_r).",
        "",
        "Fusions: the kernels XLA:CPU runs per substep (the compiled while body's fusion "
        "instructions). At a batch of one a substep costs about a fixed time per kernel, so the "
        "jvp's cost follows its kernel count and their size, not its arithmetic alone.",
    ]
    _bench.write_result("jvp_step.md", lines)


if __name__ == "__main__":
    main()
