"""Slow MS-FD runs against rigid-perfectly-plastic closed forms (docs/validation_quickstatic.md).

1. The simply supported beam driven slowly at mid-span (Fig. 12b case: n_p = 40, m_p = 1,
   l_b = 3 in ring units, E/Y = 2000) against Eq. 25, with and without axial constraint.
2. Parkes' cantilever struck at the tip (mass ratios 10 and 1, W_f / L ~ 0.2), E/Y = 1e3 ... 1e6.

The work is done by `msfd_jax.studies.reproduce.quasistatic.reproduce_analytic` (also run by
`msfd reproduce`); this prints its tables and writes docs/figures/eq25_parkes.png.

    python -m msfd_jax.studies.scripts.validate_analytic [--quick] [--mesh-study]
"""

from __future__ import annotations

import argparse
import pathlib
import sys

from msfd_jax.studies.reproduce import closed_forms as c

ROOT = pathlib.Path(__file__).resolve().parents[3]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="E/Y = 1e3, 1e4 cantilevers only")
    parser.add_argument("--mesh-study", action="store_true", help="also 40, 80 segments")
    parser.add_argument("--figures", type=pathlib.Path, default=ROOT / "docs" / "figures")
    args = parser.parse_args()
    given = " ".join(sys.argv[1:])
    command = f"python -m msfd_jax.studies.scripts.validate_analytic {given}".strip()
    print(f"Produced by `{command}`.\n")
    print(c.reproduce_analytic(args.quick, args.figures).markdown())
    if args.mesh_study:
        for segments, moduli in ((40, (1.0e4, 1.0e5)), (80, (1.0e4,))):
            study = c.parkes_study(segments=segments, moduli=moduli, max_steps=2**21)
            print("\n".join(c.parkes_table(study)))


if __name__ == "__main__":
    main()
