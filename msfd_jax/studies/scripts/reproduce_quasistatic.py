"""The paper's quasi-static results: Fig. 17c, Fig. 18/22, Eq. 25 and Parkes.

Runs `msfd_jax.studies.reproduce.quasistatic` (paper mesh unless --quick), writes the figures
docs/figures/{fig17c,fig18_fig22,eq25_parkes}.png and the markdown docs/results/
quasistatic.md (+ quasistatic.json with the numbers).

    python -m msfd_jax.studies.scripts.reproduce_quasistatic [--quick]  # ~5 min (quick ~2 min)
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from msfd_jax.studies.reproduce import closed_forms as c
from msfd_jax.studies.reproduce import quasistatic as q

ROOT = Path(__file__).resolve().parents[3]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--figures", type=Path, default=ROOT / "docs" / "figures")
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "results")
    args = parser.parse_args()
    results = [
        f(args.quick, args.figures)
        for f in (q.reproduce_fig17, q.reproduce_fig18_22, c.reproduce_analytic)
    ]
    head = [
        "# Quasi-static results of the paper (Fig. 17c, 18, 22; Eq. 25; Parkes)",
        "",
        "Written by `python -m msfd_jax.studies.scripts.reproduce_quasistatic"
        f"{' --quick' if args.quick else ''}`"
        "; figures in docs/figures/.",
        "",
    ]
    text = "\n".join(head) + "\n".join(r.markdown() for r in results)
    args.out.mkdir(parents=True, exist_ok=True)
    suffix = "_quick" if args.quick else ""
    (args.out / f"quasistatic{suffix}.md").write_text(
        text.replace("](figures/", "](../../docs/figures/")
    )
    (args.out / f"quasistatic{suffix}.json").write_text(
        json.dumps([r.to_json() for r in results], indent=1, default=float)
    )
    print(text)


if __name__ == "__main__":
    main()
