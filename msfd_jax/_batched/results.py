"""How a solve ended: one enumeration of result codes, each with its status and message.

The counterpart of diffrax's `RESULTS` (``diffrax/_solution.py``). It is an `enum.IntEnum`
rather than an `equinox.Enumeration` because `Solution.result` stays an integer array: it is
vmapped over designs and sweeps, written as an integer to the JSON and CSV outputs, and read
with ``int(solution.result)``; an `IntEnum` member *is* that integer, so
``jnp.where(..., RESULTS.settled, ...)`` inside the solver and ``RESULTS(code).status`` outside
it both hold, and ``code == RESULTS.settled`` works on a plain int. (An `equinox.Enumeration`
item compares only with items of its own enumeration.)

The values 0..5 and the status strings are part of the output format: do not renumber.
"""

from __future__ import annotations

import enum


class RESULTS(enum.IntEnum):
    """Result code of a solve: ``RESULTS(code).status`` (short) and ``.message`` (a sentence)."""

    status: str
    message: str

    def __new__(cls, value: int, status: str, message: str):
        member = int.__new__(cls, value)
        member._value_ = value
        member.status = status
        member.message = message
        return member

    settled = 0, "settled", "plastic dissipation stopped before the time cap (Settings.t_max)"
    time_limit = 1, "time limit", "reached the time cap Settings.t_max; dissipation had not stopped"
    non_finite = 2, "non-finite", "the state became non-finite (NaN or infinity)"
    energy_balance_broken = (
        3,
        "energy balance broken",
        "the energy balance error exceeded Settings.energy_guard",
    )
    max_steps = 4, "max steps", "stopped after Settings.max_steps steps before the time cap"
    # A joint folded past pi (`engine.FOLD_LIMIT`): its bars pass through each other, which
    # the model cannot follow, so the run stops there with its energy balance still closed;
    # "energy balance broken" would name the wrong cause. A smaller step does not help.
    folded = (
        5,
        "folded",
        "a plastic joint folded past pi (its bars through each other); the run stopped there",
    )

    @property
    def failed(self) -> bool:
        """True for a solve whose numbers are not to be used (non-finite, energy, max steps)."""
        return self in FAILED


# A run that reports success (settled, time limit) closes its energy balance within this
# fraction of K0, or says it does not (`balance_warning` and a suffix of its message), so that an
# open balance is never passed off as a clean success; `run` and `sweep` first rerun such a run
# at a smaller step (`_collision.attempts`).
BALANCE_TOLERANCE = 1e-4

# Aliases kept for the former ``range(5)`` constants and the name tuple.
FAILED = (RESULTS.non_finite, RESULTS.energy_balance_broken, RESULTS.max_steps, RESULTS.folded)
RESULT_NAMES = tuple(r.status for r in RESULTS)
SETTLED, TIME_LIMIT, NON_FINITE, ENERGY_BALANCE, MAX_STEPS = tuple(RESULTS)[:5]
