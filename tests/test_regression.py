"""The recorded partitions of issue 11's baseline (benchmarks/results/regression_baseline.json).

The batched core (issue 11) reproduces the showcase and the thick beam to 1e-12 K0 with the
same steps. The thin free beam with sharp contact cannot be held to 1e-9: moving its impact
velocity by one ulp moves its partition by 1.2e-3 K0 and its steps by 48, in the old core as
in the new (`python -m msfd_jax.studies.scripts.rounding_sensitivity`; the old core's record is
benchmarks/results/core_rewrite/sensitivity_old_core.json). Its recorded value is defined only
to that spread, so it is checked to 3e-3 K0 and 1 % of its steps, and, with the contact
smoothed (w = 1e-3, one-ulp spread 4e-8 K0), against the old core's record to 1e-7 K0 with
equal steps.

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

RESULTS = Path(__file__).parents[1] / "benchmarks" / "results"
OLD_CORE = json.loads((RESULTS / "core_rewrite" / "sensitivity_old_core.json").read_text())
ROUNDING_LIMITED = {"thin_free": (3e-3, 0.01)}  # K0, relative steps: the one-ulp spread x 2.5
RECORD = json.loads(
    (Path(__file__).parents[1] / "benchmarks" / "results" / "regression_baseline.json").read_text()
)


@pytest.mark.parametrize("name", list(SINGLES))
def test_single_collision_reproduces_the_recorded_partition(name, showcase):
    recorded = RECORD["singles"][name]
    collision = showcase if name == "showcase" else m.run(m.CollisionParams(**SINGLES[name]))
    out = collision.to_json()
    now = {**out["fractions"], **out["kinetic_split"]}
    tolerance, steps = ROUNDING_LIMITED.get(name, (TOLERANCE, 0.0))
    for key in FRACTIONS:
        assert now[key] == pytest.approx(recorded["fractions"][key], abs=tolerance), key
    assert out["steps"] == pytest.approx(recorded["steps"], rel=steps)
    assert out["status"] == recorded["status"]
    if not steps:
        assert out["t_end"] == pytest.approx(recorded["t_end"], rel=1e-12)


def test_smoothed_thin_free_beam_reproduces_the_old_core():
    recorded = OLD_CORE["thin_free/0.001"]
    params = m.CollisionParams(**SINGLES["thin_free"])
    out = m.run(params, m.Mesh(), contact_smoothing=1e-3).to_json()
    now = {**out["fractions"], **out["kinetic_split"]}
    for key in FRACTIONS:
        assert now[key] == pytest.approx(recorded["fractions"][key], abs=1e-7), key
    assert out["steps"] == recorded["steps"]
