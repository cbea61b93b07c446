"""Graded beams around the model (issue 30 item 1): ``msfd run --thickness-profile``, case
files, ``--from-json``, and sweeps of profiles (`msfd_jax.sweep`).

Every run uses conftest's SMALL_MESH (10 beam segments) and SHORT settings with the contact
smoothed (COMPARE_SMOOTHING: no retries, and a batch agrees with single runs to rounding), so
the file compiles four programs: a graded single run (shared by the CLI and `m.run`), a graded
and a uniform sweep, and the sweep's beam mass ratios. The refusals compile nothing.
"""

import contextlib
import io
import json

import numpy as np
import pytest
from conftest import COMPARE_SMOOTHING, SHORT, SMALL_MESH

import msfd_jax as m
from msfd_jax._sweeps.sweep import INPUTS, OUTPUTS, collisions
from msfd_jax.cli import main
from msfd_jax.cli.run import mass_ratio, with_mass_ratio

SMALL = [
    "--ring-segments=6",
    "--beam-contact-segments=8",
    "--beam-outer-segments=2",
    "--t-max=1.5",
    "--history-points=31",
    "--shape-times=0.5",
    f"--contact-smoothing={COMPARE_SMOOTHING}",
    "--no-cache",
]
SEGMENTS = m.beam_segments(SMALL_MESH)  # 8 + 2
EQUAL = [2.5] * SEGMENTS
STEP = [2.0] * (SEGMENTS // 2) + [3.0] * (SEGMENTS - SEGMENTS // 2)
TEXT = ",".join(map(str, STEP))
CASE = f"""
[collision]
thickness_profile = {STEP}

[mesh]
ring_segments = 6
beam_contact_segments = 8
beam_outer_segments = 2

[settings]
t_max = 1.5
history_points = 31
shape_times = [0.5]
contact_smoothing = {COMPARE_SMOOTHING}
no_cache = true
"""


def call(*argv: str) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(list(argv))
    return code, out.getvalue(), err.getvalue()


def record_of(*argv: str) -> dict:
    code, out, err = call(*argv)
    assert code == 0, err
    lines = out.splitlines()
    assert len(lines) == 1, out  # one JSON object, nothing else
    return json.loads(lines[0])


@pytest.fixture(scope="module")
def graded_record():
    return record_of("run", *SMALL, "--thickness-profile", TEXT, "--json")


# --- refusals: exit code 2, the parameter, the count and the range named; nothing compiled


@pytest.mark.parametrize(
    "args, words",
    [
        (["--thickness-profile", "2,2,2"], ["thickness_profile", "3 values", "10 segments"]),
        (["--thickness-profile", "2,2,2", "--si"], ["thickness_profile", "10 segments"]),
        (
            ["--thickness-profile", "2,2,2", "--si", "--impact-speed", "20"],
            ["thickness_profile", "10 segments", "(0, 100]"],
        ),
        (["--thickness-profile", "2,2,2", "--beam-outer-segments=5"], ["13 segments"]),
        (["--thickness-profile", "2,2,2,2,0,3,3,3,3,3"], ["thickness_profile", "(0, 100]"]),
        (["--thickness-profile=-2,2,2,2,2,3,3,3,3,3"], ["thickness_profile", "-2", "(0, 100]"]),
        (["--thickness-profile", "2,2,2,2,2,300,3,3,3,3"], ["thickness_profile", "300"]),
        (["--thickness-profile", "2,2,2,2,2,nan,3,3,3,3"], ["thickness_profile", "nan"]),
        (["--thickness-profile", "2,,3"], ["--thickness-profile", "t0,t1"]),
        (["--thickness-profile", "thick"], ["--thickness-profile", "t0,t1"]),
    ],
)
def test_bad_profiles_exit_2_naming_the_parameter(args, words):
    code, out, err = call("run", *SMALL, *args)
    assert code == 2
    assert out == "" and "Traceback" not in err
    assert "--thickness-profile" in err  # the option (argparse's or `name_the_option`'s)
    for word in words:
        assert word in err, (word, err)


def test_bad_profile_with_json_prints_a_failure_record():
    code, out, err = call("run", *SMALL, "--thickness-profile", "2,2,2", "--json")
    assert code == 2
    record = json.loads(out)
    assert record["ok"] is False and record["status"] == "bad input"
    assert "thickness_profile has 3 values" in record["message"]
    assert "(0, 100]" in record["message"]


@pytest.mark.parametrize(
    "value, words",
    [
        ("[2.0, 3.0]", ["thickness_profile has 2 values", "10 segments", "(0, 100]"]),
        (f"{[*STEP[:-1], -1.0]}", ["thickness_profile", "-1", "(0, 100]"]),
        ('["a", "b"]', ["[collision] thickness_profile", "t0,t1"]),
        ("[]", ["[collision] thickness_profile"]),
        ("true", ["[collision] thickness_profile"]),
    ],
)
def test_bad_profiles_in_a_case_file_exit_2(tmp_path, value, words):
    case = tmp_path / "case.toml"
    case.write_text(CASE.replace(f"thickness_profile = {STEP}", f"thickness_profile = {value}"))
    code, out, err = call("run", str(case))
    assert code == 2 and out == "" and "Traceback" not in err
    for word in words:
        assert word in err, (word, err)


@pytest.mark.parametrize(
    "profile, words",
    [
        ([STEP, STEP], ["thickness_profile must be one list", "2 dimensions"]),
        ([2.0, "abc"], ["thickness_profile", "real number"]),
        ("abc", ["--from-json", "params.thickness_profile must be a list"]),
        (2.5, ["--from-json", "params.thickness_profile must be a list"]),
    ],
)
def test_from_json_refuses_a_profile_that_is_not_one_list(tmp_path, profile, words):
    path = tmp_path / "out.json"
    path.write_text(json.dumps({"params": {"thickness_profile": profile}}))
    code, out, err = call("run", *SMALL, "--from-json", str(path))
    assert code == 2 and out == "" and "Traceback" not in err
    for word in words:
        assert word in err, (word, err)


def test_help_says_the_profile_is_in_ring_thicknesses_with_si():
    code, out, _ = call("run", "--help")
    assert code == 0
    text = " ".join(out.split())
    assert "--thickness-profile T0,T1,..." in text
    assert "also with --si" in text and "beam_mass_ratio" in text


def test_a_uniform_record_stays_as_it_was():
    assert mass_ratio(m.CollisionParams(), SMALL_MESH) is None
    record = {"ok": True, "params": {"thickness_ratio": 2.5}, "mesh": {}}
    assert with_mass_ratio(record, None) is record
    assert list(with_mass_ratio(record, 0.9)) == ["ok", "params", "beam_mass_ratio", "mesh"]


# --- graded runs: the record, the table, case files, --from-json, SI


def test_json_records_the_profile_and_the_beam_mass_ratio(graded_record):
    record = graded_record
    assert record["ok"] is True
    assert record["params"]["thickness_profile"] == STEP
    assert record["params"]["thickness_ratio"] == 2.5  # the uniform reference
    keys = list(record)
    assert keys.index("beam_mass_ratio") == keys.index("params") + 1
    params = m.CollisionParams(thickness_profile=STEP)
    expected = float(m.beam_mass_ratio(params, SMALL_MESH))
    assert record["beam_mass_ratio"] == pytest.approx(expected, rel=1e-15)
    # segments of OC are 2/8 long, of CE 1/2: (8 x 0.25 x t_k + 2 x 0.5 x 3) / (2.5 x 3)
    assert expected == pytest.approx((0.25 * (5 * 2.0 + 3 * 3.0) + 0.5 * 6.0) / 7.5, rel=1e-12)
    single = m.run(params, SMALL_MESH, SHORT, contact_smoothing=COMPARE_SMOOTHING).to_json()
    assert record["steps"] == single["steps"]
    assert record["fractions"] == single["fractions"]


def test_table_shows_the_profile_and_the_beam_mass_ratio(graded_record):
    code, out, err = call("run", *SMALL, "--thickness-profile", TEXT)
    assert code == 0, err
    assert "h_b/h_r = graded (uniform reference 2.5)" in out
    assert f"h_k/h_r = {', '.join(f'{v:g}' for v in STEP)} (10 segments, O to E)" in out
    assert f"beam_mass_ratio       {graded_record['beam_mass_ratio']:.6g}" in out


def test_case_file_profile_equals_the_command_line(tmp_path, graded_record):
    case = tmp_path / "case.toml"
    case.write_text(CASE)
    record = record_of("run", str(case), "--json")
    assert record["params"] == graded_record["params"]
    assert record["mesh"] == graded_record["mesh"]
    assert record["beam_mass_ratio"] == graded_record["beam_mass_ratio"]
    assert record["steps"] == graded_record["steps"]
    assert record["fractions"] == graded_record["fractions"]
    # the command line overrides the case file
    again = record_of("run", str(case), "--thickness-profile", ",".join(["2.5"] * 10), "--json")
    assert again["params"]["thickness_profile"] == EQUAL
    assert again["beam_mass_ratio"] == pytest.approx(1.0, rel=1e-15)


def test_from_json_reruns_the_graded_collision(tmp_path, graded_record):
    path = tmp_path / "out.json"
    path.write_text(json.dumps(graded_record))
    record = record_of("run", "--from-json", str(path), "--no-cache", "--json")
    assert record["params"] == graded_record["params"]
    assert record["fractions"] == graded_record["fractions"]


def test_si_run_takes_the_profile_in_ring_thicknesses(tmp_path):
    argv = ["run", *SMALL, "--si", "--impact-speed", "20", "--thickness-profile", TEXT, "--json"]
    record = record_of(*argv)
    assert record["si_inputs"]["impact_speed"] == 20.0
    assert record["params"]["thickness_profile"] == STEP  # h_k/h_r, not metres
    assert record["params"]["thickness_ratio"] == pytest.approx(2.5)  # 0.125 m / 0.05 m
    assert record["beam_mass_ratio"] == pytest.approx(
        float(m.beam_mass_ratio(m.CollisionParams(thickness_profile=STEP), SMALL_MESH))
    )
    assert "peak_beam_deflection_m" in record["si"]
    path = tmp_path / "si.json"
    path.write_text(json.dumps(record))  # an SI record keeps its profile on a rerun
    again = record_of("run", "--from-json", str(path), "--no-cache", "--json")
    assert again["params"] == record["params"] and again["si_inputs"] == record["si_inputs"]
    assert again["fractions"] == record["fractions"]


# --- sweeps of graded beams


@pytest.fixture(scope="module")
def graded_sweep(tmp_path_factory):
    """[equal profile, two-step profile, uniform (given the equal profile)] in one sweep,
    its rows written to a CSV store as they finish."""
    rows = [
        {"thickness_profile": EQUAL},
        {"thickness_profile": STEP, "velocity": 0.7},
        {"thickness_ratio": 2.0},
    ]
    path = tmp_path_factory.mktemp("graded") / "rows.csv"
    table = m.sweep(
        rows, SMALL_MESH, SHORT, contact_smoothing=COMPARE_SMOOTHING, output=path, workers=1
    )
    return rows, table, path


@pytest.fixture(scope="module")
def uniform_sweep():
    rows = [{"thickness_ratio": 2.5}, {"thickness_ratio": 2.0}]
    return m.sweep(rows, SMALL_MESH, SHORT, contact_smoothing=COMPARE_SMOOTHING, workers=1)


COMPARED = (*m.FRACTION_KEYS, "energy_balance_error", "t_end", "dt", "dt_critical", "k0")


def test_a_sweep_without_profiles_has_no_new_column(uniform_sweep):
    assert set(uniform_sweep.keys()) == {*INPUTS, *OUTPUTS}
    assert uniform_sweep.profile is None
    assert "thickness_profile" not in INPUTS
    columns, _ = collisions([{"thickness_ratio": 2.0}, {"velocity": 0.5}])
    assert set(columns) == set(INPUTS)


def test_sweep_table_carries_the_profiles_and_mass_ratios(graded_sweep):
    _, table, _ = graded_sweep
    names = [f"thickness_profile_{k}" for k in range(SEGMENTS)]
    assert set(table.keys()) == {*INPUTS, *names, "beam_mass_ratio", *OUTPUTS}
    np.testing.assert_array_equal(table["thickness_profile"], [EQUAL, STEP, [2.0] * SEGMENTS])
    expected = float(m.beam_mass_ratio(m.CollisionParams(thickness_profile=STEP), SMALL_MESH))
    np.testing.assert_allclose(table["beam_mass_ratio"], [1.0, expected, 1.0], rtol=1e-14)
    assert (table["status"] != "").all() and not table.failed.any()


def test_graded_sweep_rows_equal_single_runs(graded_sweep):
    rows, table, _ = graded_sweep
    for i, row in enumerate(rows[:2]):
        params = m.CollisionParams(**row)
        single = m.run(params, SMALL_MESH, SHORT, contact_smoothing=COMPARE_SMOOTHING).to_json()
        assert table["steps"][i] == single["steps"]
        assert table["retries"][i] == single["retries"] == 0
        assert table["velocity"][i] == params.velocity
        for key, value in single["fractions"].items():
            assert table[key][i] == pytest.approx(value, rel=1e-12, abs=1e-12), key
        for key in ("t_end", "dt", "dt_critical", "k0"):
            assert table[key][i] == pytest.approx(single[key], rel=1e-12), key


def test_an_equal_profile_gives_the_uniform_row(graded_sweep, uniform_sweep):
    _, graded, _ = graded_sweep
    for g, u in ((0, 0), (2, 1)):  # equal 2.5 profile; uniform 2.0 given its equal profile
        assert graded["steps"][g] == uniform_sweep["steps"][u]
        assert graded["status"][g] == uniform_sweep["status"][u]
        for key in COMPARED:
            assert graded[key][g] == pytest.approx(uniform_sweep[key][u], rel=1e-12, abs=1e-12)


def test_graded_rows_round_trip_and_resume(graded_sweep):
    rows, table, path = graded_sweep
    back = m.SweepTable.read_csv(path)
    assert list(back.keys()) == list(table.keys())
    np.testing.assert_array_equal(back["thickness_profile"], table["thickness_profile"])
    np.testing.assert_array_equal(back["beam_mass_ratio"], table["beam_mass_ratio"])
    assert len(table.rows()[1]) == len(table.keys())
    resumed = m.sweep(
        rows, SMALL_MESH, SHORT, contact_smoothing=COMPARE_SMOOTHING, output=path, resume=True
    )
    assert not resumed.computed.any()  # every row matched by its inputs, profile included
    for key in ("steps", *m.FRACTION_KEYS, "beam_mass_ratio"):
        np.testing.assert_array_equal(resumed[key], table[key], err_msg=key)


def test_a_grid_takes_one_profile_from_base():
    base = m.CollisionParams(thickness_profile=STEP)
    columns, grid = collisions({"velocity": [0.5, 0.8]}, base)
    assert list(grid) == ["velocity"]
    np.testing.assert_array_equal(columns["thickness_profile"], [STEP, STEP])


@pytest.mark.parametrize(
    "sweep, words",
    [
        ({"thickness_profile": [EQUAL, STEP]}, ["cannot be a grid axis", "base="]),
        (
            [{"thickness_profile": EQUAL}, {"thickness_profile": [2.5] * 25}],
            ["collision 0 has 10", "collision 1 has 25"],
        ),
        ([{"thickness_profile": [2.5] * 25}], ["thickness_profile has 25 values", "10 segments"]),
        ([{"thickness_profile": [*STEP[:-1], 0.0]}], ["thickness_profile", "(0, 100]"]),
        ([{"thickness_profile": [EQUAL]}], ["collision 0", "one list"]),
        ([{"thickness_profile": "thick"}], ["collision 0", "real numbers"]),
    ],
)
def test_bad_profiles_in_a_sweep_are_refused(sweep, words):
    with pytest.raises((ValueError, TypeError)) as error:
        m.sweep(sweep, SMALL_MESH, SHORT)
    for word in words:
        assert word in str(error.value), (word, str(error.value))
