"""What the solver computes now, recorded before the batched core is rebuilt.

The rebuilt core must reproduce the current partitions (with the corrected contact
stiffness), step counts and end times to 1e-9 K0, so that the rewrite is known to change no
result beyond rounding. This script records them, on the paper's mesh with the
default settings, for

- the three single collisions of the accuracy and convergence studies (showcase, thin free
  beam h_b/h_r = 0.5, thick constrained beam h_b/h_r = 4), through `msfd_jax.run`;
- the 64-collision sweep of `benchmarks/sweep_throughput.py` (h_b/h_r 0.25-5 x 16, free and
  held, g = 5 and 10), through `msfd_jax.sweep` with its default (lean) settings.

    python -m msfd_jax.studies.scripts.regression_baseline            # write (~1-2 min)
    python -m msfd_jax.studies.scripts.regression_baseline --check    # compare, exit 1 if not

`--check` holds every fraction to 1e-9 K0 with the same step count; a row that misses
that is rerun with the impact velocity 1 to 4 ulps up and down, and passes as
rounding-sensitive if its difference is within `SPREAD_FACTOR` times that spread (the thin
beams with sharp contact: the core's rewrite moved them as much as a few ulps do;
tests/test_regression.py). ~5 min.

Writes tests/data/regression_baseline.json; `tests/test_regression.py` checks the
single collisions against it on every run of the suite. The record is of the core's first
attempts: the rerun of successes whose balance stays open (added after this record) is off
here (`_collision.attempts.first_attempts`); failure retries are on but none of these runs fails.
"""

from __future__ import annotations

import argparse
import itertools
import json
import sys
import time
from pathlib import Path

import jax
import numpy as np

import msfd_jax as m
from msfd_jax._collision.attempts import first_attempts

ROOT = Path(__file__).resolve().parents[3]
OUT = ROOT / "tests" / "data" / "regression_baseline.json"
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
TOLERANCE = 1e-9  # K0: what the rebuilt core must reproduce the record to


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


# A row that misses TOLERANCE still passes when its difference from the record is within
# SPREAD_FACTOR times its rounding spread: how far the same code moves it when the impact
# velocity moves by 1 to SPREAD_ULPS ulps either way (2 x SPREAD_ULPS runs, `spreads`). Such
# a row amplifies rounding (thin beams with sharp contact: tests/test_regression.py), so any
# change of the order of operations (the core's rewrite, a CPU with another instruction set,
# a GPU) moves it by about that much. Its step count is as loosely defined: one ulp moved the
# thinnest free beam's by 24 and 96 steps, eight ulps by up to 27 000 (of 31 184).
SPREAD_ULPS = 4
SPREAD_FACTOR = 3


def _row_of(where: str) -> dict:
    """The params of a compared row (`differences`' labels: singles.NAME, sweep[I])."""
    if where.startswith("singles."):
        return SINGLES[where.split(".", 1)[1]]
    rows = [dict(zip(SWEEP_GRID, r, strict=True)) for r in itertools.product(*SWEEP_GRID.values())]
    return rows[int(where[len("sweep[") : -1])]


def nudged_velocities() -> list[float]:
    """The impact velocity moved by 1 .. SPREAD_ULPS ulps up and down."""
    out = []
    for toward in (2.0, 0.0):
        v = float(m.CollisionParams().velocity)
        for _ in range(SPREAD_ULPS):
            v = float(np.nextafter(v, toward))
            out.append(v)
    return out


def spreads(wheres: list[str], now: dict) -> dict[str, tuple[float, int]]:
    """Each row's rounding spread against `now`: the largest |fraction change| and step
    change over `nudged_velocities` (first attempts, as recorded)."""
    vels = nudged_velocities()
    out: dict[str, tuple[float, int]] = {}
    for w in (w for w in wheres if w.startswith("singles.")):
        base = now["singles"][w.split(".", 1)[1]]
        diff, steps = 0.0, 0
        for vel in vels:
            with first_attempts():
                j = m.run(m.CollisionParams(**_row_of(w), velocity=vel), m.Mesh()).to_json()
            f = {**j["fractions"], **j["kinetic_split"]}
            diff = max(diff, *(abs(f[k] - base["fractions"][k]) for k in FRACTIONS))
            steps = max(steps, abs(int(j["steps"]) - base["steps"]))
        out[w] = (diff, steps)
    rows = [w for w in wheres if not w.startswith("singles.")]
    if rows:
        grid = [_row_of(w) | {"velocity": vel} for w in rows for vel in vels]
        with first_attempts():
            table = m.sweep(grid, m.Mesh(), progress=False)
        for j, w in enumerate(rows):
            base = now["sweep"][int(w[len("sweep[") : -1])]
            idx = range(j * len(vels), (j + 1) * len(vels))
            out[w] = (
                max(abs(float(table[k][i]) - base[k]) for i in idx for k in FRACTIONS),
                max(abs(int(table["steps"][i]) - base["steps"]) for i in idx),
            )
    return out


def judged(recorded: dict, now: dict) -> tuple[list[str], list[str]]:
    """(rows beyond their rounding spread, rows within it), a line each: the rows that miss
    TOLERANCE or their step count, judged against SPREAD_FACTOR x their rounding spread."""
    bad = differences(recorded, now)
    by_row: dict[str, list[str]] = {}
    for line in bad:
        by_row.setdefault(line.split(" ", 1)[0], []).append(line)
    if not by_row:
        return [], []
    spread_of = spreads(list(by_row), now)
    beyond, within = [], []
    for where, lines in by_row.items():
        a, b = _compared(recorded, now, where)
        diff = max(abs(a["fractions"][k] - b["fractions"][k]) for k in FRACTIONS)
        steps = abs(a["steps"] - b["steps"])
        spread, spread_steps = spread_of[where]
        ok = diff <= SPREAD_FACTOR * spread and steps <= SPREAD_FACTOR * spread_steps
        text = (
            f"{where}: {diff:.2e} K0 and {steps} steps from the record; rounding spread "
            f"{spread:.2e} K0 and {spread_steps} steps"
        )
        (within if ok else beyond).append(text if ok else text + "\n  " + "\n  ".join(lines))
    return beyond, within


def _compared(recorded: dict, now: dict, where: str) -> tuple[dict, dict]:
    if where.startswith("singles."):
        name = where.split(".", 1)[1]
        return recorded["singles"][name], now["singles"][name]
    i = int(where[len("sweep[") : -1])
    a, b = recorded["sweep"][i], now["sweep"][i]
    return {"fractions": a, **a}, {"fractions": b, **b}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="compare with the recorded file")
    args = parser.parse_args(argv)
    now = record()
    if args.check:
        beyond, within = judged(json.loads(OUT.read_text()), now)
        if within:
            print(
                f"rounding-sensitive rows, within {SPREAD_FACTOR}x their rounding spread "
                f"(velocity +-1..{SPREAD_ULPS} ulps):\n" + "\n".join(within)
            )
        if beyond:
            print("beyond their rounding spread:\n" + "\n".join(beyond))
        n = len(within) + len(beyond)
        print(
            f"{len(beyond)} of {n} differing rows beyond their spread; every other row within "
            f"{TOLERANCE:g} K0 with the same steps"
        )
        return 1 if beyond else 0
    OUT.write_text(json.dumps(now, indent=1) + "\n")
    print(f"wrote {OUT}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
