"""Tuning a design to an energy-split target: projected Adam on a smoothed model, annealed.

Method (the smoothing is a path back to the sharp model, whose design the answer is):

1. Each stage fixes a yield smoothing s (fraction of the yield value) and a contact smoothing w
   (units of R); stages anneal both towards zero. They are arrays in the scene, so no stage
   compiles a new program.
2. Each iteration evaluates the **sharp** model at the design, and takes the gradient
   dJ/dx = dJ/df(f_sharp) . df_smooth/dx: the objective's value and its derivative with respect
   to the partition come from the sharp model, only the slope of the partition in the design
   from the smoothed one (whose slope is clean, where the sharp one is jagged). At a fixed
   point f_sharp meets the target, so the smoothing's bias on the partition (up to ~0.1 K0 at
   s = 0.05, `benchmarks/smoothing_bias.py`) does not move the answer; it only has to give a
   slope of the right sign. ``sharp_correction=False`` tunes the smoothed model itself.
3. Adam (optax) steps in unit coordinates u = (x - low)/(high - low), projected back into
   [0, 1]; every stage restarts Adam with its own (smaller) learning rate.
4. Stop as soon as the sharp model meets every term within `tolerance` (K0), or when the
   design sits on a bound with the gradient pushing outwards (`STALL` iterations running).
5. Safeguard (one design variable, one `TargetShare`): where the sharp share jumps (a change
   of deformation mode) the smoothed slope can point the wrong way and the steps stall; if two
   designs seen (iterates or box corners) put the sharp share on either side of the target,
   regula falsi on the sharp model shrinks that bracket (`bracket` evaluations at most).
6. Otherwise the goal is reported ``unreachable`` if some term was met by no design seen and
   (for a target) lies outside the range of the shares seen, box corners included, or if the
   designs seen that meet one term all miss another (the terms conflict: a beam-share target
   whose designs all put the ring above its limit); the message names the term that cannot be
   met. Else ``not converged`` (each term met somewhere, not together, and no conflict seen).

Robust tuning: a `Problem` with `Conditions` (samples of v0 and g) makes every step above work
on the *expected* partition over the samples (vmapped, one program); the result then also holds
each sample's sharp partition at the found design and the spread of every share.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from typing import Any, NamedTuple

import jax
import numpy as np
import optax

import msfd_jax as m

from ._conditions import spread
from ._design import Box, Design, as_arrays, default_box, project
from ._gradient import SHARP_REMEDY, gradient, is_sharp
from ._objective import STRUCTURES, Objective, TargetShare, share
from ._problem import Problem, arrays, check, evaluate


class Stage(NamedTuple):
    """One annealing stage: smoothing levels, iteration budget and Adam's learning rate (in u)."""

    yield_smoothing: float
    contact_smoothing: float
    iterations: int
    learning_rate: float


# Smoothing levels from benchmarks/smoothing_bias.py (bias of the beam share up to ~0.1 K0 at
# the first level, ~0.02 at the last); learning rates in unit coordinates, halved per stage.
DEFAULT_STAGES = (
    Stage(0.05, 0.01, 10, 0.08),
    Stage(0.02, 0.004, 10, 0.04),
    Stage(0.005, 0.001, 10, 0.02),
)


