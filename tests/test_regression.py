"""The recorded partitions of issue 11's baseline (tests/data/regression_baseline.json).

The batched core (issue 11) reproduces the showcase and the thick beam to 1e-12 K0 with the
same steps. The thin free beam with sharp contact cannot be held to 1e-9: moving its impact
velocity by one ulp moves its partition by 1.2e-3 K0 and its steps by 48, in the old core as
in the new (`python -m msfd_jax.studies.scripts.rounding_sensitivity`; the old core's record is
tests/data/sensitivity_old_core.json). Its recorded value is defined only
to that spread, so it is checked to 3e-3 K0 and 1 % of its steps, and, with the contact
smoothed (w = 1e-3, one-ulp spread 4e-8 K0), against the old core's record to 1e-7 K0 with
equal steps.

The record is of the core's first attempt: it was taken before issue 12 item 1 reruns a
success whose balance stays open by more than 1e-4 K0 at half the step, so the runs compared
here have that rerun off (`_attempts.first_attempts`; failure retries stay on, and none of
these runs fails). What the rerun does to thin_free (1.45e-4 K0 open at the first attempt) is
asserted apart.

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
from msfd_jax._batched.results import BALANCE_TOLERANCE
from msfd_jax._collision.attempts import first_attempts
from msfd_jax.studies.scripts.regression_baseline import FRACTIONS, SINGLES, TOLERANCE

DATA = Path(__file__).parent / "data"
OLD_CORE = json.loads((DATA / "sensitivity_old_core.json").read_text())
ROUNDING_LIMITED = {"thin_free": (3e-3, 0.01)}  # K0, relative steps: the one-ulp spread x 2.5
RECORD = json.loads((DATA / "regression_baseline.json").read_text())


@pytest.mark.parametrize("name", list(SINGLES))
def test_single_collision_reproduces_the_recorded_partition(name, showcase):
    recorded = RECORD["singles"][name]
    if name == "showcase":
        collision = showcase  # closes to 5e-6 K0: its first attempt is the one reported
    else:
        with first_attempts():
            collision = m.run(m.CollisionParams(**SINGLES[name]))
    assert collision.retries == 0
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
    with first_attempts():
        out = m.run(params, m.Mesh(), contact_smoothing=1e-3).to_json()
    now = {**out["fractions"], **out["kinetic_split"]}
    for key in FRACTIONS:
        assert now[key] == pytest.approx(recorded["fractions"][key], abs=1e-7), key
    assert out["steps"] == recorded["steps"]


def test_thin_free_beam_is_rerun_once_and_closes_its_balance():
    """Issue 12 item 1 with the rerun on: thin_free's first attempt (safety 0.7) settles with
    1.3-1.5e-4 K0 open, above BALANCE_RETRY_ABOVE = 1e-4; one halving closes it (measured
    1.7e-5 K0 at 0.35, 47 184 steps) and moves the partition by less than the case's own
    rounding spread (1.8e-3 K0 against the 3e-3 that the record is checked to)."""
    recorded = RECORD["singles"][name := "thin_free"]
    collision = m.run(m.CollisionParams(**SINGLES[name]))
    out = collision.to_json()
    assert out["status"] == "settled" and out["retries"] == 1
    assert out["safety"] == pytest.approx(0.35)
    assert abs(out["energy_balance_error"]) <= BALANCE_TOLERANCE
    assert not out["balance_warning"]
    assert out["message"].startswith("retried with dt = ") and "; balance 1." in out["message"]
    assert out["steps"] == pytest.approx(2 * recorded["steps"], rel=0.02)
    now = {**out["fractions"], **out["kinetic_split"]}
    for key in FRACTIONS:
        assert now[key] == pytest.approx(recorded["fractions"][key], abs=3e-3), key
