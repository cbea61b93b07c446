"""optimise (issue 4): gradients vs finite differences, forward vs reverse, tuning, robust
tuning over impact samples, CLI.

Every test uses one fixed configuration (the small mesh, a short run, one fixed dt), so the
session compiles one primal, one forward-mode and one reverse-mode program, and for the robust
tests one vmapped primal and one vmapped forward-mode program (two paired samples). The fixed dt
matters for the finite differences: msfd_jax holds the step out of the derivative, and a
design-dependent dt would add its own O(dt^2) variation to f(x + h) - f(x - h).
"""

import dataclasses
import inspect
import json
import types
import warnings

import jax.numpy as jnp
import numpy as np
import pytest
from conftest import SMALL_MESH

import msfd_jax as m
import optimise as o
from msfd_jax import cli

DT = 2.0e-4  # below 0.5 x the stability limit at the stiffest design of the box (h_b/h_r = 5)
SETTINGS = m.Settings(t_max=1.5, dt=DT, history_points=31, shape_times=(0.5,))
SMOOTH = dict(yield_smoothing=0.05, contact_smoothing=0.01)
GOAL = o.objective(o.TargetShare("beam", 0.6), o.ShareAtMost("ring", 0.3, weight=2.0))
# two impact conditions, paired: a slow light block and a fast heavy one
SAMPLES = dict(velocity=[0.7, 1.0], mass_ratio=[5.0, 20.0])


def strict_json(text: str):
    """json.loads that refuses NaN and Infinity (strict parsers do: RFC 8259)."""

    def refuse(constant):
        raise ValueError(f"not JSON: {constant}")

    return json.loads(text, parse_constant=refuse)


@pytest.fixture(scope="module")
def problem():
    box = o.default_box(o.Design(thickness_ratio=2.0))
    stiff = m.ring_on_beam(m.CollisionParams(thickness_ratio=5.0), SMALL_MESH)
    assert DT < 0.5 * float(m.critical_step(stiff))
    return o.make_problem(m.CollisionParams(), SMALL_MESH, SETTINGS, box)


@pytest.fixture(scope="module")
def robust_problem():
    box = o.default_box(o.Design(thickness_ratio=2.0))
    conditions = o.Conditions(**SAMPLES)
    return o.make_problem(m.CollisionParams(), SMALL_MESH, SETTINGS, box, conditions)


def test_forward_gradient_matches_central_differences(problem):
    design = o.Design(thickness_ratio=2.0)
    evaluation, grad = o.gradient(design, problem, GOAL, mode="forward", **SMOOTH)
    fd = o.finite_difference(design, problem, GOAL, step=3e-4, **SMOOTH)
    assert int(evaluation.result) in (0, 1)
    g, f = float(grad.thickness_ratio), float(fd.thickness_ratio)
    assert abs(g) > 1e-3  # a real slope, not a vanishing one compared to noise
    # central differences err by O(h^2 f'''): since issue 9's stiffer contact the map curves
    # more (1.9e-3 relative at h = 1e-3, 3.8e-4 at 3e-4, 1.5e-4 at 1e-4: converging to g)
    assert g == pytest.approx(f, rel=1e-3)
    # the value is the objective of the smoothed partition
    assert float(evaluation.value) == pytest.approx(float(GOAL(evaluation.fractions)), rel=1e-12)


def test_forward_equals_reverse(problem):
    design = o.Design(thickness_ratio=2.0)
    fwd_eval, fwd = o.gradient(design, problem, GOAL, mode="forward", **SMOOTH)
    rev_eval, rev = o.gradient(design, problem, GOAL, mode="reverse", **SMOOTH)
    # the same discrete map differentiated two ways: equal to rounding (measured 2e-12)
    assert float(fwd.thickness_ratio) == pytest.approx(float(rev.thickness_ratio), rel=1e-8)
    assert float(fwd_eval.value) == pytest.approx(float(rev_eval.value), rel=1e-10)


