"""Sweep throughput: collisions per second of `msfd_jax.sweep` by chunk size and mesh.

A 64-collision sweep (h_b/h_r from 0.25 to 5 in 16 steps x free/constrained x g = 5, 10; the
paper's v0 = 0.82, Fig. 10) runs on the paper's mesh (15, 20 + 5) and on the small test mesh
(6, 8 + 2) with chunk sizes 16, 32, 64 (the batched core rounds a chunk up to a power of
two from 16; the committed sweep.md is of 2026-12-01, before it, with chunks 1, 8, 32, 64).
Each configuration is compiled first on one chunk
(same `max_steps`, so the same program), then the whole sweep is timed: collisions/s exclude
compilation. ``--shard`` re-runs with each chunk split across all JAX devices; on CPU start it
as ``XLA_FLAGS=--xla_force_host_platform_device_count=2 python benchmarks/sweep_throughput.py
--shard --chunks 2 8 32 64`` to get two host devices (chunks must be a multiple of the device
count). Results are merged into ``benchmarks/results/sweep.json``
and rewritten as ``sweep.md``.

    python benchmarks/sweep_throughput.py                 # unsharded, both meshes
    python benchmarks/sweep_throughput.py --quick         # small mesh, chunk 16
    XLA_FLAGS=--xla_force_host_platform_device_count=2 \
        python benchmarks/sweep_throughput.py --shard --chunks 2 8 32 64   # two host devices
    python benchmarks/sweep_throughput.py --collapse      # the collapse contacts' cost

``--collapse`` times the same sweep three ways, side by side in one process (interleaved,
``--repeats`` each, the median kept): the paper's model (``Mesh(collapse_contacts=False)``),
the default (``None``: a row the paper's model leaves failed is solved again with the collapse
contacts) and the collapse contacts always on (``True``). Written to ``sweep.json``'s
``collapse_cost`` and a second table of ``sweep.md``.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import platform
import sys
import time
from pathlib import Path

import _bench
import equinox as eqx
import jax
import numpy as np

import msfd_jax as m

# the step bound a sweep derives from its collisions' stability limits (no public API): set
# beforehand, so that the one-chunk warm-up compiles the whole sweep's program
from msfd_jax._sweeps.sweep import sweep_step_bound

SWEEP_SETTINGS = _bench.sweep_settings()

# the paper's model: the throughput of the core itself (the small mesh has 4 rows that model
# leaves failed, which the default would solve again with the collapse contacts, compiling a
# program of their own inside the timed sweep); --collapse times the default against it
MESHES = {
    "paper": m.Mesh(collapse_contacts=False),
    "small": m.Mesh(6, 8, 2, collapse_contacts=False),
}
GRID = {
    "thickness_ratio": np.linspace(0.25, 5.0, 16),
    "axial_constraint": [0.0, 1.0],
    "mass_ratio": [5.0, 10.0],
}


def bounded_settings(mesh: m.Mesh) -> m.Settings:
    """SWEEP_SETTINGS with the step bound of the sweep, so a one-chunk warm-up compiles it."""
    rows = [m.CollisionParams(**row) for row in _bench.grid_rows(GRID)]
    critical_step = eqx.filter_jit(m.critical_step)  # compiled once per mesh
    dt_crit = np.asarray([float(critical_step(m.ring_on_beam(p, mesh))) for p in rows])
    bound = sweep_step_bound(dt_crit, SWEEP_SETTINGS)
    return dataclasses.replace(SWEEP_SETTINGS, max_steps=bound)


def measure(mesh_name: str, chunk: int, shard: bool, settings: m.Settings) -> dict:
    mesh = MESHES[mesh_name]
    first = _bench.grid_rows(GRID)[:chunk]
    tick = time.perf_counter()
    m.sweep(first, mesh, settings, chunk_size=chunk, progress=False, shard=shard)
    compile_and_first = time.perf_counter() - tick
    table = m.sweep(GRID, mesh, settings, chunk_size=chunk, progress=False, shard=shard)
    wall = table.wall_time_s
    record = dict(
        mesh=mesh_name,
        chunk_size=chunk,
        shard=shard,
        devices=jax.device_count() if shard else 1,
        collisions=len(table),
        wall_s=wall,
        collisions_per_s=len(table) / wall,
        first_chunk_with_compile_s=compile_and_first,
        failed=int(table.failed.sum()),
        status_counts={s: int(np.sum(table["status"] == s)) for s in np.unique(table["status"])},
        failed_rows=[
            {
                k: table[k][i].item()
                for k in ("thickness_ratio", "axial_constraint", "mass_ratio", "message")
            }
            for i in np.flatnonzero(table.failed)
        ],
        mean_steps=float(np.mean(table["steps"])),
        max_steps_bound=settings.max_steps,
        verlet_steps_per_s=float(np.sum(table["steps"]) / wall),
        load_average_1min=os.getloadavg()[0],  # other processes share the CPUs
    )
    print(json.dumps(record), flush=True)
    return record


COLLAPSE = {"off (paper's model)": False, "default (automatic)": None, "always on": True}


def collapse_cost(mesh_name: str, chunk: int, repeats: int) -> list[dict]:
    """The sweep's wall time with the collapse contacts off, automatic and on, interleaved."""
    base = MESHES[mesh_name]
    meshes = {k: dataclasses.replace(base, collapse_contacts=v) for k, v in COLLAPSE.items()}
    settings = {}
    for k, mesh in list(meshes.items()):
        try:
            settings[k] = bounded_settings(mesh)
        except ValueError as refused:  # "always on" where the mesh cannot hold them
            print(f"{mesh_name} mesh, collapse contacts {k}: refused ({refused})", flush=True)
            del meshes[k]
    first = _bench.grid_rows(GRID)[:chunk]
    compile_s, walls, tables = {}, {k: [] for k in meshes}, {}
    for k, mesh in meshes.items():  # each program compiled on one chunk first
        tick = time.perf_counter()
        m.sweep(first, mesh, settings[k], chunk_size=chunk, progress=False)
        compile_s[k] = time.perf_counter() - tick
    for _ in range(repeats):
        for k, mesh in meshes.items():
            table = m.sweep(GRID, mesh, settings[k], chunk_size=chunk, progress=False)
            walls[k].append(table.wall_time_s)
            tables[k] = table
    off = float(np.median(walls["off (paper's model)"]))
    off_table = tables["off (paper's model)"]
    records = []
    for k, table in tables.items():
        wall = float(np.median(walls[k]))
        both = ~np.asarray(off_table.failed) & ~np.asarray(table.failed)  # shares compared
        records.append(
            dict(
                mesh=mesh_name,
                chunk_size=chunk,
                collapse=k,
                walls_s=walls[k],
                wall_s=wall,
                ratio_to_off=wall / off,
                first_chunk_with_compile_s=compile_s[k],
                failed=int(table.failed.sum()),
                mean_steps=float(np.mean(table["steps"])),
                largest_share_difference=float(
                    max(
                        np.max(np.abs(table[c] - off_table[c])[both], initial=0.0)
                        for c in ("ring_bending", "beam_bending", "contact", "kinetic")
                    )
                ),
                solved_after_a_failure=int(
                    np.sum(np.asarray(off_table.failed) & ~np.asarray(table.failed))
                ),
                load_average_1min=os.getloadavg()[0],
            )
        )
        print(json.dumps(records[-1]), flush=True)
    return records


