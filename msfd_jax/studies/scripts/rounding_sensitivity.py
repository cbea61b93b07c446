"""How far the recorded partitions are defined: each baseline collision run twice, with the
impact velocity moved by one ulp (0.82 -> nextafter(0.82, 1)), sharp and smoothed contact.

The rebuilt core must reproduce the recorded partitions to 1e-9 K0. Where the
model itself moves by more than that under a one-ulp change of an input, no rewrite that
changes the order of floating-point operations can: such a collision amplifies rounding
(the sharp, stiff contact chatters), and its recorded value is defined only to that spread.

    python -m msfd_jax.studies.scripts.rounding_sensitivity            # ~2 min
    python -m msfd_jax.studies.scripts.rounding_sensitivity --out PATH

Writes tests/data/sensitivity.json (this core). The same script run on
the core before the rewrite (commit 47e72ae) wrote sensitivity_old_core.json beside it;
tests/test_regression.py checks the smoothed thin free beam against that record.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

import msfd_jax as m

from .regression_baseline import SINGLES

ROOT = Path(__file__).resolve().parents[3]
OUT = ROOT / "tests" / "data" / "sensitivity.json"
SMOOTHINGS = (0.0, 1e-3)


def measure() -> dict:
    out = {}
    for name, kw in SINGLES.items():
        for smooth in SMOOTHINGS:
            rows = []
            for v in (0.82, float(np.nextafter(0.82, 1.0))):
                j = m.run(
                    m.CollisionParams(velocity=v, **kw), m.Mesh(), contact_smoothing=smooth
                ).to_json()
                rows.append(({**j["fractions"], **j["kinetic_split"]}, j["steps"]))
            spread = max(abs(rows[0][0][k] - rows[1][0][k]) for k in rows[0][0])
            out[f"{name}/{smooth}"] = dict(
                fractions=rows[0][0], steps=rows[0][1], ulp_spread=spread, steps_ulp=rows[1][1]
            )
            print(
                f"{name:10s} contact smoothing {smooth:g}: steps {rows[0][1]} / {rows[1][1]}, "
                f"one-ulp spread {spread:.2e} K0",
                flush=True,
            )
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=OUT)
    args = parser.parse_args()
    record = measure()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(record, indent=1) + "\n")
    print(f"written to {args.out}")


if __name__ == "__main__":
    main()