def test_objective_terms():
    f = {"beam_bending": jnp.asarray(0.5), "beam_axial": jnp.asarray(0.2)}
    f |= {"ring_bending": jnp.asarray(0.25), "ring_axial": jnp.asarray(0.0)}
    assert float(o.share(f, "beam")) == pytest.approx(0.7)
    assert float(o.ShareAtMost("ring", 0.3)(f)) == 0.0  # inside the limit: no pull at all
    assert float(o.ShareAtMost("ring", 0.2).violation(f)) == pytest.approx(0.05)
    assert float(o.ShareAtLeast("beam", 0.8).violation(f)) == pytest.approx(0.1)
    assert float(o.objective(o.TargetShare("beam", 0.6))(f)) == pytest.approx(0.01)
    with pytest.raises(ValueError, match="unknown structure"):
        o.TargetShare("bumper", 0.5)
    with pytest.raises(ValueError, match="must be below"):
        o.default_box(o.Design(thickness_ratio=1.0), thickness_ratio=(3.0, 2.0))
    unit = o.project(o.Design(thickness_ratio=jnp.asarray(1.7)))
    assert float(unit.thickness_ratio) == 1.0


def test_tuning_reaches_a_target_confirmed_by_the_sharp_model(problem):
    goal = o.objective(o.TargetShare("beam", 0.6))
    lines = []
    result = o.tune(
        o.Design(thickness_ratio=2.5), problem, goal, tolerance=0.01, progress=lines.append
    )
    assert result.status == "converged", result.message
    assert len(lines) == result.iterations and "thickness_ratio=" in lines[0]
    # independent sharp-model check at the found design (no smoothing anywhere)
    check = o.evaluate(result.design, problem, goal)
    beam = float(o.share(check.fractions, "beam"))
    assert abs(beam - 0.6) <= 0.01  # the tolerance tuning was asked for
    assert result.fractions["beam_bending"] == pytest.approx(float(check.fractions["beam_bending"]))
    lo, hi = result.achievable["beam"]
    assert lo < 0.6 < hi


def test_unreachable_target_is_reported(problem):
    # the small scene's beam share stays below ~0.78 over h_b/h_r in [0.5, 5]
    goal = o.objective(o.TargetShare("beam", 0.95))
    result = o.tune(o.Design(thickness_ratio=2.5), problem, goal, progress=None)
    assert result.status == "unreachable", result.message
    assert "unreachable" in result.message and "corners of the box" in result.message
    assert result.achievable["beam"][1] < 0.95 - 0.01
    assert result.violation > 0.01


def test_cli_tune_json(problem, capsys):
    args = ["tune", "--target-beam-share", "0.6", "--axial-constraint", "--json", "--quiet"]
    args += ["--ring-segments", "6", "--beam-contact-segments", "8", "--beam-outer-segments", "2"]
    args += ["--t-max", "1.5", "--dt", repr(DT), "--history-points", "31", "--shape-times", "0.5"]
    code = cli.main([*args, "--no-cache"])
    record = strict_json(capsys.readouterr().out)
    assert code == 0 and record["status"] == "converged"
    assert "si" not in record  # non-dimensional inputs: no SI thickness
    assert {"thickness_ratio", "fractions", "iterations", "objective_history"} <= set(record)
    assert len(record["objective_history"]) == record["iterations"]
    beam = record["fractions"]["beam_bending"] + record["fractions"]["beam_axial"]
    assert abs(beam - 0.6) <= 0.01
    assert cli.main(["tune", "--json", "--no-cache"]) == cli.EXIT_USAGE  # no target given
    assert np.isfinite(record["thickness_ratio"])
    assert record["final_status"] and record["settled"] == (record["final_status"] == ["settled"])