def write(records: list[dict], results: Path, collapse: list[dict] | None = None) -> None:
    path = results / "sweep.json"
    stored = json.loads(path.read_text()) if path.exists() else {}
    old = stored.get("runs", [])
    collapse = collapse or stored.get("collapse_cost", [])
    key = lambda r: (r["mesh"], r["chunk_size"], r["shard"], r["devices"])  # noqa: E731
    merged = {key(r): r for r in [*old, *records]}
    runs = sorted(merged.values(), key=key)
    here = dict(
        platform=platform.platform(),
        cpus=os.cpu_count(),
        jax=jax.__version__,
        backend=jax.default_backend(),
    )
    this = " ".join(["python benchmarks/sweep_throughput.py", *sys.argv[1:]])
    # each table keeps the machine and command that made it (a --collapse run adds no runs)
    if records:
        machine, command, cap = here, this, _t_max_text()
        collapse_meta = stored.get("collapse_meta")
    else:
        machine, command = stored.get("machine", here), stored.get("command", this)
        cap = stored.get("t_max", _t_max_text())
        collapse_meta = dict(machine=here, command=this)
    record = dict(command=command, machine=machine, grid=_grid_text(), t_max=cap, runs=runs)
    if collapse:
        record["collapse_cost"] = collapse
        record["collapse_meta"] = collapse_meta or dict(machine=here, command=this)
    path.write_text(json.dumps(record, indent=1))
    lines = [
        "# Sweep throughput",
        "",
        f"Written by `{command}` on {machine['platform']}, "
        f"{machine['cpus']} CPUs, jax {machine['jax']} ({machine['backend']}).",
        f"Sweep: {_grid_text()}; default sweep settings ({cap}, "
        f"settle rule, safety {float(SWEEP_SETTINGS.safety):g}).",
        "Collisions/s exclude compilation (each configuration is compiled on one chunk first).",
        "",
        "| mesh | chunk | devices | collisions/s | wall [s] | compile + first chunk [s] |"
        " mean steps | Verlet steps/s | failed |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in runs:
        lines.append(
            f"| {r['mesh']} | {r['chunk_size']} | {r['devices']}"
            f"{' (shard_map)' if r['shard'] else ''} | {r['collisions_per_s']:.3g} | "
            f"{r['wall_s']:.3g} | {r['first_chunk_with_compile_s']:.3g} | "
            f"{r['mean_steps']:.0f} | {r['verlet_steps_per_s']:.3g} | {r['failed']} |"
        )
    if collapse:
        lines += [
            "",
            "## The collapse contacts' cost (`--collapse`)",
            "",
            f"`{record['collapse_meta']['command']}` on "
            f"{record['collapse_meta']['machine']['platform']}, "
            f"{record['collapse_meta']['machine']['cpus']} CPUs.",
            "",
            "The same sweep with the collapse contacts off (the paper's model), automatic (the"
            " default: a row the paper's model leaves failed is solved again with them) and always"
            " on, interleaved in one process; wall: the median of the repeats; share difference:"
            " the largest difference of a ring/beam bending, contact or kinetic share from the"
            " paper's model, in K0, over the rows both solved; answered: rows the paper's model"
            " left failed that this variant solved.",
            "",
            "| mesh | chunk | collapse contacts | wall [s] (repeats) | ratio to off |"
            " compile + first chunk [s] | mean steps | failed | answered | share difference |",
            "|---|---|---|---|---|---|---|---|---|---|",
        ]
        for r in collapse:
            repeats = ", ".join(f"{w:.3g}" for w in r["walls_s"])
            lines.append(
                f"| {r['mesh']} | {r['chunk_size']} | {r['collapse']} | {r['wall_s']:.3g} "
                f"({repeats}) | {r['ratio_to_off']:.3f} | {r['first_chunk_with_compile_s']:.3g} |"
                f" {r['mean_steps']:.0f} | {r['failed']} | {r.get('solved_after_a_failure', '-')} |"
                f" {r['largest_share_difference']:.2g} |"
            )
    (results / "sweep.md").write_text("\n".join(lines) + "\n")


def _t_max_text() -> str:
    # the sweep's default is each collision's derived cap (t_max None, issue 12)
    t_max = SWEEP_SETTINGS.t_max
    return "t_max: each collision's derived cap" if t_max is None else f"t_max = {float(t_max):g}"


def _grid_text() -> str:
    return (
        "64 collisions: h_b/h_r = 0.25..5 (16 values) x axial constraint free/held x g = 5, 10;"
        " v0 = 0.82, E/Y = 500, R/h_r = 10, L_b = 3R"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--meshes", nargs="+", default=list(MESHES), choices=list(MESHES))
    parser.add_argument("--chunks", nargs="+", type=int, default=[16, 32, 64])
    parser.add_argument("--shard", action="store_true", help="split chunks across devices")
    parser.add_argument(
        "--collapse", action="store_true", help="the collapse contacts off / automatic / on"
    )
    parser.add_argument("--repeats", type=int, default=3, help="--collapse: sweeps per variant")
    _bench.add_quick(parser)
    args = parser.parse_args()
    if args.quick:
        args.meshes, args.chunks = ["small"], [16]
    results = _bench.results_dir(args.quick)
    if args.collapse:
        chunks = args.chunks if args.chunks != [16, 32, 64] else [32]
        cost = [
            r for name in args.meshes for c in chunks for r in collapse_cost(name, c, args.repeats)
        ]
        write([], results, cost)
        return
    records = []
    for mesh_name in args.meshes:
        settings = bounded_settings(MESHES[mesh_name])
        for chunk in args.chunks:
            records.append(measure(mesh_name, chunk, args.shard, settings))
            write(records, results)


if __name__ == "__main__":
    main()