@dataclasses.dataclass
class TuneResult:
    """The outcome of `tune`: the design, the sharp model's partition there, and the history."""

    design: Design
    status: str  # "converged", "unreachable" or "not converged"
    message: str
    fractions: dict[str, float]  # sharp model at `design`
    violation: float  # largest violation over the objective's terms (K0), sharp model
    iterations: int
    objective_history: list[float]  # J at each iterate, sharp-model partition
    design_history: list[dict[str, float]]
    achievable: dict[str, list[float]]  # [min, max] of each share over the box's corners
    wall_time_s: float
    bracketing_steps: int = 0  # sharp evaluations spent by the bracketing safeguard
    # how the sharp collision(s) at `design` ended: settled (dissipation stopped) or not
    final_status: list[str] = dataclasses.field(default_factory=list)
    settled: bool = False
    # robust tuning only (a problem with Conditions): `fractions` is then the expected split
    conditions: list[dict[str, float]] | None = None  # each sample's v0, g and weight
    samples: list[dict[str, float]] | None = None  # each sample's sharp partition at `design`
    spread: dict[str, dict[str, float]] | None = None  # mean/std/min/max of each share

    def to_json(self) -> dict[str, Any]:
        robust = {}
        if self.samples is not None:
            robust = {
                "expected": True,
                "conditions": self.conditions,
                "samples": [
                    {**c, "fractions": {k: f[k] for k in m.FRACTION_KEYS}}
                    for c, f in zip(self.conditions, self.samples, strict=True)
                ],
                "spread": self.spread,
            }
        return {
            **self.design.as_floats(),
            "fractions": {k: self.fractions[k] for k in m.FRACTION_KEYS},
            "kinetic_split": {
                k: self.fractions[k] for k in ("kinetic_ring", "kinetic_block", "kinetic_beam")
            },
            "status": self.status,
            "message": self.message,
            "violation": self.violation,
            "iterations": self.iterations,
            "objective_history": self.objective_history,
            "design_history": self.design_history,
            "achievable": self.achievable,
            "wall_time_s": self.wall_time_s,
            "bracketing_steps": self.bracketing_steps,
            "final_status": self.final_status,
            "settled": self.settled,
            **robust,
        }


def progress_line(iteration: int, stage: Stage, design: Design, value, violation) -> str:
    variables = " ".join(f"{k}={v:.4f}" for k, v in design.as_floats().items())
    return (
        f"tune: it {iteration:3d}  s={stage.yield_smoothing:g} w={stage.contact_smoothing:g}  "
        f"{variables}  J={float(value):.3e}  worst miss={float(violation):.4f} K0"
    )


def _floats(fractions) -> dict[str, float]:
    return {k: float(v) for k, v in fractions.items()}


def achievable_range(problem: Problem, objective: Objective, box: Box) -> dict[str, list[float]]:
    """[min, max] of each share the objective names, sharp model, over the box's corners."""
    shares: dict[str, list[float]] = {s: [] for s in objective.structures()}
    for corner in box.corners():
        evaluation = evaluate(corner, problem, objective)
        check(evaluation, corner, problem.conditions)
        for s in shares:
            shares[s].append(float(share(evaluation.fractions, s)))
    return {s: [min(v), max(v)] for s, v in shares.items()}


def _terms_met(objective: Objective, fractions, tolerance: float) -> list[bool]:
    return [float(term.violation(fractions)) <= tolerance for term in objective.terms]


def _on_bound_pushing_out(unit: Design, grad_unit: Design) -> bool:
    """True if some variable sits on a bound and descent would take it outside the box."""
    leaves = jax.tree_util.tree_leaves
    for u, g in zip(leaves(unit), leaves(grad_unit), strict=True):
        if (float(u) <= 0.0 and float(g) > 0.0) or (float(u) >= 1.0 and float(g) < 0.0):
            return True
    return False