def test_tune_takes_an_optax_optimiser(problem):
    import optax

    rates = []

    def sgd(learning_rate):
        rates.append(learning_rate)
        return optax.sgd(learning_rate)

    stages = (o.Stage(0.05, 0.01, 1, 0.08), o.Stage(0.02, 0.004, 1, 0.04))
    goal = o.objective(o.TargetShare("beam", 0.95))  # unreachable: every stage runs
    result = o.tune(
        o.Design(thickness_ratio=2.5),
        problem,
        goal,
        stages=stages,
        optimiser=sgd,
        progress=None,
        bracket=0,
    )
    assert rates == [0.08, 0.04]
    assert result.final_status and isinstance(result.settled, bool)


def test_bracketing_safeguard_finds_a_target_without_gradient_steps(problem):
    # a learning rate of 0 keeps the design at its start: only the regula falsi on the sharp
    # model between the box corners can meet the target
    stages = (o.Stage(0.05, 0.01, 1, 0.0),)
    goal = o.objective(o.TargetShare("beam", 0.6))
    result = o.tune(o.Design(thickness_ratio=2.5), problem, goal, stages=stages, progress=None)
    assert result.status == "converged", result.message
    assert "bracketing" in result.message
    beam = float(o.share(o.evaluate(result.design, problem, goal).fractions, "beam"))
    assert abs(beam - 0.6) <= 0.01
    none = o.tune(o.Design(thickness_ratio=2.5), problem, goal, stages=stages, bracket=0)
    assert none.status == "not converged", none.message  # bracketed by the corners: reachable


def test_conditions_input():
    grid = o.Conditions.grid(velocity=[0.6, 1.0], mass_ratio=[5.0, 10.0, 20.0])
    assert len(grid) == 6 and float(jnp.sum(grid.weights)) == pytest.approx(1.0)
    assert grid.rows()[1] == {"velocity": 0.6, "mass_ratio": 10.0, "weight": pytest.approx(1 / 6)}
    with pytest.raises(ValueError, match="equal"):
        o.Conditions(velocity=[0.6, 1.0], mass_ratio=[5.0])
    with pytest.raises(ValueError):
        o.Conditions(velocity=[-1.0])  # outside CollisionParams' range
    with pytest.raises(ValueError, match="weights"):
        o.Conditions(velocity=[0.6, 1.0], weights=[1.0, -1.0])


def test_robust_objective_is_the_mean_of_single_runs(problem, robust_problem):
    design = o.Design(thickness_ratio=2.0)
    # smoothed: with the sharp (stiff, issue 9) contact the coarse mesh's ring chatters and
    # amplifies the rounding differences between a vmapped program and single runs (3e-4 K0
    # here); smoothed, the map is smooth and the two agree to rounding
    robust = o.evaluate(design, robust_problem, GOAL, **SMOOTH)
    assert robust.result.shape == (2,) and robust.samples["beam_bending"].shape == (2,)
    singles = []
    for v0, g in zip(SAMPLES["velocity"], SAMPLES["mass_ratio"], strict=True):
        params = dataclasses.replace(problem.params, velocity=v0, mass_ratio=g).as_arrays()
        single = o.evaluate(design, dataclasses.replace(problem, params=params), GOAL, **SMOOTH)
        singles.append({k: float(v) for k, v in single.fractions.items()})
    for key, value in robust.fractions.items():
        each = [s[key] for s in singles]
        # one vmapped program vs two single runs: equal to rounding (measured <= 1.1e-12)
        assert float(value) == pytest.approx(np.mean(each), abs=1e-10)
        assert np.asarray(robust.samples[key]) == pytest.approx(each, abs=1e-10)
    beams = [s["beam_bending"] + s["beam_axial"] for s in singles]
    assert abs(beams[0] - beams[1]) > 0.02  # the samples really differ
    assert float(robust.value) == pytest.approx(float(GOAL(robust.fractions)), rel=1e-12)


