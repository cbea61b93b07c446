"""The recorded partitions of issue 11's baseline (benchmarks/results/regression_baseline.json).

Recorded with `python -m msfd_jax.studies.scripts.regression_baseline` after the contact fix
(issue 9), before the batched core is rebuilt: any change of the solver that moves a fraction
by more than 1e-9 K0 or changes a step count on the paper's mesh fails here. A deliberate
change of the physics rerecords the file (and says so in its commit). The 64-collision sweep of
the same file is checked by the script's `--check`, too long for the suite.
"""

import json
from pathlib import Path

import pytest

import msfd_jax as m
from msfd_jax.studies.scripts.regression_baseline import FRACTIONS, SINGLES, TOLERANCE

RECORD = json.loads(
    (Path(__file__).parents[1] / "benchmarks" / "results" / "regression_baseline.json").read_text()
)


@pytest.mark.parametrize("name", list(SINGLES))
def test_single_collision_reproduces_the_recorded_partition(name, showcase):
    recorded = RECORD["singles"][name]
    collision = showcase if name == "showcase" else m.run(m.CollisionParams(**SINGLES[name]))
    out = collision.to_json()
    now = {**out["fractions"], **out["kinetic_split"]}
    for key in FRACTIONS:
        assert now[key] == pytest.approx(recorded["fractions"][key], abs=TOLERANCE), key
    assert out["steps"] == recorded["steps"]
    assert out["status"] == recorded["status"]
    assert out["t_end"] == pytest.approx(recorded["t_end"], rel=1e-12)
