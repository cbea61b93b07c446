"""Where does msfd_jax's time step go? Microseconds per step of variants of the same step.

All variants run a fixed number of steps of the showcase scene (no early stop), one core
(re-executed under ``taskset -c 0``), median of `--repeats` calls after a warm-up:

- ``scan``: ``lax.scan`` of ``msfd_jax._dynamics.verlet_step`` alone (state carry only);
  ``scan unroll=k``; ``scan, scene as constants`` (scene closed over, XLA folds it);
- ``scan, no contact``: the same scene without its contact set (the contact's share);
- ``respond``: the force evaluation alone (return maps + VJP), with and without contact;
- diffrax: ``diffeqsolve`` with the msfd_jax solver, with/without the Event, with/without the
  SaveAt histories, for RecursiveCheckpointAdjoint (the default) and ForwardMode (plain
  while loop, no checkpoint buffers);
- ``simulate``: ``msfd_jax.simulate`` itself (stop_when_settled=False, t_max = steps * dt).

Also counts the HLO instructions/fusions of one step of the compiled scan body (per-step
kernel launches are what a small model pays on CPU).

    python benchmarks/profile_step.py                     # writes benchmarks/results/profile.json
    XLA_FLAGS=... python benchmarks/profile_step.py --tag flags   # same, with XLA flags
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import statistics
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "results"


def _pin_to_one_core():
    if os.environ.get("MSFD_BENCH_PINNED") or shutil.which("taskset") is None:
        return
    env = dict(os.environ, MSFD_BENCH_PINNED="1")
    os.execvpe("taskset", ["taskset", "-c", "0", sys.executable, *sys.argv], env)


def timed(fn, args, repeats):
    """(compile + first run, median, min) seconds of ``fn(*args)`` with block_until_ready."""
    import jax

    start = time.perf_counter()
    jax.block_until_ready(fn(*args))
    first = time.perf_counter() - start
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        jax.block_until_ready(fn(*args))
        times.append(time.perf_counter() - start)
    return first, statistics.median(times), min(times)


def scan_fn(unroll=1, constant_scene=None):
    import equinox as eqx
    import jax

    from msfd_jax._dynamics import verlet_step

    def run(scene, state, dt, tol, n):
        def body(carry, _):
            s, t = carry
            t1 = t + dt
            return (verlet_step(scene, s, t1, dt, tol), t1), None

        (state, t), _ = jax.lax.scan(body, (state, 0.0 * dt), None, length=n, unroll=unroll)
        return state

    if constant_scene is not None:

        @eqx.filter_jit
        def closed(state, dt, tol, n):
            return run(constant_scene, state, dt, tol, n)

        return closed
    return eqx.filter_jit(run)


def respond_fn():
    import equinox as eqx
    import jax

    from msfd_jax._dynamics import respond

    @eqx.filter_jit
    def run(scene, state, n):
        def body(carry, _):
            xs, rot, strain, sets = carry
            r = respond(scene, xs, rot, strain, sets)
            # feed the forces back (tiny) so the loop body cannot be hoisted
            xs = jax.tree_util.tree_map(lambda x, f: x + 1e-12 * f, xs, r.forces)
            return (xs, r.plastic_rotation, r.plastic_strain, r.permanent_set), None

        carry = (state.x, state.plastic_rotation, state.plastic_strain, state.permanent_set)
        return jax.lax.scan(body, carry, None, length=n)[0]

    return run


def diffrax_fn(event: bool, histories: bool, adjoint: str):
    import diffrax
    import equinox as eqx
    import jax.numpy as jnp

    import msfd_jax._simulate as sim
    from msfd_jax._dynamics import initial_state
    from msfd_jax._solver import VelocityVerlet, rate_form

    @eqx.filter_jit
    def run(scene, dt, tol, n):
        y0 = initial_state(scene)
        k0 = scene.initial_kinetic_energy
        t1 = n * dt

        def stop(t, y, args, **kwargs):
            err = sim._energy_error(scene, y, k0)
            broken = ~jnp.isfinite(err) | (jnp.abs(err) > 0.05)
            quiet = (t - y.last_dissipation > 1e9) & (t >= 0.2)
            return broken | quiet

        subs = [diffrax.SubSaveAt(t1=True)]
        if histories:
            ts = jnp.linspace(0.0, t1, 1001)
            subs = [
                diffrax.SubSaveAt(ts=ts, fn=sim._history),
                diffrax.SubSaveAt(ts=jnp.linspace(0.0, t1, 5), fn=sim._shapes),
                *subs,
            ]
        adj = (
            diffrax.ForwardMode() if adjoint == "forward" else diffrax.RecursiveCheckpointAdjoint()
        )
        sol = diffrax.diffeqsolve(
            diffrax.ODETerm(rate_form),
            VelocityVerlet(),
            t0=0.0,
            t1=t1,
            dt0=dt,
            y0=y0,
            args=(scene, tol),
            saveat=diffrax.SaveAt(subs=subs),
            stepsize_controller=diffrax.ConstantStepSize(),
            event=diffrax.Event(stop) if event else None,
            max_steps=n + 16,
            adjoint=adj,
            throw=False,
        )
        return sol.ys, sol.stats["num_steps"]

    return run


def hlo_counts(fn, *args):
    """Instruction and fusion counts of the compiled program (the while body dominates)."""
    text = fn.lower(*args).compile().compiled.as_text()
    return dict(
        instructions=len(re.findall(r"^\s+\S+ = ", text, flags=re.M)),
        fusions=len(re.findall(r"= \S+ fusion\(", text)),
        while_loops=len(re.findall(r" while\(", text)),
        custom_calls=len(re.findall(r"custom-call\(", text)),
        gathers=len(re.findall(r" gather\(", text)),
        scatters=len(re.findall(r" scatter\(", text)),
        dynamic_update_slices=len(re.findall(r"dynamic-update-slice\(", text)),
    )


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=8192)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--tag", default="")
    parser.add_argument("--only", default="", help="comma-separated variant name prefixes")
    parser.add_argument("--no-pin", action="store_true")
    args = parser.parse_args()
    if not args.no_pin:
        _pin_to_one_core()

    import jax
    import jax.numpy as jnp

    import msfd_jax as m
    from msfd_jax._dynamics import initial_state
    from msfd_jax._simulate import step_size

    scene = m.ring_on_beam()
    bare = m.Scene(scene.chains, (), scene.initial_velocity)
    settings = m.Settings()
    dt, _ = step_size(scene, settings)
    n = args.steps
    tol = 1e-5 * scene.initial_kinetic_energy
    state, state_bare = initial_state(scene), initial_state(bare)

    variants = {
        "scan": (scan_fn(), (scene, state, dt, tol, n)),
        "scan unroll=4": (scan_fn(unroll=4), (scene, state, dt, tol, n)),
        "scan, scene as constants": (scan_fn(constant_scene=scene), (state, dt, tol, n)),
        "scan, no contact": (scan_fn(), (bare, state_bare, dt, tol, n)),
        "respond": (respond_fn(), (scene, state, n)),
        "respond, no contact": (respond_fn(), (bare, state_bare, n)),
    }
    for adjoint in ("checkpoint", "forward"):
        for event in (True, False):
            for hist in (True, False):
                name = (
                    f"diffrax {adjoint}, event {'on' if event else 'off'}, "
                    f"histories {'on' if hist else 'off'}"
                )
                variants[name] = (diffrax_fn(event, hist, adjoint), (scene, dt, tol, n))
    sim_settings = m.Settings(t_max=float(n * dt), stop_when_settled=False, max_steps=n + 16)
    variants["msfd_jax.simulate (checkpoint adjoint)"] = (
        lambda s: m.simulate(s, sim_settings),
        (scene,),
    )
    import diffrax

    variants["msfd_jax.simulate (ForwardMode adjoint)"] = (
        lambda s: m.simulate(s, sim_settings, adjoint=diffrax.ForwardMode()),
        (scene,),
    )
    # the showcase's own static bound: max_steps = 2^16 for t_max = 10 (vs n + 16 above)
    big = m.Settings(t_max=float(n * dt), stop_when_settled=False, max_steps=65536)
    variants["msfd_jax.simulate (checkpoint adjoint, max_steps 65536)"] = (
        lambda s: m.simulate(s, big),
        (scene,),
    )
    variants["msfd_jax.simulate (ForwardMode adjoint, max_steps 65536)"] = (
        lambda s: m.simulate(s, big, adjoint=diffrax.ForwardMode()),
        (scene,),
    )
    only = [p.strip() for p in args.only.split(",") if p.strip()]
    rows = []
    for name, (fn, fargs) in variants.items():
        if only and not any(name.startswith(p) for p in only):
            continue
        first, median, best = timed(fn, fargs, args.repeats)
        row = dict(
            variant=name,
            compile_s=first - median,
            median_s=median,
            us_per_step=1e6 * median / n,
            us_per_step_min=1e6 * best / n,
        )
        if hasattr(fn, "lower"):
            try:
                row["hlo"] = hlo_counts(fn, *fargs)
            except Exception as e:  # noqa: BLE001 - diagnostics only
                row["hlo"] = repr(e)
        rows.append(row)
        print(
            f"{name:60s} {row['us_per_step']:7.2f} us/step (min {row['us_per_step_min']:.2f}) "
            f"compile {row['compile_s']:.1f} s",
            flush=True,
        )
    # the scan program's HLO (its while body is one step): kernels a CPU launches per step
    step_hlo = hlo_counts(scan_fn(), scene, state, dt, tol, n)
    out = dict(
        command=" ".join(["python benchmarks/profile_step.py", *sys.argv[1:]]),
        steps=n,
        xla_flags=os.environ.get("XLA_FLAGS", ""),
        jax=jax.__version__,
        pinned=bool(os.environ.get("MSFD_BENCH_PINNED")),
        load_average=os.getloadavg(),
        one_step_hlo=step_hlo,
        rows=rows,
        contact_pairs=int(jnp.size(scene.contacts[0].stiffness)),
    )
    print("one step HLO:", step_hlo)
    RESULTS.mkdir(exist_ok=True)
    tag = f"_{args.tag}" if args.tag else ""
    (RESULTS / f"profile{tag}.json").write_text(json.dumps(out, indent=2) + "\n")
    print(f"wrote {RESULTS}/profile{tag}.json")


if __name__ == "__main__":
    main()