def test_robust_tuning_meets_the_expected_split_on_the_sharp_model(robust_problem):
    goal = o.objective(o.TargetShare("beam", 0.35))
    result = o.tune(o.Design(thickness_ratio=2.5), robust_problem, goal, progress=None)
    assert result.status == "converged", result.message
    check = o.evaluate(result.design, robust_problem, goal)  # sharp, vmapped, no smoothing
    expected = float(o.share(check.fractions, "beam"))
    assert abs(expected - 0.35) <= 0.01
    per_sample = np.asarray(o.share(check.samples, "beam"))
    assert np.mean(per_sample) == pytest.approx(expected, abs=1e-12)
    assert len(result.samples) == 2 and result.conditions[1]["mass_ratio"] == 20.0
    spread = result.spread["beam"]
    assert spread["min"] == pytest.approx(per_sample.min()) and spread["std"] > 0.01
    assert "2 impact samples" in result.message
    # t_max = 1.5 stops both samples early, and the note says so (it once read "the final
    # collision did not settle (settled, time limit)" over three samples)
    assert result.final_status == ["time limit", "time limit"] and not result.settled
    assert "note: none of the 2 final collisions settled (ended: time limit)" in result.message


def test_cli_robust_tune_json(robust_problem, capsys):
    args = ["tune", "--target-beam-share", "0.35", "--axial-constraint", "--json", "--quiet"]
    args += ["--velocity-samples", "0.7", "1.0", "--mass-samples", "5", "20", "--pair-samples"]
    args += ["--ring-segments", "6", "--beam-contact-segments", "8", "--beam-outer-segments", "2"]
    args += ["--t-max", "1.5", "--dt", repr(DT), "--history-points", "31", "--shape-times", "0.5"]
    code = cli.main([*args, "--no-cache"])
    record = strict_json(capsys.readouterr().out)
    assert code == 0 and record["status"] == "converged" and record["expected"]
    beams = [
        s["fractions"]["beam_bending"] + s["fractions"]["beam_axial"] for s in record["samples"]
    ]
    assert [s["velocity"] for s in record["samples"]] == [0.7, 1.0]
    beam = record["fractions"]["beam_bending"] + record["fractions"]["beam_axial"]
    assert beam == pytest.approx(np.mean(beams), abs=1e-12) and abs(beam - 0.35) <= 0.01
    bad = ["tune", "--target-beam-share", "0.35", "--velocity-samples", "0.7", "1.0"]
    bad += ["--mass-samples", "5", "--pair-samples", "--no-cache"]
    assert cli.main(bad) == cli.EXIT_USAGE  # unequal paired counts


def test_gradient_of_the_sharp_model_warns(problem):
    # the defaults differentiate the smoothed model (docs/tuning.md: the sharp model's
    # derivative is off by orders of magnitude against its own central differences)
    defaults = inspect.signature(o.gradient).parameters
    assert defaults["yield_smoothing"].default == o.DEFAULT_SMOOTHING["yield_smoothing"] > 0
    assert defaults["contact_smoothing"].default == o.DEFAULT_SMOOTHING["contact_smoothing"] > 0
    design = o.Design(thickness_ratio=2.0)
    with warnings.catch_warnings():  # as an error: raised before any solve
        warnings.simplefilter("error", o.SharpGradientWarning)
        with pytest.raises(o.SharpGradientWarning, match="yield_smoothing=0.05"):
            o.gradient(design, problem, GOAL, yield_smoothing=0.0, contact_smoothing=0.0)
        with pytest.raises(o.SharpGradientWarning, match="not a design gradient"):
            o.gradient(
                design, problem, GOAL, mode="reverse", yield_smoothing=0, contact_smoothing=0
            )
    # tune refuses a stage that would step on the sharp derivative, before compiling anything
    with pytest.raises(ValueError, match=r"stages\[1\].*contact_smoothing=0.01"):
        o.tune(design, problem, GOAL, stages=(o.Stage(0.05, 0.01, 1, 0.1), o.Stage(0, 0, 1, 0.1)))


