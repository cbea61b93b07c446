"""The paper's qualitative findings (Sect. 4) that the model supports, on the coarse mesh.

One vmapped sweep (one compiled program) of seven collisions; thresholds are stated with
their reasons below. Then the quick reproduction of Fig. 13-14 (`msfd reproduce --quick --only
fig13_14`), which gives the "U" to "W" finding. The full-mesh numbers are in
docs/results/reproduce/reproduce.md (`msfd reproduce`).
"""

import json

import numpy as np
import pytest
from conftest import SMALL_MESH

import msfd_jax as m

THICKNESS = (0.5, 2.5, 4.5)  # axially constrained, g = 10, v0 = 0.82 (Fig. 10b, 11)
ROWS = (
    [dict(thickness_ratio=h) for h in THICKNESS]
    + [
        dict(thickness_ratio=1.0, velocity=1.6, mass_ratio=g)
        for g in (5.0, 20.0)  # Fig. 16 mass
    ]
    + [dict(thickness_ratio=1.0, velocity=v) for v in (1.2, 2.0)]
)  # Fig. 16 velocity


@pytest.fixture(scope="module")
def table():
    # safety 0.0875 (an eighth of the default step): the contact dissipation compared below
    # converges only there on this coarse mesh. g = 5 / g = 20 at v0 = 1.6 (measured, issue 12):
    # 0.0893 / 0.0979 M_pr at safety 0.35 (two rows then rerun at half the step by the balance
    # retry, so the pair ran at different steps), 0.0893 / 0.0988 at 0.175, 0.0891 / 0.0888
    # (0.3 %) at 0.0875, where the balance closes to 2.3e-5 K0 and no row is rerun.
    settings = m.Settings(safety=0.0875, history_points=2, shape_times=())
    t = m.sweep(ROWS, SMALL_MESH, settings, chunk_size=len(ROWS), progress=False)
    assert set(t["status"]) == {"settled"}
    assert np.all(t["retries"] == 0)  # every row at the same step
    assert np.max(np.abs(t["energy_balance_error"])) < 1e-3
    return t


def _share(t, structure):
    return t[f"{structure}_bending"] + t[f"{structure}_axial"]


def test_the_less_stiff_structure_dissipates_more(table):
    # Fig. 10: with a thicker (stiffer) beam the beam's share falls and the ring's rises;
    # strict monotonicity over a factor 9 in thickness (measured: ring 0.02 -> 0.55 -> 0.83)
    beam, ring = _share(table, "beam")[:3], _share(table, "ring")[:3]
    assert np.all(np.diff(beam) < 0) and np.all(np.diff(ring) > 0)
    assert beam[0] > 0.9 and ring[-1] > 0.7  # each extreme is dominated by the softer one


def test_ring_axial_dissipation_is_negligible(table):
    # Fig. 11: "no energy is dissipated by the axial deformation of the ring"; 0.5 % of K0
    # allows the few-per-mille seen at twice the paper's velocity (measured <= 0.002)
    assert np.max(table["ring_axial"]) < 0.005


def test_beam_axial_dissipation_falls_with_thickness_under_constraint(table):
    # Fig. 11: beam axial dissipation decreases monotonically and vanishes by h_b/h_r ~ 3.5-4
    axial = table["beam_axial"][:3]
    assert np.all(np.diff(axial) < 0)
    assert axial[0] > 0.5 and axial[-1] < 0.01


def test_local_contact_dissipation_small_and_independent_of_the_attached_mass(table):
    # Fig. 16 / Sect. 4.3.2: the collision stage is local, so the contact dissipation depends
    # on v0 only. Same v0 = 1.6, g = 5 and 20: equal to 5 % (the paper mesh: 0.0 % spread over
    # g = 2-40, docs/results/reproduce/reproduce.md). On this coarse mesh the spread is a
    # step-size effect of the sharp re-contacts: 9.6 % at safety 0.35, 0.3 % at the fixture's
    # 0.0875 (see `table`); issue 11 had widened this tolerance to 8 % for it, issue 12
    # restores 5 % with the smaller step.
    absolute = table["contact"] * table["k0"]
    g5, g20 = absolute[3], absolute[4]
    assert g5 > 0.01 and g20 == pytest.approx(g5, rel=0.05)
    assert np.max(table["contact"]) < 0.05  # "a very small portion" of K0


