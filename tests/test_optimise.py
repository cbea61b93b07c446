"""optimise (issue 4): gradients vs finite differences, forward vs reverse, tuning, CLI.

Every test uses one fixed configuration (the small mesh, a short run, one fixed dt), so the
session compiles one primal, one forward-mode and one reverse-mode program. The fixed dt
matters for the finite differences: msfd_jax holds the step out of the derivative, and a
design-dependent dt would add its own O(dt^2) variation to f(x + h) - f(x - h).
"""

import json

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


@pytest.fixture(scope="module")
def problem():
    box = o.default_box(o.Design(thickness_ratio=2.0))
    stiff = m.ring_on_beam(m.CollisionParams(thickness_ratio=5.0), SMALL_MESH)
    assert DT < 0.5 * float(m.critical_step(stiff))
    return o.make_problem(m.CollisionParams(), SMALL_MESH, SETTINGS, box)


def test_forward_gradient_matches_central_differences(problem):
    design = o.Design(thickness_ratio=2.0)
    evaluation, grad = o.gradient(design, problem, GOAL, mode="forward", **SMOOTH)
    fd = o.finite_difference(design, problem, GOAL, step=1e-3, **SMOOTH)
    assert int(evaluation.result) in (0, 1)
    g, f = float(grad.thickness_ratio), float(fd.thickness_ratio)
    assert abs(g) > 1e-3  # a real slope, not a vanishing one compared to noise
    # central differences err by O(h^2 f'''): measured 4e-5 relative at h = 1e-3
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
    record = json.loads(capsys.readouterr().out)
    assert code == 0 and record["status"] == "converged"
    assert {"thickness_ratio", "fractions", "iterations", "objective_history"} <= set(record)
    assert len(record["objective_history"]) == record["iterations"]
    beam = record["fractions"]["beam_bending"] + record["fractions"]["beam_axial"]
    assert abs(beam - 0.6) <= 0.01
    assert cli.main(["tune", "--json", "--no-cache"]) == cli.EXIT_USAGE  # no target given
    assert np.isfinite(record["thickness_ratio"])