def test_conflicting_terms_are_named():
    # the sharp partitions a tuning run saw: wherever the beam share meets 0.6, the ring
    # share is about 0.35 (the coarse mesh's README goal, docs/tuning.md): infeasible together
    from optimise._tune import _Run, _why

    goal = o.objective(o.TargetShare("beam", 0.6), o.ShareAtMost("ring", 0.3))
    run = _Run(goal, 0.01, None, types.SimpleNamespace(conditions=None))
    seen = [(0.5, 0.86, 0.12), (1.1, 0.605, 0.35), (1.12, 0.597, 0.36), (5.0, 0.08, 0.9)]
    for h, beam, ring in seen:
        fractions = {"beam_bending": beam, "beam_axial": 0.0}
        fractions |= {"ring_bending": ring, "ring_axial": 0.0}
        run.seen.append((o.Design(thickness_ratio=h), fractions))
    assert run.reachable()  # each term alone is met somewhere...
    i, j, (low, high), designs = run.conflict()  # ...but not together
    assert (i, j) == (0, 1) and (low, high) == (0.35, 0.36) and len(designs) == 2
    why = _why(run)
    assert why.startswith("ring share <= 0.3 cannot be met together with beam share = 0.6")
    assert "ring share is in [0.3500, 0.3600]" in why and "reachable" not in why
    run.seen[1] = (run.seen[1][0], {**run.seen[1][1], "ring_bending": 0.29})
    assert run.conflict() is None  # a design meeting both: no conflict


def test_docs_converging_tune_example_converges():
    # docs/tuning.md's converging example, as written there: coarse mesh, default settings
    mesh = m.Mesh(ring_segments=8, beam_contact_segments=10, beam_outer_segments=3)
    design = o.Design(thickness_ratio=2.5)
    problem = o.make_problem(
        m.CollisionParams(), mesh, m.Settings(t_max=4.0), o.default_box(design)
    )
    goal = o.objective(o.TargetShare("beam", 0.45), o.ShareAtMost("ring", 0.55))
    result = o.tune(design, problem, goal, tolerance=0.01)
    assert result.status == "converged", result.message
    check = o.evaluate(result.design, problem, goal)  # the sharp model, independently
    assert abs(float(o.share(check.fractions, "beam")) - 0.45) <= 0.01
    assert float(o.share(check.fractions, "ring")) <= 0.55 + 0.01


def test_cli_tune_si_reports_the_beam_thickness_in_mm(capsys):
    args = ["tune", "--si", "--impact-speed", "20", "--block-mass", "200", "--json", "--quiet"]
    args += ["--target-beam-share", "0.5", "--iterations", "1", "--no-cache"]
    args += ["--ring-segments", "6", "--beam-contact-segments", "8", "--beam-outer-segments", "2"]
    args += ["--t-max", "1.5", "--dt", repr(DT), "--history-points", "31", "--shape-times", "0.5"]
    code = cli.main(args)
    record = strict_json(capsys.readouterr().out)
    assert code in (cli.EXIT_OK, 4), record["message"]
    si = record["si"]
    ring_mm = 1e3 * m.PAPER_SI["ring_thickness"]  # the paper's h_r = 50 mm, not overridden
    assert si["ring_thickness_mm"] == pytest.approx(ring_mm, rel=1e-12)
    assert si["thickness_ratio"] == record["thickness_ratio"]
    assert si["beam_thickness_mm"] == pytest.approx(record["thickness_ratio"] * ring_mm, rel=1e-12)
    assert si["beam_thickness_bounds_mm"] == pytest.approx([0.5 * ring_mm, 5.0 * ring_mm])
    # the text report says the same in mm
    from optimise._cli import report
    from optimise._tune import TuneResult

    fields = {f.name for f in dataclasses.fields(TuneResult)}
    result = TuneResult(**{k: v for k, v in record.items() if k in fields and k != "design"},
                        design=o.Design(thickness_ratio=record["thickness_ratio"]))  # fmt: skip
    text = report(result, si)
    assert f"beam thickness h_b = {si['beam_thickness_mm']:.2f} mm" in text
