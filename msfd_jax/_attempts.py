"""When a run is solved again at a smaller step, and which attempt is reported (issue 12).

Shared by `run` (`_outputs`), sweeps (`_retry`) and the stability catalogue.
"""

from __future__ import annotations

import contextlib
import dataclasses

import numpy as np

from ._results import BALANCE_TOLERANCE, RESULTS
from ._simulate import Settings

# Issue 12 item 3: a run stopped by a guard for a reason a smaller step can fix (non-finite or
# energy balance broken with dt above STEP_CAUSE x the stability limit, `diagnose`'s test) is
# rerun with the step halved, at most MAX_RETRIES times.
STEP_CAUSE = 0.95
MAX_RETRIES = 2
RETRY_FACTOR = 0.5
# Issue 12 item 1: a run that reports success but closes its energy balance only to worse than
# BALANCE_RETRY_ABOVE (= BALANCE_TOLERANCE, 1e-4) K0 is also rerun with the step halved, at
# most BALANCE_RETRIES halvings in all (failure retries included); the attempt reported is the
# success with the smallest |error| (`keep_earlier`). 2 from the evidence in docs/stability.md:
# the sharp-contact residual falls ~10x per halving (row 1/91: 4.1e-2, 3.3e-4, 4.7e-5 K0),
# a third halving would cost 8x the first run for the few rows two do not close.
BALANCE_RETRIES = 2
# The rerun threshold is the flag's: no success is left open above 1e-4 K0 without a rerun
# (issue 12 item 1's goal). At 2e-4 (the former value) 74 of 300 random-design successes stayed
# flagged between 1e-4 and 3.9e-4 K0, 29 of them never rerun (docs/stability.md). The paper's
# thin free beam (tests/test_regression.py, thin_free: 1.45e-4 K0 open) is now rerun; the
# regression record is its first attempt, which that test compares with the retry off.
BALANCE_RETRY_ABOVE = BALANCE_TOLERANCE
RETRY_NOTE = "; a rerun at a smaller step closed the balance no better"


def step_is_cause(result, dt, dt_critical):
    """True (elementwise) where a smaller step may fix the failure: non-finite, energy balance
    broken or folded with dt above `STEP_CAUSE` x the stability limit (`diagnose`'s cause;
    a fold was reported as a broken balance before it had its own code, and is retried as
    it was then)."""
    stopped = (RESULTS.non_finite, RESULTS.energy_balance_broken, RESULTS.folded)
    failed = np.isin(np.asarray(result), stopped)
    return failed & (np.asarray(dt) > STEP_CAUSE * np.asarray(dt_critical))


def _success(result):
    return np.isin(np.asarray(result), (RESULTS.settled, RESULTS.time_limit))


def needs_retry(result, dt, dt_critical, error, attempt):
    """True (elementwise) where attempt `attempt` (0: the first run) is rerun at a smaller
    step: a failure `step_is_cause` names (at most `MAX_RETRIES` halvings) or a success whose
    balance is open by more than `BALANCE_RETRY_ABOVE` K0 (at most `BALANCE_RETRIES` halvings
    in all)."""
    attempt = np.asarray(attempt)
    failed = step_is_cause(result, dt, dt_critical) & (attempt < MAX_RETRIES)
    open_balance = _success(result) & (np.abs(np.asarray(error)) > BALANCE_RETRY_ABOVE)
    return failed | (open_balance & (attempt < BALANCE_RETRIES))


def keep_earlier(result, error, later_result, later_error):
    """True (elementwise) where an earlier attempt is reported rather than a later one at a
    smaller step: it reports success and the later one fails or closes its balance no better."""
    later_worse = ~_success(later_result) | (
        np.abs(np.asarray(error)) <= np.abs(np.asarray(later_error))
    )
    return _success(result) & later_worse


@contextlib.contextmanager
def first_attempts():
    """Within the block no success is rerun for its balance (`BALANCE_RETRIES` = 0): `run`
    and sweeps report each successful collision's first attempt, as the regression record
    (benchmarks/results/regression_baseline.json, recorded before issue 12 item 1) holds it.
    Failure retries stay on. Process-wide: not for use while other threads solve."""
    global BALANCE_RETRIES
    kept, BALANCE_RETRIES = BALANCE_RETRIES, 0
    try:
        yield
    finally:
        BALANCE_RETRIES = kept


def smaller_step(settings: Settings) -> Settings:
    """`settings` with the step multiplied by `RETRY_FACTOR` (safety, or the fixed dt)."""
    if settings.dt is None:
        return dataclasses.replace(settings, safety=settings.safety * RETRY_FACTOR)
    return dataclasses.replace(settings, dt=settings.dt * RETRY_FACTOR)
