"""What the solver computes now, recorded before the batched core is rebuilt (issue 11).

Issue 11 asks that the new core reproduce the current (contact-fixed, issue 9) partitions,
step counts and end times to 1e-9 K0. This script records them, on the paper's mesh with the
default settings, for

- the three single collisions of the accuracy and convergence studies (showcase, thin free
  beam h_b/h_r = 0.5, thick constrained beam h_b/h_r = 4), through `msfd_jax.run`;
- the 64-collision sweep of `benchmarks/sweep_throughput.py` (h_b/h_r 0.25-5 x 16, free and
  held, g = 5 and 10), through `msfd_jax.sweep` with its default (lean) settings.

    python -m msfd_jax.studies.scripts.regression_baseline            # write (~1-2 min)
    python -m msfd_jax.studies.scripts.regression_baseline --check    # compare, exit 1 if not

Writes benchmarks/results/regression_baseline.json; `tests/test_regression.py` checks the
single collisions against it on every run of the suite. The record is of the core's first
attempts: the rerun of successes whose balance stays open (issue 12 item 1, later) is off
here (`_attempts.first_attempts`); failure retries are on but none of these runs fails.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import jax
import numpy as np

import msfd_jax as m
from msfd_jax._attempts import first_attempts

ROOT = Path(__file__).resolve().parents[3]
OUT = ROOT / "benchmarks" / "results" / "regression_baseline.json"
COMMAND = "python -m msfd_jax.studies.scripts.regression_baseline"
SINGLES = {
    "showcase": {},
    "thin_free": {"thickness_ratio": 0.5, "axial_constraint": 0.0},
    "thick": {"thickness_ratio": 4.0},
}
SWEEP_GRID = {
    "thickness_ratio": np.linspace(0.25, 5.0, 16).tolist(),
    "axial_constraint": [0.0, 1.0],
    "mass_ratio": [5.0, 10.0],
}
FRACTIONS = (*m.FRACTION_KEYS, "kinetic_ring", "kinetic_block", "kinetic_beam")
NUMBERS = ("energy_balance_error", "t_end", "dt", "dt_critical", "k0")
TOLERANCE = 1e-9  # K0, issue 11


def single(name: str) -> dict:
    with first_attempts():
        collision = m.run(m.CollisionParams(**SINGLES[name]), m.Mesh())
    out = collision.to_json()
    return {
        "params": SINGLES[name],
        "fractions": {**out["fractions"], **out["kinetic_split"]},
        **{k: out[k] for k in NUMBERS},
        "steps": int(out["steps"]),
        "status": out["status"],
    }


def sweep_rows() -> list[dict]:
    with first_attempts():
        table = m.sweep(SWEEP_GRID, m.Mesh(), progress=False)
    keys = ("thickness_ratio", "axial_constraint", "mass_ratio", *FRACTIONS, *NUMBERS)
    return [
        {**{k: float(table[k][i]) for k in keys}, "steps": int(table["steps"][i])}
        | {"status": str(table["status"][i])}
        for i in range(len(table))
    ]


def record() -> dict:
    return {
        "command": COMMAND,
        "date": time.strftime("%Y-%m-%d %H:%M %Z"),
        "jax": jax.__version__,
        "mesh": "paper (15, 20 + 5), default Settings",
        "singles": {name: single(name) for name in SINGLES},
        "sweep": sweep_rows(),
    }


def differences(recorded: dict, now: dict) -> list[str]:
    """Every fraction further than TOLERANCE from the record, and every step count changed."""
    bad = []
    pairs = [(f"singles.{n}", recorded["singles"][n], now["singles"][n]) for n in SINGLES]
    pairs += [
        (f"sweep[{i}]", {"fractions": a, **a}, {"fractions": b, **b})
        for i, (a, b) in enumerate(zip(recorded["sweep"], now["sweep"], strict=True))
    ]
    for where, a, b in pairs:
        for key in FRACTIONS:
            if abs(a["fractions"][key] - b["fractions"][key]) > TOLERANCE:
                bad.append(f"{where} {key}: {a['fractions'][key]!r} -> {b['fractions'][key]!r}")
        if a["steps"] != b["steps"]:
            bad.append(f"{where} steps: {a['steps']} -> {b['steps']}")
    return bad


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="compare with the recorded file")
    args = parser.parse_args(argv)
    now = record()
    if args.check:
        bad = differences(json.loads(OUT.read_text()), now)
        print("\n".join(bad) or f"all within {TOLERANCE:g} K0, same step counts")
        return 1 if bad else 0
    OUT.write_text(json.dumps(now, indent=1) + "\n")
    print(f"wrote {OUT}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