def tune(
    design: Design,
    problem: Problem,
    objective: Objective,
    *,
    box: Box | None = None,
    stages: tuple[Stage, ...] = DEFAULT_STAGES,
    mode: str = "forward",
    tolerance: float = 0.01,
    sharp_correction: bool = True,
    progress: Callable[[str], None] | None = None,
    bracket: int = 12,
    optimiser: Callable[[float], optax.GradientTransformation] = optax.adam,
) -> TuneResult:
    """Find a design whose *sharp-model* partition meets `objective` within `tolerance` (K0).

    **Arguments:**
    - `design`: the starting point (`Design`; its designed fields are what is tuned).
    - `problem`: the collision around it (`make_problem`, with the same `box`).
    - `objective`: the terms to meet (`objective(TargetShare(...), ShareAtMost(...))`).
    - `box`: bounds of the design (default `default_box(design)`).
    - `stages`: the annealing schedule (`Stage`s); `mode`: ``"forward"`` or ``"reverse"``. A
      stage with both smoothings zero and a learning rate is refused (`ValueError`): the sharp
      model's derivative is not a design gradient (`optimise.gradient`).
    - `tolerance`: how close (K0) the sharp partition must come to every term.
    - `sharp_correction`: take J and dJ/df from the sharp model (module docstring, step 2).
    - `progress`: called with one line per iteration (e.g. `print`); None (default): quiet.
    - `bracket`: sharp evaluations the bracketing safeguard may spend when the gradient steps
      end without meeting the target (`_bracket`; one design variable, one `TargetShare`); 0:
      none.
    - `optimiser`: an optax optimiser, called with each stage's learning rate (default
      `optax.adam`; e.g. ``optax.sgd`` or ``lambda lr: optax.chain(optax.clip(1.0),
      optax.adam(lr))``); it is restarted at every stage.

    With `Conditions` in `problem` (robust tuning) the objective is met by the expected sharp
    partition over the samples; `TuneResult.samples` and `.spread` say how each sample fares.
    """
    _check_stages(stages)
    start = time.perf_counter()
    box = default_box(design) if box is None else box
    objective = arrays(objective)
    unit = project(box.to_unit(as_arrays(design)))
    width = box.width()
    run = _Run(objective, tolerance, progress, problem)
    for stage in stages:
        step = optimiser(stage.learning_rate)
        state = step.init(unit)
        smoothing = dict(
            yield_smoothing=stage.yield_smoothing, contact_smoothing=stage.contact_smoothing
        )
        for _ in range(stage.iterations):
            point = box.from_unit(unit)
            sharp = run.record(point, evaluate(point, problem, objective), stage)
            if run.met:
                return _finish(run, problem, box, "converged", start)
            at = sharp.fractions if sharp_correction else None
            smoothed, grad = gradient(
                point, problem, objective, mode=mode, partition_at=at, **smoothing
            )
            check(smoothed, point, problem.conditions)
            grad_unit = jax.tree_util.tree_map(lambda g, w: g * w, grad, width)
            run.pushing_out = run.pushing_out + 1 if _on_bound_pushing_out(unit, grad_unit) else 0
            if run.pushing_out >= STALL:
                break  # held on a bound by the gradient: more iterations cannot help
            updates, state = step.update(grad_unit, state, unit)
            unit = project(optax.apply_updates(unit, updates))
        if run.pushing_out >= STALL:
            break
    else:
        point = box.from_unit(unit)
        run.record(point, evaluate(point, problem, objective), stages[-1])
        if run.met:
            return _finish(run, problem, box, "converged", start)
    for corner in box.corners():  # the sharp model at the corners: brackets and reachability
        evaluation = evaluate(corner, problem, objective)
        check(evaluation, corner, problem.conditions)
        run.seen.append((corner, _floats(evaluation.fractions)))
    if bracket and _bracket(run, problem, objective, bracket):
        return _finish(run, problem, box, "converged", start)
    reachable = run.reachable() and run.conflict() is None
    return _finish(run, problem, box, "not converged" if reachable else "unreachable", start)


def _check_stages(stages: tuple[Stage, ...]) -> None:
    """Refuse a stage that would take gradient steps on the sharp model's derivative."""
    if not stages:
        raise ValueError("stages must hold at least one Stage")
    for i, stage in enumerate(stages):
        if stage.learning_rate and is_sharp(stage.yield_smoothing, stage.contact_smoothing):
            raise ValueError(
                f"stages[{i}] has yield_smoothing = contact_smoothing = 0 and a learning rate: "
                "the sharp model's derivative is not a design gradient (optimise.gradient); "
                f"{SHARP_REMEDY}; tune already judges every design on the sharp model"
            )


def _bracket(run: _Run, problem: Problem, objective: Objective, budget: int) -> bool:
    """Safeguard for one design variable and one `TargetShare`: regula falsi on the sharp model.

    The gradient steps can stall where the sharp share jumps (a change of deformation mode) and
    the smoothed model's slope there points the wrong way. If two designs seen (iterates or box
    corners) have sharp shares on either side of the target, the Illinois variant of regula
    falsi shrinks that bracket with sharp evaluations only, up to `budget` of them. Returns
    True if the objective is then met.
    """
    targets = [t for t in objective.terms if isinstance(t, TargetShare)]
    names = list(run.seen[0][0].variables()) if run.seen else []
    if len(targets) != 1 or len(names) != 1:
        return False
    term, name = targets[0], names[0]
    target = float(term.target)
    points = sorted(
        (float(d.variables()[name]), float(share(f, term.structure)) - target) for d, f in run.seen
    )
    pairs = [(p, q) for p, q in zip(points, points[1:], strict=False) if p[1] * q[1] < 0]
    if not pairs:
        return False
    (a, fa), (b, fb) = min(pairs, key=lambda pq: abs(pq[0][1]) + abs(pq[1][1]))
    stage = Stage(0.0, 0.0, budget, 0.0)
    for _ in range(budget):
        x = (a * fb - b * fa) / (fb - fa)
        point = as_arrays(Design(**{name: x}))
        sharp = run.record(point, evaluate(point, problem, objective), stage)
        run.bracketed += 1
        if run.met:
            return True
        fx = float(share(sharp.fractions, term.structure)) - target
        if fx * fb < 0:
            a, fa = b, fb
        else:
            fa = fa / 2  # Illinois: halve the retained end's value, so it does not stall
        b, fb = x, fx
        if abs(b - a) < 1e-9 * max(1.0, abs(a)):
            break
    return False


