"""Work-precision study: writes docs/results/accuracy.* and the figures.

Parts (each writes its own JSON, the markdown is rebuilt from every JSON present):

- ``study``: error against wall time for three collisions and every method
  (msfd_jax/studies/accuracy/; docs/results/accuracy.json, docs/figures/accuracy_*.png);
- ``stability``: the stability catalogue's finishing scenes at a candidate default step
  (docs/results/accuracy_stability.json);
- ``mesh``: the dissipated fractions on the paper mesh refined x4 and x8, extending
  docs/results/convergence.md (docs/results/accuracy_mesh.json).

    taskset -c 1 python -m msfd_jax.studies.scripts.accuracy --parts study  # ~30-60 min
    python -m msfd_jax.studies.scripts.accuracy --parts study --quick  # coarse mesh, minutes
    python -m msfd_jax.studies.scripts.accuracy --parts stability --candidate 0.8
    python -m msfd_jax.studies.scripts.accuracy --parts mesh --factors 8
    python -m msfd_jax.studies.scripts.accuracy --parts report  # markdown + figures only

Timings: pin to one core (``taskset -c 1``) and rerun on a quiet machine; every timed run
records ``os.getloadavg()`` so that a loaded run can be recognised.
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import time
from pathlib import Path

import jax

from msfd_jax.studies import accuracy as A

ROOT = Path(__file__).resolve().parents[3]
RESULTS = ROOT / "docs" / "results"
FIGURES = ROOT / "docs" / "figures"


def _meta() -> dict:
    return dict(
        machine=f"{platform.node()} ({platform.machine()}, {platform.processor() or 'cpu'})",
        date=time.strftime("%Y-%m-%d %H:%M %Z"),
        jax=jax.__version__,
        command="python -m msfd_jax.studies.scripts.accuracy "
        + " ".join(__import__("sys").argv[1:]),
    )


def _load(name: str):
    path = RESULTS / name
    return json.loads(path.read_text()) if path.exists() else None


def _dump(name: str, obj) -> None:
    (RESULTS / name).write_text(json.dumps(obj, indent=1, default=float) + "\n")


def report() -> str:
    lines = ["# Work-precision study (raw results)", ""]
    res = _load("accuracy.json")
    if res:
        lines += [
            f"Produced by `{res['command']}` ({res['date']}, {res['machine']}, jax {res['jax']}, "
            f"CPU affinity {res['affinity']} of {res['cpu_count']}; "
            f"{res['total_wall_time_s']:.0f} s in all). Mesh {res['config']['mesh']}, "
            f"fixed time tau = {res['config']['t_fixed']}, {res['config']['repeats']} timed "
            "repeats after a warm-up run, interleaved. Errors: max over components in K0 "
            "(fixed_time: all seven fractions at tau = T; at_stop: five dissipated fractions "
            "and K + U at the settled stop).",
            "",
            A.markdown(res),
            "",
            "## Fastest configuration within 1e-3 K0 (median wall time)",
            "",
            "| case | metric | method | parameter | error [K0] | median s |",
            "|---|---|---|---|---|---|",
        ]
        for metric in ("at_stop", "fixed_time"):
            for case, r in A.fastest_within(res["rows"], 1e-3, metric).items():
                lines.append(
                    f"| {case} | {metric} | {r['method']} | {r['parameter']} = {r['value']:g} "
                    f"| {r['error']:.2e} | {r['wall_median_s']:.3f} |"
                )
        lines.append("")
        lines += [
            "## Largest Verlet step within 1e-3 K0",
            "",
            "| case | metric | safety | error [K0] | errors at 1.0 / 0.9 / 0.8 / 0.7 / 0.5 [K0] |",
            "|---|---|---|---|---|",
        ]
        for case in res["cases"]:
            for metric in ("at_stop", "fixed_time"):
                sel = [
                    r
                    for r in res["rows"]
                    if r["case"] == case and r["metric"] == metric and r["method"] == "verlet"
                ]
                good = [r for r in sel if r["ok"] and r["error"] <= 1e-3]
                big = max(good, key=lambda r: r["value"]) if good else None
                at = {r["value"]: r["error"] for r in sel}
                listed = " / ".join(f"{at.get(s, math.nan):.1e}" for s in (1.0, 0.9, 0.8, 0.7, 0.5))
                lines.append(
                    f"| {case} | {metric} | {big['value'] if big else '-'} "
                    f"| {big['error'] if big else math.nan:.1e} | {listed} |"
                )
        lines.append("")
    stab = _load("accuracy_stability.json")
    if stab:
        from msfd_jax.studies import stability as _stability

        lines += [
            f"## Stability catalogue at the candidate step safety = {stab['candidate']}",
            "",
            f"Produced by `{stab['command']}` ({stab['date']}): every finishing scene of "
            "msfd_jax/studies/stability.py that uses the default step, run at the candidate "
            f"({'quick' if stab['quick'] else 'paper'} mesh form).",
            "",
            _stability.markdown_table(stab["rows"]),
            "",
        ]
    mesh = _load("accuracy_mesh.json")
    if mesh:
        lines += [
            "## Mesh refinement (extends convergence.md)",
            "",
            f"Produced by `{mesh['command']}` ({mesh['date']}): default settings, settled stop; "
            "dissipated fractions of K0.",
            "",
            "| case | mesh | beam_bending | beam_axial | ring_bending | ring_axial | contact "
            "| tau end | steps | result | wall s (with compile) |",
            "|---|---|---|---|---|---|---|---|---|---|---|",
        ]
        for r in mesh["rows"]:
            f = r["fractions"]
            lines.append(
                f"| {r['case']} | x{r['factor']} | "
                + " | ".join(f"{f[k]:.4f}" for k in A.DISSIPATED)
                + f" | {r['t_end']:.2f} | {r['steps']} | {r['result']} "
                f"| {r['wall_s_with_compile']:.0f} |"
            )
        lines.append("")
    return "\n".join(lines)


def figures(res: dict) -> None:
    for metric in ("at_stop", "fixed_time", "fixed_time_tiny"):
        if any(r["metric"] == metric for r in res["rows"]):
            A.plot(res, metric, FIGURES / f"accuracy_{metric}.png")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--parts", nargs="+", default=["study"], choices=["study", "stability", "mesh", "report"]
    )
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--only", nargs="+", default=[], help="collisions and/or methods")
    parser.add_argument("--repeats", type=int, default=None)
    parser.add_argument("--candidate", type=float, default=0.8)
    parser.add_argument("--factors", type=int, nargs="+", default=[4, 8])
    args = parser.parse_args(argv)
    if "study" in args.parts:
        config = A.QUICK if args.quick else A.Config()
        if args.repeats:
            config = A.Config(**{**config.__dict__, "repeats": args.repeats})
        start = time.perf_counter()
        res = A.study(
            config,
            cases=[n for n in args.only if n in A.CASES] or None,
            methods=[n for n in args.only if n in A.METHODS] or None,
        )
        res.update(_meta(), total_wall_time_s=time.perf_counter() - start)
        _dump("accuracy.json", res)
    if "stability" in args.parts:
        rows = A.candidate_stability(args.candidate, quick=args.quick)
        _dump(
            "accuracy_stability.json",
            dict(candidate=args.candidate, quick=args.quick, rows=rows, **_meta()),
        )
    if "mesh" in args.parts:
        rows = A.mesh_refinement(args.factors, [n for n in args.only if n in A.CASES] or None)
        _dump("accuracy_mesh.json", dict(rows=rows, **_meta()))
    res = _load("accuracy.json")
    if res:
        figures(res)
    text = report()
    (RESULTS / "accuracy.md").write_text(text + "\n")
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
