"""Automatic recovery of a sweep's collisions (issue 12 items 1, 3): a smaller step, bounded.

A collision stopped by a guard for a reason a smaller step can fix (`_attempts.step_is_cause`:
non-finite or energy balance broken with dt above 0.95 x the stability limit) is solved again
with the step halved (`_attempts.smaller_step`), at most `_attempts.MAX_RETRIES` times, as
`run` does for one collision; so is a collision that reports success with its energy balance
open by more than `_attempts.BALANCE_RETRY_ABOVE` (1e-4) K0, at most
`_attempts.BALANCE_RETRIES` halvings (`_attempts.needs_retry`). Rows failing for another
reason (a crushed ring bar without collapse contacts, ...) are not retried. The attempt
reported is the last one, or an earlier success that closed its balance better
(`_attempts.keep_earlier`; its message then ends with `RETRY_NOTE`). Each row gets `retries`
and `safety` (= dt / dt_crit) of the run reported; a retried row's message names the step
used and the first run's failure or open balance.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ._attempts import RETRY_NOTE, keep_earlier, needs_retry, smaller_step

RETRY_OUTPUTS = ("retries", "safety")


def _counted(part: dict, attempt: int) -> dict:
    n = len(part["result"])
    out = dict(part)
    out["retries"] = np.full(n, attempt, np.int64)
    out["safety"] = np.asarray(part["dt"], np.float64) / np.asarray(part["dt_critical"])
    return out


def with_retry_columns(finished: dict) -> dict:
    """Rows read back from a store written before issue 12: no retries, safety from dt."""
    if not finished or "retries" in finished:
        return finished
    return _counted(finished, 0)


def _prefixed(part: dict, first: np.ndarray) -> dict:
    """Messages of retried rows: the step used and the failure recovered from."""
    out = dict(part)
    out["message"] = np.asarray(
        [
            f"retried with dt = {dt:.3g} ({s:.3g} x the stability limit, {r} retries) after: "
            f"{f}; then {m}"
            for dt, s, r, f, m in zip(
                part["dt"], part["safety"], part["retries"], first, part["message"], strict=True
            )
        ],
        dtype=str,
    )
    return out


def _chosen(current: dict, new: dict, first: np.ndarray | None) -> dict:
    """Per row, the later attempt `new` or, where `keep_earlier`, the `current` one (its
    message noted); `new` rows are prefixed with the first run's message when `first` is
    given (the top level)."""
    keep = keep_earlier(
        current["result"],
        current["energy_balance_error"],
        new["result"],
        new["energy_balance_error"],
    )
    if first is not None:
        new = _prefixed(new, first)
    out = {}
    for k, v in new.items():
        cur, v = np.asarray(current[k]), np.asarray(v)
        if k == "message":
            cur = np.asarray([f"{m}{RETRY_NOTE}" for m in cur.tolist()], dtype=str)
        merged = np.where(keep, cur.astype(object), v.astype(object)).tolist()
        out[k] = np.asarray(merged, dtype=str if v.dtype.kind == "U" else v.dtype)
    return out


def solve_with_retries(
    solve: Callable, columns: dict, mesh, settings, *, on_rows=None, attempt: int = 0, **kw
) -> dict:
    """`solve(columns, mesh, settings, on_rows=..., **kw)` (the sweep's unit of work) with
    the rows `needs_retry` names solved again at a smaller step; output columns gain
    `RETRY_OUTPUTS`. `on_rows` sees each row once, with its final outputs."""
    again, first = [], []

    def take(rows, part):
        rows, part = np.asarray(rows), _counted(part, attempt)
        retry = needs_retry(
            part["result"], part["dt"], part["dt_critical"], part["energy_balance_error"], attempt
        )
        again.append(rows[retry])
        first.append(np.asarray(part["message"])[retry])
        if on_rows is not None and (~retry).any():
            on_rows(rows[~retry], {k: np.asarray(v)[~retry] for k, v in part.items()})

    out = _counted(solve(columns, mesh, settings, on_rows=take, **kw), attempt)
    rows = np.concatenate(again) if again else np.zeros(0, int)
    if not len(rows):
        return out
    before = dict(zip(rows.tolist(), np.concatenate(first).tolist(), strict=True))

    def firsts(these):
        return np.asarray([before[r] for r in these.tolist()]) if attempt == 0 else None

    def current(these):
        return {k: np.asarray(out[k])[these] for k in out}

    def relay(sub_rows, part):
        sub_rows = rows[np.asarray(sub_rows)]
        if on_rows is not None:
            on_rows(sub_rows, _chosen(current(sub_rows), part, firsts(sub_rows)))

    sub = {k: np.asarray(v)[rows] for k, v in columns.items()}
    redone = solve_with_retries(
        solve, sub, mesh, smaller_step(settings), on_rows=relay, attempt=attempt + 1, **kw
    )
    redone = _chosen(current(rows), redone, firsts(rows))
    for k, v in redone.items():
        merged = np.asarray(out[k]).astype(object)
        merged[rows] = np.asarray(v).astype(object)
        out[k] = np.asarray(
            merged.tolist(),
            dtype=np.asarray(out[k]).dtype.kind == "U" and str or np.asarray(out[k]).dtype,
        )
    return out