# consecutive iterations on a bound with the gradient pointing out before tuning gives up
STALL = 3


class _Run:
    """Book-keeping of one tuning run: histories, the best design seen, progress lines."""

    def __init__(self, objective: Objective, tolerance: float, progress, problem: Problem):
        self.objective, self.tolerance, self.progress = objective, tolerance, progress
        self.conditions = problem.conditions
        self.history: list[float] = []
        self.designs: list[dict[str, float]] = []
        self.terms_met: list[list[bool]] = []
        self.best: tuple[float, Design, Any] | None = None
        self.met = False
        self.pushing_out = 0
        self.seen: list[tuple[Design, dict[str, float]]] = []  # sharp partitions, corners too
        self.bracketed = 0  # evaluations spent by the bracketing safeguard

    def unmet(self) -> list[int]:
        """Terms met by no design seen that (a target) do not lie between two shares seen."""
        out = []
        for i, term in enumerate(self.objective.terms):
            if any(float(term.violation(f)) <= self.tolerance for _, f in self.seen):
                continue
            if isinstance(term, TargetShare):
                shares = [float(share(f, term.structure)) for _, f in self.seen]
                if min(shares) <= float(term.target) <= max(shares):
                    continue
            out.append(i)
        return out

    def reachable(self) -> bool:
        """Whether every term was met by some design seen, or (a target) lies between two."""
        return not self.unmet()

    def conflict(self) -> tuple[int, int, list[float], list[dict[str, float]]] | None:
        """Two terms the sharp model never meets together, by the designs seen.

        (i, j, [min, max] of term j's share, designs) when some designs seen meet term i and
        none of them meets term j: where i holds, j fails (the combined goal is infeasible by
        that evidence, e.g. a beam-share target whose designs all put the ring above its
        limit). None when no such pair was seen.
        """
        terms, tolerance = self.objective.terms, self.tolerance
        for i, held in enumerate(terms):
            meeting = [(d, f) for d, f in self.seen if float(held.violation(f)) <= tolerance]
            if not meeting:
                continue
            for j, other in enumerate(terms):
                if j == i or any(float(other.violation(f)) <= tolerance for _, f in meeting):
                    continue
                shares = [float(share(f, other.structure)) for _, f in meeting]
                return i, j, [min(shares), max(shares)], [d.as_floats() for d, _ in meeting]
        return None

    def record(self, point: Design, sharp, stage: Stage):
        check(sharp, point, self.conditions)
        value = float(sharp.value)
        violation = float(self.objective.violation(sharp.fractions))
        self.history.append(value)
        self.designs.append(point.as_floats())
        self.terms_met.append(_terms_met(self.objective, sharp.fractions, self.tolerance))
        self.seen.append((point, _floats(sharp.fractions)))
        self.met = violation <= self.tolerance
        if self.best is None or self.met or value < self.best[0]:
            self.best = (value, point, sharp)
        if self.progress is not None:
            self.progress(progress_line(len(self.history), stage, point, value, violation))
        return sharp


