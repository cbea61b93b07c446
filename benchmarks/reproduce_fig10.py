"""Fig. 10a/b and Fig. 11 of Ruan & Yu (2003): the energy partition against h_b/h_r.

g = 10, v0 = 0.82, paper mesh, h_b/h_r from 0.25 to 5, beam free / axially constrained.
Writes docs/figures/fig10_fig11.png and benchmarks/results/fig10.md (the numbers).

    python benchmarks/reproduce_fig10.py            # 20 thicknesses x 2 constraints
    python benchmarks/reproduce_fig10.py --quick    # 6 x 2 on a coarse mesh

A first slice of issue 3 (`msfd reproduce` will absorb it); the comparison with the paper's
curves is qualitative here (their figure is read by eye).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

import msfd_jax as m

ROOT = Path(__file__).resolve().parents[1]


def run(quick: bool):
    thickness = np.linspace(0.25, 5.0, 6 if quick else 20)
    mesh = m.Mesh(6, 8, 2) if quick else m.Mesh()
    table = m.sweep(
        {"axial_constraint": [0.0, 1.0], "thickness_ratio": thickness},
        mesh,
        chunk_size=len(thickness),
    )
    return thickness, table


def shares(table, n: int):
    rows = {}
    for i, name in enumerate(("free", "constrained")):
        s = slice(i * n, (i + 1) * n)
        beam = table["beam_bending"][s] + table["beam_axial"][s]
        ring = table["ring_bending"][s] + table["ring_axial"][s]
        contact = table["contact"][s]
        rows[name] = dict(
            beam=beam,
            ring=ring,
            contact=contact,
            plastic=beam + ring + contact,
            beam_bending=table["beam_bending"][s],
            beam_axial=table["beam_axial"][s],
            ring_bending=table["ring_bending"][s],
            ring_axial=table["ring_axial"][s],
            status=table["status"][s],
            t_end=table["t_end"][s],
        )
    return rows


def plot(thickness, rows, path: Path):
    fig = Figure(figsize=(13, 4))
    axes = fig.subplots(1, 3)
    panels = (("free", "(a) Fig. 10a"), ("constrained", "(b) Fig. 10b"))
    for ax, (name, label) in zip(axes[:2], panels, strict=True):
        r = rows[name]
        for key, style in (("beam", "o-"), ("ring", "s-"), ("contact", "^-"), ("plastic", "k--")):
            ax.plot(thickness, r[key], style, ms=3, label=key)
        ax.set(title=f"{label}: beam {name}", xlabel="$h_b/h_r$", ylabel="fraction of $K_0$")
        ax.set_ylim(0, 1.05)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    r = rows["constrained"]
    ax = axes[2]
    for key, style in (
        ("beam_bending", "o-"),
        ("ring_bending", "s-"),
        ("beam_axial", "^-"),
        ("ring_axial", "v-"),
    ):
        ax.plot(thickness, r[key], style, ms=3, label=key.replace("_", " "))
    ax.set(title="(c) Fig. 11: constrained, bending vs axial", xlabel="$h_b/h_r$")
    ax.set_ylim(0, 1.05)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.suptitle("Energy partition against thickness ratio (g = 10, $v_0$ = 0.82)")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)


def markdown(thickness, rows, seconds: float, quick: bool) -> str:
    lines = [
        "# Fig. 10 and 11: energy partition against h_b/h_r (g = 10, v0 = 0.82)",
        "",
        f"Produced by `python benchmarks/reproduce_fig10.py{' --quick' if quick else ''}` "
        f"({time.strftime('%Y-%m-%d')}, {seconds:.0f} s on the 2-core CPU machine). "
        "Fractions of K0; figure: docs/figures/fig10_fig11.png.",
        "",
    ]
    for name in ("free", "constrained"):
        r = rows[name]
        lines += [
            f"## Beam {name}",
            "",
            "| h_b/h_r | beam bending | beam axial | ring bending | ring axial | contact "
            "| total plastic | tau end | status |",
            "|---|---|---|---|---|---|---|---|---|",
        ]
        for i, h in enumerate(thickness):
            lines.append(
                f"| {h:.2f} | {r['beam_bending'][i]:.3f} | {r['beam_axial'][i]:.3f} "
                f"| {r['ring_bending'][i]:.3f} | {r['ring_axial'][i]:.4f} | "
                f"{r['contact'][i]:.4f} | {r['plastic'][i]:.3f} | {r['t_end'][i]:.2f} "
                f"| {r['status'][i]} |"
            )
        lines.append("")
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args(argv)
    start = time.perf_counter()
    thickness, table = run(args.quick)
    rows = shares(table, len(thickness))
    seconds = time.perf_counter() - start
    suffix = "_quick" if args.quick else ""
    plot(thickness, rows, ROOT / "docs" / "figures" / f"fig10_fig11{suffix}.png")
    text = markdown(thickness, rows, seconds, args.quick)
    out = ROOT / "benchmarks" / "results" / f"fig10{suffix}.md"
    out.write_text(text + "\n")
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