def test_local_contact_dissipation_grows_with_velocity(table):
    # Fig. 16: it increases with v0 (measured 0, 0.036, 0.086 M_pr at v0 = 1.2, 1.6, 2.0; the
    # v0 = 1.6 point is the g = 5 run, the dissipation being independent of the mass)
    absolute = table["contact"] * table["k0"]
    v12, v16, v20 = absolute[5], absolute[3], absolute[6]
    assert v12 < v16 < v20 and v20 > 0.05


@pytest.fixture(scope="module")
def shapes_quick(tmp_path_factory):
    """The quick Fig. 13-14 reproduction (coarse mesh), written to a temporary directory."""
    from msfd_jax.studies.reproduce import run

    out = tmp_path_factory.mktemp("reproduce")
    (record,) = run(["fig13_14"], True, out / "figures", out, progress=False)
    return record, out


def test_quick_reproduction_writes_its_figures_and_report(shapes_quick):
    from msfd_jax.studies.reproduce import Reproduction

    record, out = shapes_quick
    assert isinstance(record, Reproduction) and record.key == "fig13_14"
    assert record.figures == ["fig13.png", "fig14.png"]
    for name in record.figures:
        assert (out / "figures" / name).stat().st_size > 10_000  # a drawn figure, not empty
    report = (out / "reproduce.md").read_text()
    assert "figures/fig13.png" in report and "Summary of findings" in report
    data = json.loads((out / "reproduce.json").read_text())
    assert data["quick"] and data["figures"][0]["key"] == "fig13_14"
    assert all(c["status"] == "settled" for c in record.numbers["cases"])


def test_the_final_ring_turns_from_u_to_w_as_the_beam_thickens(shapes_quick):
    # Sect. 4.2 / Fig. 14. Dimple depth w = (max_i y_i - y_apex)/R of the final ring
    # (msfd_jax/studies/reproduce/shapes.py); "U" below 0.1 h_r/R = 0.01 (a tenth of the ring's
    # thickness, node-level ripple of a flat bottom), "W" beyond h_r/R = 0.1 (the apex
    # pushed back by more than the ring's thickness); scales of the section, not fitted.
    # Coarse mesh, constrained, g = 10, v0 = 0.82; measured w = 0.000 (0.5, 1), 0.059 (2),
    # 0.40-0.53 (3-5); the paper mesh gives the same classes (docs/results/reproduce).
    record, _ = shapes_quick
    sweep = record.numbers["sweep"]
    h = np.array([r["thickness_ratio"] for r in sweep])
    w = np.array([r["dimple_depth"] for r in sweep])
    shapes = [r["shape"] for r in sweep]
    assert shapes[0] == "U" and shapes[-1] == "W"
    assert w[h == 1.0][0] < 0.01 < 0.1 < w[h >= 3.0].min()
    # the change is one-way: once the apex is pushed back it stays so for thicker beams
    assert np.all(np.diff(w) > -0.02)
    cases = {c["thickness_ratio"]: c["shape"] for c in record.numbers["cases"]}
    assert cases[1.0] == "U" and cases[2.5] == "W"  # Fig. 14a and Fig. 13


def _fig10_numbers(failed_free_first: bool) -> dict:
    """Fig. 10's numbers on four thicknesses, made up: the free beam's first run failed."""
    from msfd_jax.studies.reproduce import fig10

    thickness = np.array([0.25, 1.0, 3.0, 5.0])
    n = len(thickness)
    beam = np.array([0.6, 0.5, 0.3, 0.2])
    columns = {
        "beam_bending": np.tile(0.6 * beam, 2),
        "beam_axial": np.tile(np.array([0.2, 0.1, 0.004, 0.001]), 2),
        "ring_bending": np.tile(1.0 - beam, 2),
        "ring_axial": np.zeros(2 * n),
        "contact": np.full(2 * n, 0.001),
        "t_end": np.full(2 * n, 5.0),
        "status": np.array(["settled"] * 2 * n, dtype="U40"),
    }
    if failed_free_first:  # where it stopped: a share no run that succeeded has
        columns["status"][0] = m.RESULTS.energy_balance_broken.status
        columns["beam_bending"][0] = columns["ring_bending"][0] = 0.01
    table = m.SweepTable(columns)
    return {"thickness_ratio": thickness, **fig10.shares(table, n)}