def _why(run: _Run) -> str:
    """Which term cannot be met, by the sharp partitions of the designs seen."""
    terms = run.objective.terms
    unmet = run.unmet()
    if unmet:
        names = "; ".join(terms[i].describe() for i in unmet)
        return f"no design seen meets {names}, nor do the shares seen bracket it"
    i, j, (low, high), designs = run.conflict()
    where = ", ".join(f"{k} in [{min(d[k] for d in designs):.4f}, {max(d[k] for d in designs):.4f}]"
                      for k in designs[0])  # fmt: skip
    return (
        f"{terms[j].describe()} cannot be met together with {terms[i].describe()}: at the "
        f"{len(designs)} designs seen that meet the latter ({where}), the sharp model's "
        f"{terms[j].structure} share is in [{low:.4f}, {high:.4f}]"
    )


def _finish(run: _Run, problem: Problem, box: Box, status: str, start: float) -> TuneResult:
    """The result at the best design seen (the last one when converged)."""
    _, point, sharp = run.best
    objective, tolerance = run.objective, run.tolerance
    violation = float(objective.violation(sharp.fractions))
    achievable = achievable_range(problem, objective, box)
    ranges = ", ".join(f"{s} share in [{lo:.4f}, {hi:.4f}]" for s, (lo, hi) in achievable.items())
    variables = ", ".join(f"{k} = {v:.4f}" for k, v in point.as_floats().items())
    if status == "converged":
        message = (
            f"converged: {objective.describe()} met within {violation:.4f} <= {tolerance:g} K0 "
            f"by the sharp model at {variables}"
        )
        if run.bracketed:
            message += f" (after {run.bracketed} bracketing steps on the sharp model)"
    elif status == "unreachable":
        message = f"unreachable within the bounds: {objective.describe()}; " + _why(run)
        message += (
            f"; the best design seen ({variables}) misses by {violation:.4f} K0 (tolerance "
            f"{tolerance:g}); at the corners of the box the sharp model gives {ranges}"
        )
    else:
        several = len(objective.terms) > 1
        message = (
            f"not converged: {objective.describe()} missed by {violation:.4f} K0 at {variables} "
            f"after {len(run.history)} evaluations; "
            + (
                "each term was met (or a target bracketed) by some design seen, but no design "
                "seen met them together, and none seen shows that they conflict"
                if several
                else "the shares seen bracket the target, so it looks reachable (the sharp "
                "share may jump past it)"
            )
            + f" (at the corners: {ranges}); try another start or more iterations per stage"
        )
    robust = {}
    conditions = problem.conditions
    if conditions is not None:
        samples = {k: np.asarray(v) for k, v in sharp.samples.items()}
        shares = {s: np.asarray(share(samples, s)) for s in (*STRUCTURES, *objective.structures())}
        robust = dict(
            conditions=conditions.rows(),
            samples=[{k: float(v[i]) for k, v in samples.items()} for i in range(len(conditions))],
            spread=spread({**samples, **shares}, conditions.weights),
        )
        message += (
            f" (expected split over {len(conditions)} impact samples; "
            + ", ".join(
                f"{s} share per sample in [{robust['spread'][s]['min']:.4f}, "
                f"{robust['spread'][s]['max']:.4f}], std {robust['spread'][s]['std']:.4f}"
                for s in objective.structures()
            )
            + ")"
        )
    final = [m.RESULTS(int(c)).status for c in np.atleast_1d(np.asarray(sharp.result))]
    settled = all(c == m.RESULTS.settled for c in np.atleast_1d(np.asarray(sharp.result)))
    if not settled:
        unsettled, count = sum(status != "settled" for status in final), len(final)
        if count == 1:
            which = "the final collision did not settle"
        elif unsettled == count:
            which = f"none of the {count} final collisions settled"
        else:
            which = f"{unsettled} of the {count} final collisions did not settle"
        message += (
            f"; note: {which} (ended: {', '.join(sorted(set(final)))}): raise t_max "
            "(`--t-max`) so that the split is final"
        )
    return TuneResult(
        design=point,
        final_status=final,
        settled=bool(settled),
        status=status,
        message=message,
        fractions=_floats(sharp.fractions),
        violation=violation,
        iterations=len(run.history),
        objective_history=run.history,
        design_history=run.designs,
        achievable=achievable,
        wall_time_s=time.perf_counter() - start,
        bracketing_steps=run.bracketed,
        **robust,
    )


__all__ = ["DEFAULT_STAGES", "Stage", "TuneResult", "achievable_range", "tune"]
