"""Where the energy balance of a successful run breaks (issue 12 item 1): the worst rows.

For each of the worst successful rows of a reliability record (benchmarks/reliability.py) the
design is rerun alone on the paper's mesh with histories, at the default step, at half and a
quarter of it, with the contact smoothed (w = 1e-3 R) and with the yield smoothed (1e-3):
the final error, how it scales with the step (ratio 2: first order, a kink such as the sharp
contact onset; 4: the smooth second order of Verlet; ~1: not the step), when it grows most (the
largest jump between history samples) and what happens then (contact force, pairs in contact,
the shortest ring bar). Writes ``benchmarks/results/balance_probe.md``.

    taskset -c 1 python benchmarks/balance_probe.py --record reliability_before --rows 6
"""

from __future__ import annotations

import argparse
import dataclasses
import json
from pathlib import Path

import numpy as np

import msfd_jax as m

RESULTS = Path(__file__).parent / "results"
INPUTS = tuple(f.name for f in dataclasses.fields(m.CollisionParams))
VARIANTS = {
    "default": ({}, {}),
    "safety/2": ({"safety": 0.35}, {}),
    "safety/4": ({"safety": 0.175}, {}),
    "contact w=1e-3": ({}, {"contact_smoothing": 1e-3}),
    "yield s=1e-3": ({}, {"yield_smoothing": 1e-3}),
}


def error_history(c: m.Collision) -> np.ndarray:
    h, k0 = c.solution.history, float(c.solution.k0)
    total = (
        h["kinetic"].sum(-1)
        + h["elastic"]
        + h["bending"].sum(-1)
        + h["axial"].sum(-1)
        + h["contact"].sum(-1)
    )
    return (np.asarray(total) - k0) / k0


def probe(design: dict, t_max: float) -> dict:
    params = m.CollisionParams(**{k: design[k] for k in INPUTS if k in design})
    out = {}
    for name, (numerics, smoothing) in VARIANTS.items():
        settings = m.Settings(t_max=t_max, history_points=4001, shape_times=(), **numerics)
        c = m.run(params, m.Mesh(), settings, check=False, **smoothing)
        err = error_history(c)
        ts = np.asarray(c.solution.ts)
        reached = ts <= float(c.solution.t_end)
        err = np.where(reached, err, err[reached][-1])
        jumps = np.abs(np.diff(err))
        i = int(np.argmax(jumps))
        h = c.solution.history
        ring = c.scene.chains[0]
        strain = np.asarray(ring.axial_strain(np.asarray(c.solution.final.x[0])))
        k0 = float(c.solution.k0)
        out[name] = dict(
            status=c.status,
            error=c.energy_balance_error,
            t_end=float(c.solution.t_end),
            steps=int(c.solution.steps),
            jump=float(jumps[i]),
            jump_t=float(ts[i + 1]),
            contact_force=float(np.asarray(h["contact_force"])[i + 1].sum()) / k0,
            pairs=int(sum(np.asarray(p)[i + 1].sum() for p in h["contact_pairs"])),
            error_at_half=float(err[np.searchsorted(ts, 0.5 * float(c.solution.t_end))]),
            min_ring_strain=float(strain.min()),
            contact_dissipation=float(np.asarray(c.solution.contact).sum()) / k0,
        )
    return out


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--record", default="reliability_before")
    parser.add_argument("--rows", type=int, default=6)
    parser.add_argument("--t-max", type=float, default=10.0)
    parser.add_argument("--pick", nargs="*", default=None, help="seed/row keys instead")
    parser.add_argument("--name", default="balance_probe")
    args = parser.parse_args(argv)
    record = json.loads((RESULTS / f"{args.record}.json").read_text())
    ok = [r for r in record["rows"] if r["status"] in ("settled", "time limit")]
    worst = sorted(ok, key=lambda r: -abs(r["energy_balance_error"]))[: args.rows]
    if args.pick:
        keys = {f"{r['seed']}/{r['index']}": r for r in record["rows"]}
        worst = [keys[k] for k in args.pick]
    lines = [
        "# Energy balance of the worst successful rows, one by one",
        "",
        f"`taskset -c 1 python benchmarks/balance_probe.py --record {args.record} --rows "
        f"{args.rows} --t-max {args.t_max:g}"
        + (f" --pick {' '.join(args.pick)}" if args.pick else "")
        + f" --name {args.name}` (paper mesh; errors in K0; jump: the largest "
        "change of the error between two of 4001 history samples, at tau; F: contact force/K0 "
        "then; pairs: node pairs in contact then; strain: the shortest ring bar at the end).",
        "",
        "| seed/row | h_b/h_r | g | v0 | E/Y | R/h_r | held | variant | status | error | "
        "tau end | jump | at tau | F | pairs | strain | contact D |",
        "|---" * 17 + "|",
    ]
    found = []
    for r in worst:
        result = probe(r, args.t_max)
        found.append({"design": r, "variants": result})
        for name, v in result.items():
            cells = [f"{r['seed']}/{r['index']}"]
            cells += [f"{r[k]:.3g}" for k in ("thickness_ratio", "mass_ratio", "velocity")]
            cells += [f"{r[k]:.3g}" for k in ("modulus_ratio", "slenderness")]
            cells += [int(r["axial_constraint"]), name, v["status"], f"{v['error']:+.2e}"]
            cells += [f"{v['t_end']:.3g}", f"{v['jump']:.1e}", f"{v['jump_t']:.3g}"]
            cells += [f"{v['contact_force']:.2g}", v["pairs"], f"{v['min_ring_strain']:.2f}"]
            cells += [f"{v['contact_dissipation']:.2g}"]
            line = "| " + " | ".join(str(c) for c in cells) + " |"
            lines.append(line)
            print(line, flush=True)
    (RESULTS / f"{args.name}.md").write_text("\n".join(lines) + "\n")
    (RESULTS / f"{args.name}.json").write_text(json.dumps(found, indent=1) + "\n")


if __name__ == "__main__":
    main()