def test_fig10_leaves_failed_runs_out_of_the_figure_and_the_findings(tmp_path):
    from msfd_jax.studies.reproduce import fig10

    clean, failed = _fig10_numbers(False), _fig10_numbers(True)
    assert failed["free"]["ok"].tolist() == [False, True, True, True]
    findings = fig10.judge_fig10(failed)
    # the made-up failed run would have reversed the free beam's trend: it is not used
    assert [f.agree for f in findings] == [f.agree for f in fig10.judge_fig10(clean)]
    assert "failed, left out: h_b/h_r = 0.25" in findings[0].ours
    assert "not data" in fig10.table_fig10(failed)
    [name] = fig10.draw_fig10(failed, tmp_path)
    assert (tmp_path / name).exists()
    from matplotlib.figure import Figure

    ax = Figure().subplots()
    r = failed["free"]
    from msfd_jax.studies.reproduce import _batch as b

    b.plot_runs(ax, failed["thickness_ratio"], r["beam"], r["ok"], "o-", label="beam")
    b.mark_failed(ax, failed["thickness_ratio"], r["ok"], r["status"])
    line, cross = ax.get_lines()
    assert np.isnan(line.get_ydata()[0]) and list(cross.get_xdata()) == [0.25]
    assert "failed" in cross.get_label()


def test_fig16_onset_text_never_says_nan():
    from msfd_jax.studies.reproduce.contact import _onset_text

    assert _onset_text(float("nan"), 0.4).startswith("non-zero at every v0 swept")
    assert _onset_text(0.3, 0.4) == "zero for v0 <= 0.3, non-zero from v0 = 0.4"
    assert "nan" not in _onset_text(float("nan"), float("nan"))


def test_fig23_with_one_run_below_k0_4_is_not_judged():
    """One run below K0 = 4 cannot show a rise there: not comparable, not a disagreement."""
    from msfd_jax.studies.reproduce.mass_velocity import judge_fig23_24

    ring = np.array([0.13, 0.22, 0.2, 0.1])
    one_below = {"k0": np.array([3.89, 8.33, 14.8, 23.1]), "ring": ring}
    two_below = {"k0": np.array([1.2, 3.89, 12.3, 24.1]), "ring": ring}
    findings = judge_fig23_24({"mass": two_below, "velocity": one_below})
    fig23 = [f.agree for f in findings if f.figure == "Fig. 23"]
    assert fig23 == [True, None]


def test_fig16_quick_run_does_not_judge_the_step_bound_mass_spread():
    from msfd_jax.studies.reproduce import contact

    velocity = np.array([0.5, 0.82, 1.6, 2.0, 0.82, 1.6])
    mass = np.array([10.0, 10.0, 10.0, 10.0, 20.0, 20.0])
    absolute = np.array([0.01, 0.02, 0.089, 0.18, 0.02, 0.099])  # 10 % spread at v0 = 1.6
    numbers = {
        "k0": np.ones(6),
        "velocity": velocity,
        "mass_ratio": mass,
        "contact": absolute,
        "contact_absolute": absolute,
        "series": {
            "velocity (g = 10)": np.arange(4),
            "mass (v0 = 0.82)": np.array([1, 4]),
            "mass (v0 = 1.6)": np.array([2, 5]),
        },
        "onset_velocity": [float("nan"), 0.5],
        "two_mass": {"peak": 100.0, "f_y": 50.0, "onset_velocity": 0.4},
    }
    full = contact.judge_fig16({**numbers, "quick": False})
    quick = contact.judge_fig16({**numbers, "quick": True})
    assert full[1].agree is False and quick[1].agree is None
    assert "step" in quick[1].reason
    assert all("nan" not in f.ours for f in quick)
